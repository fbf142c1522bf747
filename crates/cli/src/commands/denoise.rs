//! `normalnet denoise IN OUT`: denoises a mesh with any registered method
//! of `normalnet_denoise` (NormalNet by default, SPEC §7; the classical
//! filters, SPEC §4, §9; the oracle), writes the result atomically with the
//! input's vertex and face order, and prints timings (the denoising call
//! alone and the whole command), the parameters and, with `--gt`, the error
//! metrics (SPEC §3).
//!
//! Parameters: shorthand flags (`--iterations`, `--mu-g`, ...; each method's
//! registry entry says which it takes and which parameter each sets) and
//! `--param KEY=VALUE` for any field of the method's parameters. Absent ones
//! keep the method's defaults, which `--help` shows. A flag that does not
//! apply to the chosen method is an error rather than silently ignored.
//!
//! The output keeps what the input file carries (issue 38,
//! `normalnet_mesh::io::attributes`): an output in the input's format gets
//! its polygons, texture coordinates, materials, groups, colours, extra PLY
//! properties and STL attribute bytes back around the denoised positions,
//! normals recomputed; `--triangulate` writes triangles instead of the
//! polygons. What cannot be kept is said on stderr.
//!
//! Outlier vertices (issue 14, `normalnet_mesh::outliers`) are warned about
//! on reading; every method leaves them and their faces out of the
//! denoising and in place, and `--remove-outliers` drops them (and their
//! faces) from the output instead.

use super::info::format_for;
use super::metrics::check_ground_truth;
use crate::input::{read_mesh, read_mesh_file};
use crate::mesh_output::write_result;
use crate::output;
use crate::progress::Bar;
use anyhow::{Context, bail};
use normalnet_denoise::flags::{FLAGS, FlagValue};
use normalnet_denoise::params::parse_assignment;
use normalnet_denoise::{Denoiser, METHODS, MethodInfo, Outcome, Params};
use normalnet_mesh::Mesh;
use normalnet_mesh::io::{FileWriteOptions, check_encodable};
use normalnet_mesh::metrics::{Metrics, compare};
use normalnet_mesh::outliers::{OutlierParams, outlier_vertices, without_vertices};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Every registered name and alias, for `--method`.
fn method_names() -> Vec<&'static str> {
    METHODS
        .iter()
        .flat_map(|m| std::iter::once(m.name).chain(m.aliases.iter().copied()))
        .collect()
}

/// `text` followed by each method's default for the parameter `flag` sets.
fn flag_help(flag: &str, text: &str) -> String {
    let defaults: Vec<String> = METHODS
        .iter()
        .filter_map(|m| {
            let field = m.flag_field(flag)?;
            let v = (m.defaults)().get(field).cloned()?;
            Some(format!("{} {v}", m.name))
        })
        .collect();
    format!("{text} [defaults: {}]", defaults.join(", "))
}

/// The methods that take `flag`, comma-separated.
fn takers(flag: &str) -> String {
    let names: Vec<&str> = METHODS
        .iter()
        .filter(|m| m.flag_field(flag).is_some())
        .map(|m| m.name)
        .collect();
    names.join(", ")
}

fn method_help() -> String {
    let lines: Vec<String> = METHODS
        .iter()
        .map(|m| {
            let aliases = if m.aliases.is_empty() {
                String::new()
            } else {
                format!(" (also {})", m.aliases.join(", "))
            };
            format!("{}{aliases}: {}", m.name, m.summary)
        })
        .collect();
    format!("Denoising method:\n{}", lines.join("\n"))
}

/// The method and its parameters: shared by `denoise` and `batch`. Its
/// flags come from the registry's table (`normalnet_denoise::flags::FLAGS`),
/// not typed here: `--method`, one flag per table entry, `--param`.
#[derive(Clone, Debug)]
pub struct MethodArgs {
    /// the method's name as given
    pub method: String,
    /// the shorthand flags given, in table order, with the parameter value
    /// each means (`--no-switch` → `false`)
    pub flags: Vec<(&'static str, Value)>,
    /// `--param KEY=VALUE`, in order
    pub params: Vec<(String, Value)>,
}

impl clap::Args for MethodArgs {
    fn augment_args(mut cmd: clap::Command) -> clap::Command {
        use clap::{Arg, ArgAction};
        cmd = cmd.arg(
            Arg::new("method")
                .long("method")
                .short('m')
                .default_value("normalnet")
                .help("Denoising method")
                .long_help(method_help())
                .value_parser(clap::builder::PossibleValuesParser::new(method_names())),
        );
        for flag in FLAGS {
            let help = match flag.value {
                // a switch or a path has no default to show: say who takes it
                FlagValue::Off | FlagValue::Path => {
                    format!("{} [methods: {}]", flag.help, takers(flag.name))
                }
                _ => flag_help(flag.name, flag.help),
            };
            let arg = Arg::new(flag.name).long(flag.name).help(help);
            cmd = cmd.arg(match flag.value {
                FlagValue::Off => arg.action(ArgAction::SetTrue),
                _ => arg
                    .allow_negative_numbers(true)
                    .value_parser(move |text: &str| flag.parse(text))
                    .value_name(if flag.value == FlagValue::Path {
                        "PATH"
                    } else {
                        "VALUE"
                    }),
            });
        }
        cmd.arg(
            Arg::new("param")
                .long("param")
                .short('p')
                .value_name("KEY=VALUE")
                .action(ArgAction::Append)
                .value_parser(parse_assignment)
                .help(
                    "Any parameter of the method, by its field name (see `--json` output for \
                     the names), e.g. `--param fold_guard_cos=0` or `-p mu_g=0.3`; repeatable. \
                     The value is read as JSON when it parses, else as text",
                ),
        )
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

impl clap::FromArgMatches for MethodArgs {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let flags = FLAGS
            .iter()
            .filter_map(|flag| match flag.value {
                FlagValue::Off => m
                    .get_flag(flag.name)
                    .then_some((flag.name, Value::Bool(false))),
                _ => m
                    .get_one::<Value>(flag.name)
                    .map(|v| (flag.name, v.clone())),
            })
            .collect();
        Ok(MethodArgs {
            method: m
                .get_one::<String>("method")
                .cloned()
                .unwrap_or_else(|| "normalnet".into()),
            flags,
            params: m
                .get_many::<(String, Value)>("param")
                .map(|v| v.cloned().collect())
                .unwrap_or_default(),
        })
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

/// Arguments of `normalnet denoise`.
#[derive(clap::Args)]
pub struct Args {
    /// Noisy input mesh (.obj, .off, .ply, .stl, .gltf, .glb).
    pub input: PathBuf,
    /// Output mesh (format from the extension; written atomically).
    pub output: PathBuf,
    /// The method and its parameters.
    #[command(flatten)]
    pub choice: MethodArgs,
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
    /// Write triangles (the fan triangulation the denoiser worked on)
    /// instead of the input's polygons.
    #[arg(long)]
    pub triangulate: bool,
}

/// The parameters the flags give for `info` (shorthand flags mapped onto
/// their fields, then `--param`); a flag the method does not take is an
/// error.
pub fn given_params(args: &MethodArgs, info: &MethodInfo) -> anyhow::Result<Params> {
    let mut params = Params::new();
    for (flag, value) in &args.flags {
        let Some(field) = info.flag_field(flag) else {
            bail!("--{flag} does not apply to --method {}", info.name);
        };
        params.insert(field.to_string(), value.clone());
    }
    for (key, value) in &args.params {
        params.insert(key.clone(), value.clone());
    }
    Ok(params)
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
        stderr_line!("warning: --remove-outliers: no face would be left; the mesh is kept whole");
        return (mesh, None);
    };
    let removed = Removed {
        vertices: mesh.num_vertices() - inner.num_vertices(),
        faces: mesh.num_faces() - inner.num_faces(),
        mask: outliers.mask,
    };
    stderr_line!(
        "--remove-outliers: dropped {} vertices and {} faces",
        removed.vertices,
        removed.faces
    );
    (inner, Some(removed))
}

/// Runs `normalnet denoise`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let t_total = Instant::now();
    let info = normalnet_denoise::find(&args.choice.method)?;
    if info.needs_gt() && args.gt.is_none() {
        bail!(
            "--method {} reads the ground truth: pass --gt GT",
            args.choice.method
        );
    }
    output::check_file(&args.output, output::MESH, "output mesh")?;
    let inputs: Vec<&Path> = std::iter::once(args.input.as_path())
        .chain(args.gt.as_deref())
        .collect();
    output::check_not_input(&args.output, &inputs)?;
    // parameters checked and the model loaded before the mesh is read
    let denoiser = Denoiser::new(info.name, &given_params(&args.choice, info)?)?;
    let file =
        read_mesh_file(&args.input).with_context(|| format!("reading {}", args.input.display()))?;
    let (mesh, attributes) = (file.mesh, file.attributes);
    let out_format = format_for(&args.output, None)?;
    check_encodable(&args.output, &mesh, out_format).with_context(|| {
        format!(
            "{}: its coordinates do not fit the output format",
            args.input.display()
        )
    })?;
    let (mesh, removed) = if args.remove_outliers {
        remove_outliers(mesh)
    } else {
        (mesh, None)
    };
    let gt = ground_truth(&args, removed.as_ref(), &mesh)?;
    let progress = Bar::new(quiet);
    let t_denoise = Instant::now();
    let outcome = denoiser
        .run(&mesh, gt.as_ref(), &progress)
        .with_context(|| format!("denoising {} with {}", args.input.display(), info.name))?;
    let denoise_seconds = t_denoise.elapsed().as_secs_f64();
    write_result(
        &args.output,
        out_format,
        &outcome.mesh,
        &attributes,
        &args.input,
        &FileWriteOptions {
            triangulate: args.triangulate,
            ply_ascii: false,
        },
    )?;
    let metrics = match &gt {
        Some(gt) => Some(compare(gt, &outcome.mesh).context("computing metrics")?),
        None => None,
    };
    let report = Report {
        args: &args,
        method: info.name,
        vertices: mesh.num_vertices(),
        faces: mesh.num_faces(),
        parameters: denoiser.parameters(),
        denoise_seconds,
        total_seconds: t_total.elapsed().as_secs_f64(),
        outcome: &outcome,
        metrics,
        removed: removed.as_ref(),
    };
    if args.json {
        report.print_json()
    } else {
        report.print_text()
    }
}

/// The ground truth of `--gt`, without the vertices `--remove-outliers`
/// dropped from the input, checked against the input `mesh`.
fn ground_truth(
    args: &Args,
    removed: Option<&Removed>,
    mesh: &Mesh,
) -> anyhow::Result<Option<Mesh>> {
    let Some(path) = &args.gt else {
        return Ok(None);
    };
    let gt = read_mesh(path).with_context(|| format!("reading ground truth {}", path.display()))?;
    let gt = match removed {
        Some(r) if gt.num_vertices() == r.mask.len() => without_vertices(&gt, &r.mask)
            .map(|(m, _)| m)
            .with_context(|| format!("{}: no face left without the outliers", path.display()))?,
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
    check_ground_truth(path, &gt, &args.input, mesh)?;
    Ok(Some(gt))
}

/// What `normalnet denoise` prints when it is done.
struct Report<'a> {
    args: &'a Args,
    method: &'static str,
    vertices: usize,
    faces: usize,
    parameters: Value,
    denoise_seconds: f64,
    total_seconds: f64,
    /// the denoiser's result: its stage times and fold repair
    outcome: &'a Outcome,
    metrics: Option<Metrics>,
    removed: Option<&'a Removed>,
}

impl Report<'_> {
    /// `--json`: one object with every figure.
    fn print_json(&self) -> anyhow::Result<()> {
        let v = json!({
            "input": self.args.input,
            "output": self.args.output,
            "method": self.method,
            "vertices": self.vertices,
            "faces": self.faces,
            "parameters": self.parameters,
            "denoise_seconds": self.denoise_seconds,
            "total_seconds": self.total_seconds,
            "threads": rayon::current_num_threads(),
            "isa": normalnet_denoise::isa::active().name(),
            "stages": self.outcome.stages,
            "folds": self.outcome.folds,
            "gt": self.args.gt,
            "metrics": self.metrics,
            "removed_outliers": self.removed.map(|r| json!({
                "vertices": r.vertices,
                "faces": r.faces,
            })),
        });
        writeln!(
            std::io::stdout().lock(),
            "{}",
            serde_json::to_string_pretty(&v)?
        )?;
        Ok(())
    }

    /// A few lines: the run, its parameters, the fold repair when it did
    /// something, the metrics with `--gt`.
    fn print_text(&self) -> anyhow::Result<()> {
        let mut out = std::io::stdout().lock();
        writeln!(
            out,
            "{} -> {}: {}, {} vertices, {} faces, denoise {:.3} s, total {:.3} s",
            self.args.input.display(),
            self.args.output.display(),
            self.method,
            self.vertices,
            self.faces,
            self.denoise_seconds,
            self.total_seconds
        )?;
        writeln!(out, "parameters: {}", self.parameters)?;
        if let Some(f) = self.outcome.folds.as_ref().filter(|f| f.before > 0) {
            writeln!(
                out,
                "folded faces: input {}, method {}, after the repair {} ({} vertices moved)",
                f.input, f.before, f.after, f.moved
            )?;
        }
        if let Some(m) = &self.metrics {
            writeln!(
                out,
                "E_a {:.3}°  E_v {:.6} (E_v/l_e {:.4})  Hausdorff {:.6}",
                m.e_a_deg, m.e_v, m.e_v_over_le, m.hausdorff
            )?;
        }
        Ok(())
    }
}
