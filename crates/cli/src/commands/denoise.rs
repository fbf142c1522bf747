//! `normalnet denoise IN OUT`: denoises a mesh with NormalNet (the default,
//! SPEC §7) or a classical method of `normalnet_filters` (SPEC §4, §9), writes
//! the result atomically with the input's vertex and face order, and prints
//! timings (the denoising call alone and the whole command), the parameters
//! and, with `--gt`, the error metrics (SPEC §3).
//!
//! Method parameters are optional flags; an absent flag keeps the default of
//! the method's params struct (`GnfParams::default()`, ...), which is also
//! what `--help` shows. A flag that does not apply to the chosen method is an
//! error rather than silently ignored.
//!
//! Outlier vertices (issue 14, `normalnet_mesh::outliers`) are warned about
//! on reading; every method, NormalNet included, leaves them and their
//! faces out of the denoising and in place, and `--remove-outliers` drops
//! them (and their faces) from the output instead.

use super::denoise_normalnet::{self, NormalnetOptions};
use crate::input::read_mesh;
use crate::output;
use crate::progress::Bar;
use anyhow::{Context, bail};
use normalnet_filters::{
    BiParams, BnfParams, GnfParams, GtGuidedGnfParams, L0Params, Method, Sun07Params, VtParams,
    gt_guided_gnf,
};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::metrics::compare;
use normalnet_mesh::outliers::{OutlierParams, denoise_around, outlier_vertices, without_vertices};
use normalnet_mesh::{Mesh, write_mesh};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// The denoising methods of `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodName {
    /// NormalNet (learned normal filtering, SPEC §7)
    Normalnet,
    /// guided mesh normal filtering (Zhang et al. 2015)
    Gnf,
    /// GNF guided by ground-truth normals (needs --gt; the oracle)
    GtGnf,
    /// bilateral normal filtering, local scheme (Zheng et al. 2011)
    Bnf,
    /// fast and effective feature-preserving denoising (Sun et al. 2007)
    Sun07,
    /// L0 minimisation (He & Schaefer 2013)
    L0,
    /// bi-normal filtering, core scheme (Wei et al. 2015)
    Bi,
    /// normal voting tensor + binary optimisation (Yadav et al. 2018)
    Vt,
}

fn help_iterations() -> String {
    format!(
        "Normal-filtering iterations N_f [defaults: normalnet 10, gnf {}, gt-gnf {}, bnf {}, sun07 {}, bi {}, vt {}]",
        GnfParams::default().normal_iterations,
        GtGuidedGnfParams::default().iterations,
        BnfParams::default().normal_iterations,
        Sun07Params::default().normal_iterations,
        BiParams::default().normal_iterations,
        VtParams::default().normal_iterations
    )
}

fn help_vertex_iterations() -> String {
    format!(
        "Vertex-update passes N_v (per iteration for normalnet/gnf/gt-gnf/bi/vt, after all normal passes for bnf/sun07) \
         [defaults: normalnet 20, gnf {}, gt-gnf {}, bnf {}, sun07 {}, bi {}, vt {}]",
        GnfParams::default().vertex_iterations,
        GtGuidedGnfParams::default().vertex_iterations,
        BnfParams::default().vertex_iterations,
        Sun07Params::default().vertex_iterations,
        BiParams::default().vertex_iterations,
        VtParams::default().vertex_iterations
    )
}

fn help_mu_g() -> String {
    format!(
        "μ_g (σ_r of GNF): width of the guidance range kernel [defaults: normalnet 0.35 (nearest trained output), \
         gnf {}, gt-gnf {}]",
        GnfParams::default().mu_g,
        GtGuidedGnfParams::default().mu_g
    )
}

fn help_sigma_s() -> String {
    format!(
        "Spatial kernel width σ_s in units of the mean centre distance d_s [defaults: gnf {}, gt-gnf {}, bnf {}, bi {}]",
        GnfParams::default().sigma_s_over_ds,
        GtGuidedGnfParams::default().sigma_s_over_ds,
        BnfParams::default().sigma_s_over_ds,
        BiParams::default().sigma_s_over_ds
    )
}

fn help_radius() -> String {
    format!(
        "Neighbourhood radius: gnf in units of d_s, vt (r) in units of the mean edge length l_e \
         [defaults: gnf {}, vt {}]",
        GnfParams::default().radius_over_ds,
        VtParams::default().radius_over_le
    )
}

fn help_sigma_r() -> String {
    format!(
        "σ_r: range kernel width on normal differences (bnf) or on the vertex-normal guidance (bi) \
         [defaults: bnf {}, bi {}]",
        BnfParams::default().sigma_r,
        BiParams::default().sigma_r
    )
}

fn help_sigma_n() -> String {
    format!(
        "BI σ_n: width of the kernel keeping a corner's vertex normal on its side of a feature [default: {}]",
        BiParams::default().sigma_n
    )
}

fn help_rho() -> String {
    format!(
        "VT ρ: a neighbour votes only if n_i·n_j ≥ ρ [default: {}]",
        VtParams::default().rho
    )
}

fn help_tau() -> String {
    format!(
        "VT τ: binary-optimisation threshold on the normalised eigenvalues [default: {}]",
        VtParams::default().tau
    )
}

fn help_threshold() -> String {
    format!(
        "Sun07 threshold T on n_i·n_j [default: {}]",
        Sun07Params::default().threshold
    )
}

fn help_lambda() -> String {
    format!(
        "L0 λ in units of l_e² (mean edge length squared) [default: {}]",
        L0Params::default().lambda_over_le2
    )
}

fn help_kappa() -> String {
    format!(
        "L0 κ: growth of β per iteration [default: {}]",
        L0Params::default().kappa
    )
}

fn help_beta0() -> String {
    format!("L0 β_0: initial β [default: {}]", L0Params::default().beta0)
}

fn help_beta_max() -> String {
    format!(
        "L0 β_max: stop once β exceeds it [default: {}]",
        L0Params::default().beta_max
    )
}

fn help_alpha0() -> String {
    format!(
        "L0 α_0 in units of the mean dihedral angle γ̄ [default: {}]",
        L0Params::default().alpha0_over_gamma
    )
}

fn help_alpha_decay() -> String {
    format!(
        "L0 μ_α: decay of α per iteration [default: {}]",
        L0Params::default().alpha_decay
    )
}

/// Arguments of `normalnet denoise`.
#[derive(clap::Args)]
pub struct Args {
    /// Noisy input mesh (.obj, .off, .ply, .stl).
    pub input: PathBuf,
    /// Output mesh (format from the extension; written atomically).
    pub output: PathBuf,
    /// Denoising method.
    #[arg(long, short, value_enum, default_value_t = MethodName::Normalnet)]
    pub method: MethodName,
    /// N_f.
    #[arg(long, help = help_iterations())]
    pub iterations: Option<usize>,
    /// N_v.
    #[arg(long, help = help_vertex_iterations())]
    pub vertex_iterations: Option<usize>,
    /// μ_g.
    #[arg(long, allow_negative_numbers = true, help = help_mu_g())]
    pub mu_g: Option<f64>,
    /// σ_s / d_s.
    #[arg(long, allow_negative_numbers = true, help = help_sigma_s())]
    pub sigma_s: Option<f64>,
    /// GNF radius / d_s.
    #[arg(long, allow_negative_numbers = true, help = help_radius())]
    pub radius: Option<f64>,
    /// BNF/BI σ_r.
    #[arg(long, allow_negative_numbers = true, help = help_sigma_r())]
    pub sigma_r: Option<f64>,
    /// BI σ_n.
    #[arg(long, allow_negative_numbers = true, help = help_sigma_n())]
    pub sigma_n: Option<f64>,
    /// VT ρ.
    #[arg(long, allow_negative_numbers = true, help = help_rho())]
    pub rho: Option<f64>,
    /// VT τ.
    #[arg(long, allow_negative_numbers = true, help = help_tau())]
    pub tau: Option<f64>,
    /// Sun07 T.
    #[arg(long, allow_negative_numbers = true, help = help_threshold())]
    pub threshold: Option<f64>,
    /// L0 λ / l_e².
    #[arg(long, allow_negative_numbers = true, help = help_lambda())]
    pub lambda: Option<f64>,
    /// L0 κ.
    #[arg(long, allow_negative_numbers = true, help = help_kappa())]
    pub kappa: Option<f64>,
    /// L0 β_0.
    #[arg(long, allow_negative_numbers = true, help = help_beta0())]
    pub beta0: Option<f64>,
    /// L0 β_max.
    #[arg(long, allow_negative_numbers = true, help = help_beta_max())]
    pub beta_max: Option<f64>,
    /// L0 α_0 / γ̄.
    #[arg(long, allow_negative_numbers = true, help = help_alpha0())]
    pub alpha0: Option<f64>,
    /// L0 μ_α.
    #[arg(long, allow_negative_numbers = true, help = help_alpha_decay())]
    pub alpha_decay: Option<f64>,
    /// NormalNet model bundle folder (default: the shipped bundle).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// NormalNet: from this filtering iteration on, the network's normals
    /// guide a joint-bilateral pass over the current normals (range width
    /// μ_g, spatial 2·d_s) instead of being the filtered normals (0 = never:
    /// the paper's form).
    #[arg(long)]
    pub guided_from: Option<usize>,
    /// Ground-truth mesh: print error metrics of the result (required by gt-gnf).
    #[arg(long)]
    pub gt: Option<PathBuf>,
    /// Print timings, parameters (and metrics) as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Drop the outlier vertices (far outside the mesh's robust extent, or
    /// isolated spikes; see `normalnet info`) and every face using one
    /// before denoising: the output then has fewer vertices and faces (the
    /// rest in their order; with --gt the same vertices and faces are
    /// dropped from the ground truth). Without it, every method keeps them
    /// and their faces in place and denoises the rest around them.
    #[arg(long)]
    pub remove_outliers: bool,
    /// Switch off the fold guard of the vertex update (normalnet, gnf, bnf,
    /// sun07, bi, vt; on by default: a vertex move may not fold a face over
    /// against its filtered normal). Off reproduces the reference
    /// implementations and the paper's NormalNet pipeline.
    #[arg(long)]
    pub no_fold_guard: bool,
}

/// The classical parameters or NormalNet options chosen by the flags.
enum Chosen {
    Normalnet(NormalnetOptions),
    Classical(Method),
    GtGuided(GtGuidedGnfParams),
}

/// Rejects flags that the chosen method does not use.
fn reject_unused(args: &Args, used: &[&str]) -> anyhow::Result<()> {
    let given: [(&str, bool); 19] = [
        ("iterations", args.iterations.is_some()),
        ("vertex-iterations", args.vertex_iterations.is_some()),
        ("mu-g", args.mu_g.is_some()),
        ("sigma-s", args.sigma_s.is_some()),
        ("radius", args.radius.is_some()),
        ("sigma-r", args.sigma_r.is_some()),
        ("sigma-n", args.sigma_n.is_some()),
        ("rho", args.rho.is_some()),
        ("tau", args.tau.is_some()),
        ("threshold", args.threshold.is_some()),
        ("lambda", args.lambda.is_some()),
        ("kappa", args.kappa.is_some()),
        ("beta0", args.beta0.is_some()),
        ("beta-max", args.beta_max.is_some()),
        ("alpha0", args.alpha0.is_some()),
        ("alpha-decay", args.alpha_decay.is_some()),
        ("model", args.model.is_some()),
        ("guided-from", args.guided_from.is_some()),
        ("no-fold-guard", args.no_fold_guard),
    ];
    for (flag, present) in given {
        if present && !used.contains(&flag) {
            bail!(
                "--{flag} does not apply to --method {}",
                method_label(args.method)
            );
        }
    }
    Ok(())
}

fn method_label(m: MethodName) -> &'static str {
    match m {
        MethodName::Normalnet => "normalnet",
        MethodName::Gnf => "gnf",
        MethodName::GtGnf => "gt-gnf",
        MethodName::Bnf => "bnf",
        MethodName::Sun07 => "sun07",
        MethodName::L0 => "l0",
        MethodName::Bi => "bi",
        MethodName::Vt => "vt",
    }
}

fn choose(args: &Args) -> anyhow::Result<Chosen> {
    fn set<T: Copy>(field: &mut T, value: Option<T>) {
        if let Some(v) = value {
            *field = v;
        }
    }
    let chosen = match args.method {
        MethodName::Normalnet => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "mu-g",
                    "model",
                    "guided-from",
                ],
            )?;
            if args.vertex_iterations == Some(0) {
                bail!(
                    "--vertex-iterations 0 with --method normalnet would run the whole network and \
                     return the input unchanged (NormalNet moves vertices only in its vertex-update \
                     passes); give at least 1 (default 20)"
                );
            }
            let options = NormalnetOptions {
                model: args.model.clone(),
                iterations: args.iterations,
                vertex_iterations: args.vertex_iterations,
                mu_g: args.mu_g,
                guided_from: args.guided_from,
                fold_guard: args.no_fold_guard.then_some(false),
                fold_guard_cos: None,
            };
            // the ranges, before the bundle and the mesh are loaded
            denoise_normalnet::params(&options).validate()?;
            Chosen::Normalnet(options)
        }
        MethodName::Gnf => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "mu-g",
                    "sigma-s",
                    "radius",
                    "no-fold-guard",
                ],
            )?;
            let mut p = GnfParams::default();
            set(&mut p.normal_iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.mu_g, args.mu_g);
            set(&mut p.sigma_s_over_ds, args.sigma_s);
            set(&mut p.radius_over_ds, args.radius);
            p.fold_guard &= !args.no_fold_guard;
            Chosen::Classical(Method::Gnf(p))
        }
        MethodName::GtGnf => {
            reject_unused(
                args,
                &["iterations", "vertex-iterations", "mu-g", "sigma-s"],
            )?;
            if args.gt.is_none() {
                bail!("--method gt-gnf needs the ground truth: pass --gt GT");
            }
            let mut p = GtGuidedGnfParams::default();
            set(&mut p.iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.mu_g, args.mu_g);
            set(&mut p.sigma_s_over_ds, args.sigma_s);
            p.validate()?;
            Chosen::GtGuided(p)
        }
        MethodName::Bnf => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "sigma-s",
                    "sigma-r",
                    "no-fold-guard",
                ],
            )?;
            let mut p = BnfParams::default();
            set(&mut p.normal_iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.sigma_s_over_ds, args.sigma_s);
            set(&mut p.sigma_r, args.sigma_r);
            p.fold_guard &= !args.no_fold_guard;
            Chosen::Classical(Method::Bnf(p))
        }
        MethodName::Sun07 => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "threshold",
                    "no-fold-guard",
                ],
            )?;
            let mut p = Sun07Params::default();
            set(&mut p.normal_iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.threshold, args.threshold);
            p.fold_guard &= !args.no_fold_guard;
            Chosen::Classical(Method::Sun07(p))
        }
        MethodName::L0 => {
            reject_unused(
                args,
                &[
                    "lambda",
                    "kappa",
                    "beta0",
                    "beta-max",
                    "alpha0",
                    "alpha-decay",
                ],
            )?;
            let mut p = L0Params::default();
            set(&mut p.lambda_over_le2, args.lambda);
            set(&mut p.kappa, args.kappa);
            set(&mut p.beta0, args.beta0);
            set(&mut p.beta_max, args.beta_max);
            set(&mut p.alpha0_over_gamma, args.alpha0);
            set(&mut p.alpha_decay, args.alpha_decay);
            Chosen::Classical(Method::L0(p))
        }
        MethodName::Bi => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "sigma-s",
                    "sigma-r",
                    "sigma-n",
                    "no-fold-guard",
                ],
            )?;
            let mut p = BiParams::default();
            set(&mut p.normal_iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.sigma_s_over_ds, args.sigma_s);
            set(&mut p.sigma_r, args.sigma_r);
            set(&mut p.sigma_n, args.sigma_n);
            p.fold_guard &= !args.no_fold_guard;
            Chosen::Classical(Method::Bi(p))
        }
        MethodName::Vt => {
            reject_unused(
                args,
                &[
                    "iterations",
                    "vertex-iterations",
                    "radius",
                    "rho",
                    "tau",
                    "no-fold-guard",
                ],
            )?;
            let mut p = VtParams::default();
            set(&mut p.normal_iterations, args.iterations);
            set(&mut p.vertex_iterations, args.vertex_iterations);
            set(&mut p.radius_over_le, args.radius);
            set(&mut p.rho, args.rho);
            set(&mut p.tau, args.tau);
            p.fold_guard &= !args.no_fold_guard;
            Chosen::Classical(Method::Vt(p))
        }
    };
    if let Chosen::Classical(m) = &chosen {
        m.validate()?;
    }
    Ok(chosen)
}

/// What `--remove-outliers` dropped.
struct Removed {
    /// one flag per input vertex (len #V of the file)
    mask: Vec<bool>,
    /// vertices dropped
    vertices: usize,
    /// faces dropped
    faces: usize,
}

/// `mesh` without its outlier vertices and their faces (`--remove-outliers`),
/// said on stderr; unchanged (and `None`) when there is none or no face
/// would be left.
fn remove_outliers(mesh: Mesh) -> (Mesh, Option<Removed>) {
    let outliers = outlier_vertices(&mesh, &OutlierParams::default());
    if outliers.count() == 0 {
        return (mesh, None);
    }
    let Some((inner, _)) = without_vertices(&mesh, &outliers.mask) else {
        eprintln!("warning: --remove-outliers: no face would be left; the mesh is kept whole");
        return (mesh, None);
    };
    let removed = Removed {
        vertices: mesh.num_vertices() - inner.num_vertices(),
        faces: mesh.num_faces() - inner.num_faces(),
        mask: outliers.mask,
    };
    eprintln!(
        "--remove-outliers: dropped {} vertices and {} faces",
        removed.vertices, removed.faces
    );
    (inner, Some(removed))
}

/// Runs `normalnet denoise`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let t_total = Instant::now();
    let chosen = choose(&args)?;
    output::check_file(&args.output, output::MESH, "output mesh")?;
    let mesh =
        read_mesh(&args.input).with_context(|| format!("reading {}", args.input.display()))?;
    let (mesh, removed) = if args.remove_outliers {
        remove_outliers(mesh)
    } else {
        (mesh, None)
    };
    let gt: Option<Mesh> = match &args.gt {
        Some(path) => {
            let gt = read_mesh(path)
                .with_context(|| format!("reading ground truth {}", path.display()))?;
            let gt = match &removed {
                Some(r) if gt.num_vertices() == r.mask.len() => without_vertices(&gt, &r.mask)
                    .map(|(m, _)| m)
                    .with_context(|| {
                        format!("{}: no face left without the outliers", path.display())
                    })?,
                Some(r) => bail!(
                    "{}: {} vertices, but {} had {}; --remove-outliers drops the same vertices \
                     from the ground truth and needs the same vertex count",
                    path.display(),
                    gt.num_vertices(),
                    args.input.display(),
                    r.mask.len()
                ),
                None => gt,
            };
            if gt.num_faces() != mesh.num_faces() {
                bail!(
                    "{}: {} faces, but {} has {}; metrics compare face by face",
                    path.display(),
                    gt.num_faces(),
                    args.input.display(),
                    mesh.num_faces()
                );
            }
            Some(gt)
        }
        None => None,
    };
    let progress = Bar::new(quiet);
    let t_denoise = Instant::now();
    let mut stages = None;
    let (result, parameters) = match &chosen {
        Chosen::Normalnet(options) => {
            // outliers and their faces stay in place, as for the classical methods
            let out = denoise_around(&mesh, |m| {
                let (out, times) = denoise_normalnet::denoise_with_stages(m, options, &progress)?;
                stages = Some(times);
                anyhow::Ok(out)
            })?;
            let parameters = json!({
                "model": options.model,
                "iterations": options.iterations,
                "vertex_iterations": options.vertex_iterations,
                "mu_g": options.mu_g,
                "guided_from": options.guided_from,
            });
            (out, parameters)
        }
        Chosen::Classical(method) => {
            let out = method.denoise(&mesh, &progress).with_context(|| {
                format!("denoising {} with {}", args.input.display(), method.name())
            })?;
            // The params struct of the variant, without the enum tag.
            let tagged = serde_json::to_value(method)?;
            let parameters = tagged
                .as_object()
                .and_then(|o| o.values().next().cloned())
                .unwrap_or(tagged);
            (out, parameters)
        }
        Chosen::GtGuided(params) => {
            let gt = gt.as_ref().context("--method gt-gnf needs --gt")?;
            let out = gt_guided_gnf(&mesh, &face_normals(gt), params, &progress)
                .with_context(|| format!("denoising {} with gt-gnf", args.input.display()))?;
            (out, serde_json::to_value(params)?)
        }
    };
    let denoise_seconds = t_denoise.elapsed().as_secs_f64();
    write_mesh(&args.output, &result)
        .with_context(|| format!("writing {}", args.output.display()))?;
    let metrics = match &gt {
        Some(gt) => Some(compare(gt, &result).context("computing metrics")?),
        None => None,
    };
    let total_seconds = t_total.elapsed().as_secs_f64();
    let method = method_label(args.method);
    if args.json {
        let v = json!({
            "input": args.input,
            "output": args.output,
            "method": method,
            "vertices": mesh.num_vertices(),
            "faces": mesh.num_faces(),
            "parameters": parameters,
            "denoise_seconds": denoise_seconds,
            "total_seconds": total_seconds,
            "threads": rayon::current_num_threads(),
            "stages": stages,
            "gt": args.gt,
            "metrics": metrics,
            "removed_outliers": removed.as_ref().map(|r| json!({
                "vertices": r.vertices,
                "faces": r.faces,
            })),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{} -> {}: {method}, {} vertices, {} faces, denoise {denoise_seconds:.3} s, total {total_seconds:.3} s",
            args.input.display(),
            args.output.display(),
            mesh.num_vertices(),
            mesh.num_faces()
        );
        println!("parameters: {parameters}");
        if let Some(m) = metrics {
            println!(
                "E_a {:.3}°  E_v {:.6} (E_v/l_e {:.4})  Hausdorff {:.6}",
                m.e_a_deg, m.e_v, m.e_v_over_le, m.hausdorff
            );
        }
    }
    Ok(())
}
