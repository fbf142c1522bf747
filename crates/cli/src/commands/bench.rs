//! `normalnet bench`: runs methods over noisy/clean pairs (`MODEL/Noisy.obj`
//! and `MODEL/Original.obj`) and writes the comparison in the layout of the
//! paper's Table 3 (`table.md`), plus `results.csv`, `results.json`,
//! `index.html` and, with `--render`, one picture per model with the noisy
//! input, every method and the ground truth side by side, coloured by angular
//! error (SPEC §3 metrics, SPEC §7 NormalNet settings per model).
//!
//! Settings come from a TOML file (`configs/bench.toml`): for each method,
//! `[defaults.METHOD]` then `[models."MODEL".METHOD]` override the method's
//! own defaults key by key; keys are the fields of the method's parameters
//! (`normalnet_denoise`'s one mechanism: what `normalnet denoise --json`
//! prints as `parameters`, and `--param` sets). `[models."MODEL"] view = [az, el]`
//! sets the camera of that model's picture and `skip = ["METHOD", ...]`
//! leaves methods out on that model (shown as `skipped`). A column may be a
//! variant `METHOD-NAME` (e.g. `gnf-ref`, `l0-lambda0.1`): it runs METHOD
//! with the settings under its own name, so one method can appear with
//! several settings side by side. `oracle` runs GT-guided GNF (it reads the
//! ground truth: the ceiling of a perfect NormalNet, shown but never ranked)
//! with the model's NormalNet N_f / N_v / μ_g unless `[..oracle]` says otherwise. A failing method is reported as a
//! failed cell and the bench goes on.
//!
//! `--suite FILE` (e.g. `configs/validation.toml`, `normalnet_denoise::suite`)
//! replaces `--data`: the suite's pairs are generated into `--cache` where
//! missing or out of date, benched like model folders (the pair's name is
//! the model), and `table.md` / `results.json` add each group's means.

use crate::commands::render::{parse_size, parse_view};
use crate::input;
use crate::progress::Bar;
use anyhow::{Context, bail};
use normalnet_denoise::params::describe;
use normalnet_denoise::suite::{Suite, describe_noise};
use normalnet_denoise::{Denoiser, Kind, METHODS, Params};
use normalnet_mesh::metrics::{Metrics, compare, per_face_angle_errors};
use normalnet_mesh::{Mesh, read_mesh};
use normalnet_render::report::{
    BenchReport, NOISY, ReportGroup, RunRecord, split_model_name, write_report,
};
use normalnet_render::{
    ColourBar, Image, RenderOptions, append_colour_bar, compose_grid, draw_lines, error_colors,
    nice_error_scale, render,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The settings shipped with the repository (used when `--settings` is not
/// given and `configs/bench.toml` is not in the working directory).
const BUILTIN_SETTINGS: &str = include_str!("../../../../configs/bench.toml");

/// The NormalNet method's name in `--methods`.
const NORMALNET: &str = "normalnet";

/// The oracle's name in `--methods`: GT-guided GNF (guidance = the ground
/// truth's normals), NormalNet's training target run as a denoiser, i.e. the
/// ceiling a perfect CNN would reach (MEASURED.md). It reads the ground
/// truth, so it is shown for reference and never ranked.
const ORACLE: &str = "oracle";

/// Arguments of `normalnet bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Folder with one sub-folder per model holding Noisy.obj and Original.obj.
    #[arg(long, default_value = "../shared/data/gd")]
    pub data: PathBuf,
    /// A validation suite (TOML, e.g. configs/validation.toml) instead of --data: clean sources with
    /// seeded noise specs and groups; missing noisy meshes are generated into --cache, and the table
    /// adds per-group means.
    #[arg(long, conflicts_with = "data")]
    pub suite: Option<PathBuf>,
    /// Cache folder of the suite's generated meshes (CACHE/PAIR/Noisy.obj, key.json).
    #[arg(long, default_value = "target/validation-cache")]
    pub cache: PathBuf,
    /// Methods, comma-separated: normalnet and the classical ones (see `normalnet denoise --help`).
    /// Default: normalnet and every classical method.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Models (sub-folder names), comma-separated. Default: every folder with a pair.
    #[arg(long, value_delimiter = ',')]
    pub models: Vec<String>,
    /// Per-model settings (TOML). Default: ./configs/bench.toml if present, else the built-in copy.
    #[arg(long)]
    pub settings: Option<PathBuf>,
    /// Output folder (created if needed).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Also write one PNG per model: noisy / each method / ground truth, coloured by error.
    #[arg(long)]
    pub render: bool,
    /// Size of one picture panel, WIDTHxHEIGHT.
    #[arg(long, default_value = "480x360", value_parser = parse_size)]
    pub panel_size: (u32, u32),
    /// Camera AZIMUTH,ELEVATION for the pictures (a model's `view` in the settings wins).
    #[arg(long, default_value = "30,20", value_parser = parse_view, allow_hyphen_values = true)]
    pub view: (f64, f64),
    /// Also save every result mesh as OUT/MODEL/METHOD.obj.
    #[arg(long)]
    pub save_meshes: bool,
    /// Keep the runs of an earlier OUT/results.json that this invocation does
    /// not redo (slow methods can run separately); pictures reuse the saved
    /// meshes of earlier runs (--save-meshes).
    #[arg(long)]
    pub merge: bool,
}

/// Parsed settings file.
#[derive(Debug, Default)]
pub struct Settings {
    source: String,
    defaults: toml::Table,
    models: toml::Table,
}

impl Settings {
    /// Parses settings text; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> anyhow::Result<Settings> {
        let mut table: toml::Table = text
            .parse()
            .with_context(|| format!("{source}: invalid TOML"))?;
        let take = |table: &mut toml::Table, key: &str| -> anyhow::Result<toml::Table> {
            match table.remove(key) {
                None => Ok(toml::Table::new()),
                Some(toml::Value::Table(t)) => Ok(t),
                Some(_) => bail!("{source}: `{key}` must be a table"),
            }
        };
        let defaults = take(&mut table, "defaults")?;
        let models = take(&mut table, "models")?;
        if let Some(key) = table.keys().next() {
            bail!(
                "{source}: unknown top-level key `{key}` (expected [defaults.METHOD] or [models.\"MODEL\".METHOD])"
            );
        }
        let known = |m: &str| base_method(m).is_some();
        for (method, v) in &defaults {
            if !known(method) {
                bail!("{source}: [defaults.{method}]: unknown method `{method}`");
            }
            if !v.is_table() {
                bail!("{source}: [defaults.{method}] must be a table");
            }
        }
        for (model, v) in &models {
            let Some(t) = v.as_table() else {
                bail!("{source}: [models.\"{model}\"] must be a table");
            };
            for (key, v) in t {
                if key == "view" {
                    view_from_toml(v)
                        .with_context(|| format!("{source}: [models.\"{model}\"] view"))?;
                } else if key == "skip" {
                    let names = v
                        .as_array()
                        .map(|a| a.iter().map(|x| x.as_str()).collect::<Option<Vec<_>>>());
                    let Some(Some(names)) = names else {
                        bail!("{source}: [models.\"{model}\"] skip must be a list of method names");
                    };
                    if let Some(bad) = names.iter().find(|m| !known(m)) {
                        bail!("{source}: [models.\"{model}\"] skip: unknown method `{bad}`");
                    }
                } else if !known(key) {
                    bail!("{source}: [models.\"{model}\"]: unknown method `{key}`");
                } else if !v.is_table() {
                    bail!("{source}: [models.\"{model}\".{key}] must be a table");
                }
            }
        }
        Ok(Settings {
            source: source.to_string(),
            defaults,
            models,
        })
    }

    /// Loads `path`, or `./configs/bench.toml`, or the built-in copy.
    pub fn load(path: Option<&Path>) -> anyhow::Result<Settings> {
        match path {
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("reading settings {}", p.display()))?;
                Settings::parse(&text, &p.display().to_string())
            }
            None => {
                let local = Path::new("configs/bench.toml");
                if local.is_file() {
                    Settings::load(Some(local))
                } else {
                    Settings::parse(BUILTIN_SETTINGS, "built-in configs/bench.toml")
                }
            }
        }
    }

    /// The overrides for `method` on `model`: defaults, then the model's own,
    /// each with where it came from (for error messages).
    fn overrides(&self, model: &str, method: &str) -> Vec<(String, toml::Table)> {
        let mut out = Vec::new();
        if let Some(t) = self.defaults.get(method).and_then(|v| v.as_table()) {
            out.push((format!("{}: [defaults.{method}]", self.source), t.clone()));
        }
        if let Some(t) = self
            .models
            .get(model)
            .and_then(|m| m.get(method))
            .and_then(|v| v.as_table())
        {
            out.push((
                format!("{}: [models.\"{model}\".{method}]", self.source),
                t.clone(),
            ));
        }
        out
    }

    /// Whether the settings skip `method` on `model` (`[models."MODEL"] skip = [...]`).
    fn skips(&self, model: &str, method: &str) -> bool {
        self.models
            .get(model)
            .and_then(|m| m.get("skip"))
            .and_then(|v| v.as_array())
            .is_some_and(|a| a.iter().any(|x| x.as_str() == Some(method)))
    }

    /// The picture camera of `model`, if the settings give one.
    fn view(&self, model: &str) -> Option<(f64, f64)> {
        self.models
            .get(model)
            .and_then(|m| m.get("view"))
            .and_then(|v| view_from_toml(v).ok())
    }

    /// The parameters column `column` gives on `model`: its base method
    /// (the column's name, or the method a variant `METHOD-NAME` runs), the
    /// settings laid over each other (defaults, then the model's), and where
    /// they came from. The oracle starts from the N_f / N_v / μ_g of the
    /// model's NormalNet settings (it is a perfect NormalNet).
    pub fn params(
        &self,
        model: &str,
        column: &str,
    ) -> anyhow::Result<(&'static str, Params, String)> {
        let base = base_method(column).with_context(|| format!("unknown method `{column}`"))?;
        let mut params = Params::new();
        let mut sources = Vec::new();
        if base == ORACLE {
            for (source, table) in self.overrides(model, NORMALNET) {
                for (key, v) in table {
                    if ["iterations", "vertex_iterations", "mu_g"].contains(&key.as_str()) {
                        params.insert(key, serde_json::to_value(v)?);
                        sources.push(source.clone());
                    }
                }
            }
        }
        for (source, table) in self.overrides(model, column) {
            for (key, v) in table {
                params.insert(key, serde_json::to_value(v)?);
            }
            sources.push(source);
        }
        sources.dedup();
        Ok((base, params, sources.join(", ")))
    }

    /// The denoiser column `column` runs on `model` ([`Settings::params`]),
    /// and a one-line description of its parameters.
    pub fn denoiser(&self, model: &str, column: &str) -> anyhow::Result<(Denoiser, String)> {
        let (base, params, sources) = self.params(model, column)?;
        let d = Denoiser::new(base, &params).with_context(|| {
            format!(
                "settings for {column} on {model} (from {})",
                if sources.is_empty() {
                    "defaults"
                } else {
                    &sources
                }
            )
        })?;
        let described = describe(&d.parameters());
        Ok((d, described))
    }
}

/// The method a column name runs: the name itself when it is `normalnet` or
/// a classical method, else the part before the first `-` when that is one
/// (a variant such as `gnf-ref` or `l0-lambda0.1`, with its own settings).
pub fn base_method(name: &str) -> Option<&'static str> {
    let known = |m: &str| normalnet_denoise::find(m).ok().map(|i| i.name);
    if let Some(base) = known(name) {
        return Some(base);
    }
    let (prefix, _) = name.split_once('-')?;
    known(prefix)
}

fn view_from_toml(v: &toml::Value) -> anyhow::Result<(f64, f64)> {
    let a = v
        .as_array()
        .filter(|a| a.len() == 2)
        .context("expected [azimuth, elevation]")?;
    let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
    let az = num(&a[0]).context("azimuth must be a number")?;
    let el = num(&a[1]).context("elevation must be a number")?;
    if !az.is_finite() || !(-90.0..=90.0).contains(&el) {
        bail!("elevation must be within -90..=90, got {el}");
    }
    Ok((az, el))
}

/// Folders under `data` holding `Noisy.obj` and `Original.obj`, sorted.
fn discover_models(data: &Path) -> anyhow::Result<Vec<String>> {
    let entries = std::fs::read_dir(data)
        .with_context(|| format!("reading data folder {}", data.display()))?;
    let mut models: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("Noisy.obj").is_file() && e.path().join("Original.obj").is_file())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    models.sort();
    Ok(models)
}

/// One model of the bench: its name and the files of its noisy input and
/// ground truth.
struct BenchInput {
    model: String,
    noisy: PathBuf,
    clean: PathBuf,
}

/// The models of a data folder (`--models`, else every pair folder), checked.
fn inputs_from_data(data: &Path, names: &[String]) -> anyhow::Result<Vec<BenchInput>> {
    let models = if names.is_empty() {
        discover_models(data)?
    } else {
        names.iter().map(|m| m.trim().to_string()).collect()
    };
    if models.is_empty() {
        bail!(
            "no model folders with Noisy.obj and Original.obj under {}",
            data.display()
        );
    }
    let mut inputs = Vec::new();
    for m in models {
        let dir = data.join(&m);
        for f in ["Noisy.obj", "Original.obj"] {
            if !dir.join(f).is_file() {
                bail!("{}: missing {f}", dir.display());
            }
        }
        inputs.push(BenchInput {
            noisy: dir.join("Noisy.obj"),
            clean: dir.join("Original.obj"),
            model: m,
        });
    }
    Ok(inputs)
}

/// What a suite gives the bench: its inputs, the report's groups and the
/// noise description of each pair.
struct SuiteInputs {
    inputs: Vec<BenchInput>,
    groups: Vec<ReportGroup>,
    noise_labels: Vec<(String, String)>,
}

/// The pairs of a suite (`--models`: only those), generated into `cache`
/// where missing, with the report's groups and noise labels.
fn inputs_from_suite(
    path: &Path,
    cache: &Path,
    names: &[String],
    quiet: bool,
) -> anyhow::Result<SuiteInputs> {
    let mut suite = Suite::load(path)?;
    let names: Vec<&str> = names.iter().map(|n| n.trim()).collect();
    if let Some(bad) = names
        .iter()
        .find(|n| !suite.pairs.iter().any(|p| &p.name == *n))
    {
        bail!("{}: no pair named `{bad}`", path.display());
    }
    if !names.is_empty() {
        suite.pairs.retain(|p| names.contains(&p.name.as_str()));
    }
    let prepared = suite.prepare(cache, &Bar::new(quiet))?;
    if !quiet {
        let made = prepared.iter().filter(|p| p.generated).count();
        stderr_line!(
            "suite {}: {} pairs, {made} generated into {}",
            path.display(),
            prepared.len(),
            cache.display()
        );
    }
    let groups = suite
        .groups
        .iter()
        .map(|g| ReportGroup {
            name: g.clone(),
            models: suite.members(g).iter().map(|m| m.to_string()).collect(),
        })
        .filter(|g| !g.models.is_empty())
        .collect();
    let labels = suite
        .pairs
        .iter()
        .map(|p| (p.name.clone(), describe_noise(&p.noise)))
        .collect();
    let inputs = prepared
        .into_iter()
        .map(|p| BenchInput {
            model: p.name,
            noisy: p.noisy,
            clean: p.clean,
        })
        .collect();
    Ok(SuiteInputs {
        inputs,
        groups,
        noise_labels: labels,
    })
}

/// Gives the records of a suite's pairs their noise description (the
/// folder-name split of [`split_model_name`] does not apply to them).
fn label_noise(report: &mut BenchReport) {
    for r in &mut report.records {
        if let Some((_, label)) = report.noise_labels.iter().find(|(m, _)| m == &r.model) {
            r.noise = label.clone();
        }
    }
}

/// Runs a closure, turning a panic into an error so one method cannot stop the bench.
fn guarded<T>(what: &str, f: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            bail!("{what} panicked: {msg}")
        }
    }
}

fn record_from(
    model: &str,
    method: &str,
    params: String,
    m: &Metrics,
    denoise_s: Option<f64>,
    total_s: f64,
) -> RunRecord {
    RunRecord {
        model: model.to_string(),
        noise: split_model_name(model).1,
        method: method.to_string(),
        params,
        e_a_deg: Some(m.e_a_deg),
        e_v: Some(m.e_v),
        e_v_over_le: Some(m.e_v_over_le),
        hausdorff: Some(m.hausdorff),
        flipped_faces: Some(m.flipped_faces),
        denoise_seconds: denoise_s,
        total_seconds: Some(total_s),
        error: None,
        skipped: None,
    }
}

fn failed(
    model: &str,
    method: &str,
    params: String,
    error: &anyhow::Error,
    total_s: f64,
) -> RunRecord {
    RunRecord {
        model: model.to_string(),
        noise: split_model_name(model).1,
        method: method.to_string(),
        params,
        total_seconds: Some(total_s),
        error: Some(format!("{error:#}")),
        ..Default::default()
    }
}

/// One panel of a model's picture.
struct Panel {
    label: String,
    mesh: Mesh,
    errors: Option<Vec<f64>>,
    /// E_a of a ranked method's result (chooses the colour scale)
    ranked_e_a: Option<f64>,
}

/// Renders the panels of one model side by side with a shared camera (the
/// ground truth's box) and error scale, a title and a colour bar.
fn model_picture(
    model: &str,
    panels: &[Panel],
    gt: &Mesh,
    args: &Args,
    view: (f64, f64),
) -> anyhow::Result<Image> {
    // the scale fits the best ranked method (95th percentile of its errors,
    // rounded up), so differences between good results stay visible; worse
    // results and the noisy input saturate towards red
    let best = panels
        .iter()
        .filter(|p| p.errors.is_some() && p.ranked_e_a.is_some())
        .min_by(|a, b| {
            a.ranked_e_a
                .partial_cmp(&b.ranked_e_a)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    let max = match best.and_then(|p| p.errors.as_ref()) {
        Some(errors) => nice_error_scale(errors),
        None => {
            let all: Vec<f64> = panels
                .iter()
                .filter_map(|p| p.errors.as_ref())
                .flatten()
                .copied()
                .collect();
            nice_error_scale(&all)
        }
    };
    let base = RenderOptions {
        width: args.panel_size.0,
        height: args.panel_size.1,
        azimuth_deg: view.0,
        elevation_deg: view.1,
        supersample: 2,
        bounds: Some(gt.bounding_box()),
        ..Default::default()
    };
    let mut images = Vec::with_capacity(panels.len());
    let mut labels = Vec::with_capacity(panels.len());
    for p in panels {
        let options = RenderOptions {
            face_colors: p.errors.as_ref().map(|e| error_colors(e, max)),
            ..base.clone()
        };
        images.push(
            render(&p.mesh, &options).with_context(|| format!("rendering {model} {}", p.label))?,
        );
        labels.push(p.label.clone());
    }
    let cols = if images.len() <= 4 {
        images.len()
    } else {
        images.len().div_ceil(2)
    };
    let grid = compose_grid(&images, cols, &labels);
    let bar = ColourBar::for_height(max, grid.height().min(2 * args.panel_size.1), "error (deg)");
    let body = append_colour_bar(&grid, &bar);
    let scale = (body.width() / 600).clamp(1, 3);
    let title_h = 8 * scale + 24;
    let mut out = Image::new(body.width(), body.height() + title_h, [255, 255, 255]);
    draw_lines(
        &mut out,
        8,
        8,
        &[format!(
            "{model}: faces coloured by angle to ground-truth normals"
        )],
        scale,
    );
    out.blit(&body, 0, title_h as i64);
    Ok(out)
}

/// The runs of an earlier `results.json` in `out`, for `--merge`.
fn previous_report(out: &Path) -> anyhow::Result<Option<BenchReport>> {
    let path = out.join("results.json");
    if !path.is_file() {
        return Ok(None);
    }
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let report: BenchReport = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a bench results file", path.display()))?;
    Ok(Some(report))
}

/// A finished run kept for the picture.
struct Finished {
    method: String,
    mesh: Mesh,
    e_a: f64,
}

/// The picture panels of one model: noisy, each method in column order (this
/// run's results, or with `--merge` the saved mesh of an earlier run), ground truth.
fn panels_for(
    model: &str,
    noisy: &Mesh,
    gt: &Mesh,
    finished: Vec<Finished>,
    report: &BenchReport,
    args: &Args,
) -> Vec<Panel> {
    let errors = |mesh: &Mesh| per_face_angle_errors(gt, mesh).ok();
    let mut panels = Vec::new();
    if let Some(r) = report
        .records
        .iter()
        .find(|r| r.model == model && r.method == NOISY)
        && let Some(e_a) = r.e_a_deg
    {
        panels.push(Panel {
            label: format!("{NOISY}\nE_a {e_a:.2} deg"),
            errors: errors(noisy),
            mesh: noisy.clone(),
            ranked_e_a: None,
        });
    }
    let mut finished: Vec<Option<Finished>> = finished.into_iter().map(Some).collect();
    for method in report.methods.iter().filter(|m| *m != NOISY) {
        let ranked = !report.unranked.contains(method);
        let this_run = finished
            .iter_mut()
            .find(|f| f.as_ref().is_some_and(|f| &f.method == method))
            .and_then(Option::take);
        let (mesh, e_a) = match this_run {
            Some(f) => (f.mesh, f.e_a),
            None => {
                // an earlier run's result, when it was saved with --save-meshes
                let Some(e_a) = report
                    .records
                    .iter()
                    .find(|r| r.model == model && &r.method == method && r.error.is_none())
                    .and_then(|r| r.e_a_deg)
                else {
                    continue;
                };
                match read_mesh(args.out.join(model).join(format!("{method}.obj"))) {
                    Ok(mesh) if mesh.faces == gt.faces => (mesh, e_a),
                    _ => continue,
                }
            }
        };
        panels.push(Panel {
            label: format!("{method}\nE_a {e_a:.2} deg"),
            errors: errors(&mesh),
            mesh,
            ranked_e_a: ranked.then_some(e_a),
        });
    }
    panels.push(Panel {
        label: "ground truth\n ".into(),
        mesh: gt.clone(),
        errors: None,
        ranked_e_a: None,
    });
    panels
}

/// Runs `normalnet bench`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let started = Instant::now();
    let settings = Settings::load(args.settings.as_deref())?;
    let methods: Vec<String> = if args.methods.is_empty() {
        METHODS
            .iter()
            .filter(|m| m.kind != Kind::Oracle)
            .map(|m| m.name.to_string())
            .collect()
    } else {
        args.methods
            .iter()
            .map(|m| m.trim().to_ascii_lowercase())
            .collect()
    };
    for m in &methods {
        if m == NOISY || base_method(m).is_none() {
            bail!(
                "unknown method `{m}` (known: {}, or a variant METHOD-NAME with its own settings)",
                normalnet_denoise::names().join(", ")
            );
        }
    }
    let SuiteInputs {
        inputs,
        groups,
        noise_labels,
    } = match &args.suite {
        Some(suite) => inputs_from_suite(suite, &args.cache, &args.models, quiet)?,
        None => SuiteInputs {
            inputs: inputs_from_data(&args.data, &args.models)?,
            groups: Vec::new(),
            noise_labels: Vec::new(),
        },
    };
    let models: Vec<String> = inputs.iter().map(|i| i.model.clone()).collect();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    let previous = if args.merge {
        previous_report(&args.out)?
    } else {
        None
    };
    let merged = previous.is_some();
    let mut report = previous.unwrap_or_default();
    report.title = "normalnet bench: E_a and E_v on noisy/clean pairs".into();
    for m in &models {
        if !report.models.contains(m) {
            report.models.push(m.clone());
        }
    }
    for m in &methods {
        if !report.methods.contains(m) {
            report.methods.push(m.clone());
        }
    }
    report.unranked = report
        .methods
        .iter()
        .filter(|m| base_method(m) == Some(ORACLE))
        .cloned()
        .collect();
    let old_notes = std::mem::take(&mut report.notes);
    if !report.unranked.is_empty() {
        report.notes.push(format!(
            "{}: GT-guided GNF (guidance = ground-truth normals, sigma_s = 2 d_s), NormalNet's training target \
             used as a denoiser; it reads the ground truth, so it is the ceiling a perfect CNN would reach, not a method",
            report.unranked.join(", ")
        ));
    }
    report.groups = groups;
    for (model, label) in noise_labels {
        report.noise_labels.retain(|(m, _)| m != &model);
        report.noise_labels.push((model, label));
    }
    match &args.suite {
        Some(suite) => report.notes.push(format!(
            "suite: {} (generated into {})",
            suite.display(),
            args.cache.display()
        )),
        None => report.notes.push(format!("data: {}", args.data.display())),
    }
    report.notes.push(format!("settings: {}", settings.source));
    report
        .notes
        .push(format!("threads: {}", rayon::current_num_threads()));
    if merged {
        report.notes.push(format!(
            "merged: runs of {} on {} are from this invocation; the others are kept from the earlier results.json",
            methods.join(", "),
            models.join(", ")
        ));
        for n in old_notes {
            let n = n
                .strip_prefix("earlier run: ")
                .map(str::to_string)
                .unwrap_or(n);
            if !report.notes.contains(&n) && !n.starts_with("merged: ") {
                report.notes.push(format!("earlier run: {n}"));
            }
        }
    }

    let total_runs = models.len() * methods.len();
    let mut run_index = 0;
    for input in &inputs {
        let model = &input.model;
        // runs redone here replace the earlier ones (model by model, so a
        // stopped bench keeps the earlier runs of the models it did not reach)
        report
            .records
            .retain(|r| !(&r.model == model && (r.method == NOISY || methods.contains(&r.method))));
        let load_start = Instant::now();
        let loaded = (|| -> anyhow::Result<(Mesh, Mesh)> {
            Ok((
                input::read_mesh(&input.noisy)?,
                input::read_mesh(&input.clean)?,
            ))
        })();
        let (noisy, gt) = match loaded {
            Ok(pair) => pair,
            Err(e) => {
                let secs = load_start.elapsed().as_secs_f64();
                report
                    .records
                    .push(failed(model, NOISY, String::new(), &e, secs));
                for m in &methods {
                    report
                        .records
                        .push(failed(model, m, String::new(), &e, 0.0));
                }
                run_index += methods.len();
                continue;
            }
        };
        match compare(&gt, &noisy) {
            Ok(m) => {
                report.records.push(record_from(
                    model,
                    NOISY,
                    String::new(),
                    &m,
                    None,
                    load_start.elapsed().as_secs_f64(),
                ));
                if !quiet {
                    stderr_line!(
                        "{model}: {} faces, noisy E_a {:.2} deg, E_v/l_e {:.4}",
                        noisy.num_faces(),
                        m.e_a_deg,
                        m.e_v_over_le
                    );
                }
            }
            Err(e) => {
                let e = anyhow::Error::from(e).context(format!(
                    "{model}: {} and {} do not match",
                    input.noisy.display(),
                    input.clean.display()
                ));
                report
                    .records
                    .push(failed(model, NOISY, String::new(), &e, 0.0));
            }
        }
        let mut finished = Vec::new();
        for method in &methods {
            run_index += 1;
            if settings.skips(model, method) {
                if !quiet {
                    stderr_line!(
                        "[{run_index}/{total_runs}] {model} {method}: skipped by the settings"
                    );
                }
                report.records.push(RunRecord {
                    model: model.clone(),
                    noise: split_model_name(model).1,
                    method: method.clone(),
                    skipped: Some(format!("{}: [models.\"{model}\"] skip", settings.source)),
                    ..Default::default()
                });
                continue;
            }
            let run_start = Instant::now();
            let bar = Bar::new(quiet);
            let mut params = String::new();
            let outcome = guarded(method, || {
                let (denoiser, described) = settings.denoiser(model, method)?;
                params = described;
                let t = Instant::now();
                let result = denoiser.denoise(&noisy, Some(&gt), &bar)?;
                let denoise_s = t.elapsed().as_secs_f64();
                let metrics = compare(&gt, &result).context("metrics of the result")?;
                Ok((result, denoise_s, metrics))
            });
            use normalnet_mesh::Progress as _;
            bar.finish();
            match outcome {
                Ok((result, denoise_s, metrics)) => {
                    if !quiet {
                        stderr_line!(
                            "[{run_index}/{total_runs}] {model} {method}: E_a {:.2} deg, E_v/l_e {:.4}, {denoise_s:.2} s",
                            metrics.e_a_deg,
                            metrics.e_v_over_le
                        );
                    }
                    if args.save_meshes {
                        let path = args.out.join(model).join(format!("{method}.obj"));
                        std::fs::create_dir_all(args.out.join(model))?;
                        normalnet_mesh::write_mesh(&path, &result)
                            .with_context(|| format!("saving {}", path.display()))?;
                    }
                    report.records.push(record_from(
                        model,
                        method,
                        params,
                        &metrics,
                        Some(denoise_s),
                        run_start.elapsed().as_secs_f64(),
                    ));
                    if args.render {
                        finished.push(Finished {
                            method: method.clone(),
                            mesh: result,
                            e_a: metrics.e_a_deg,
                        });
                    }
                }
                Err(e) => {
                    if !quiet {
                        stderr_line!("[{run_index}/{total_runs}] {model} {method}: failed: {e:#}");
                    }
                    report.records.push(failed(
                        model,
                        method,
                        params,
                        &e,
                        run_start.elapsed().as_secs_f64(),
                    ));
                }
            }
        }
        if args.render {
            let panels = panels_for(model, &noisy, &gt, finished, &report, &args);
            let view = settings.view(model).unwrap_or(args.view);
            let file = format!("{model}.png");
            report.pictures.retain(|(m, _)| m != model);
            match model_picture(model, &panels, &gt, &args, view)
                .and_then(|img| img.write_png(args.out.join(&file)).map_err(Into::into))
            {
                Ok(()) => report.pictures.push((model.clone(), file)),
                Err(e) => report.notes.push(format!("{model}: picture failed: {e:#}")),
            }
        }
        // keep the files current so a long bench can be watched (and survives a stop)
        label_noise(&mut report);
        write_report(&args.out, &report)
            .with_context(|| format!("writing the report into {}", args.out.display()))?;
    }
    report.notes.push(format!(
        "whole bench: {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    label_noise(&mut report);
    write_report(&args.out, &report)
        .with_context(|| format!("writing the report into {}", args.out.display()))?;
    if !quiet {
        stderr_line!(
            "wrote {}/table.md, results.csv, results.json, index.html",
            args.out.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(s: &Settings, model: &str, column: &str) -> Params {
        s.params(model, column).unwrap().1
    }

    #[test]
    fn builtin_settings_parse_and_apply_table_2() {
        let s = Settings::parse(BUILTIN_SETTINGS, "builtin").unwrap();
        let nn = |model: &str| {
            let p = given(&s, model, NORMALNET);
            (
                p["iterations"].clone(),
                p["vertex_iterations"].clone(),
                p["mu_g"].clone(),
            )
        };
        assert_eq!(nn("Fandisk0.3"), (10.into(), 20.into(), 0.25.into()));
        assert_eq!(nn("Bunny0.2"), (2.into(), 5.into(), 0.3.into()));
        assert_eq!(nn("SharpSphere0.3"), (10.into(), 20.into(), 0.35.into()));
        let (d, desc) = s.denoiser("Fandisk0.3", NORMALNET).unwrap();
        assert_eq!(d.name(), NORMALNET);
        assert!(desc.contains("mu_g=0.25"), "{desc}");
        let (_, desc) = s.denoiser("Twelve0.5Impulsive", "gnf").unwrap();
        assert!(
            desc.contains("normal_iterations=25") && desc.contains("mu_g=0.3"),
            "{desc}"
        );
    }

    #[test]
    fn variants_run_their_base_method_with_their_own_settings() {
        assert_eq!(base_method("gnf"), Some("gnf"));
        assert_eq!(base_method("gnf-ref"), Some("gnf"));
        assert_eq!(base_method("normalnet-fast"), Some(NORMALNET));
        assert_eq!(base_method("gt-gnf"), Some(ORACLE));
        assert_eq!(base_method("nosuch-x"), None);
        assert_eq!(base_method("gnfx"), None);
        let s = Settings::parse(
            "[defaults.gnf]\nmu_g = 0.25\n[defaults.\"gnf-ref\"]\nnormal_iterations = 3\n",
            "f.toml",
        )
        .unwrap();
        let (_, plain) = s.denoiser("M", "gnf").unwrap();
        let (_, variant) = s.denoiser("M", "gnf-ref").unwrap();
        assert!(
            plain.contains("mu_g=0.25") && plain.contains("normal_iterations=20"),
            "{plain}"
        );
        assert!(
            variant.contains("mu_g=0.35") && variant.contains("normal_iterations=3"),
            "{variant}"
        );
    }

    #[test]
    fn oracle_follows_the_normalnet_settings_then_its_own() {
        let s = Settings::parse(BUILTIN_SETTINGS, "builtin").unwrap();
        let (d, desc) = s.denoiser("Block0.4", ORACLE).unwrap();
        let p = d.parameters();
        assert_eq!(
            (
                p["iterations"].clone(),
                p["vertex_iterations"].clone(),
                p["mu_g"].clone()
            ),
            (20.into(), 30.into(), 0.3.into())
        );
        assert!(desc.contains("sigma_s_over_ds=2.0"), "{desc}");
        let s = Settings::parse(
            "[defaults.normalnet]\niterations = 4\nmodel = \"x\"\n[defaults.oracle]\nmu_g = 0.5\n",
            "f.toml",
        )
        .unwrap();
        let p = given(&s, "M", ORACLE);
        assert_eq!(
            (p["iterations"].clone(), p["mu_g"].clone()),
            (4.into(), 0.5.into())
        );
        assert!(p.get("model").is_none());
        let s = Settings::parse("[defaults.oracle]\nbogus = 1\n", "f.toml").unwrap();
        assert!(s.denoiser("M", ORACLE).is_err());
    }

    #[test]
    fn bad_settings_name_the_place() {
        let e = Settings::parse("[defaults.nosuch]\nx = 1\n", "f.toml").unwrap_err();
        assert!(
            format!("{e:#}").contains("f.toml: [defaults.nosuch]"),
            "{e:#}"
        );
        let s = Settings::parse("[models.\"M\".gnf]\nitersx = 3\n", "f.toml").unwrap();
        let e = s.denoiser("M", "gnf").unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.contains("unknown parameter `itersx`") && e.contains("f.toml: [models.\"M\".gnf]"),
            "{e}"
        );
        let s = Settings::parse("[defaults.normalnet]\nmu_g = \"a\"\n", "f.toml").unwrap();
        assert!(s.denoiser("M", NORMALNET).is_err());
        assert!(Settings::parse("[models.\"M\"]\nview = [0, 100]\n", "f.toml").is_err());
        assert!(Settings::parse("[models.\"M\"]\nskip = [\"nosuch\"]\n", "f.toml").is_err());
        let s = Settings::parse("[models.\"M\"]\nskip = [\"normalnet\"]\n", "f.toml").unwrap();
        assert!(s.skips("M", "normalnet") && !s.skips("M", "gnf") && !s.skips("N", "normalnet"));
    }
}
