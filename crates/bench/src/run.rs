//! A bench run: the report started (or merged with an earlier one), every
//! model's pair loaded and measured, every method run on it, its picture,
//! the report rewritten after each model.

use anyhow::{Context, bail};
use normalnet_denoise::{Kind, METHODS};
use normalnet_mesh::metrics::{Metrics, compare};
use normalnet_mesh::{Mesh, Progress};
use normalnet_render::report::{BenchReport, NOISY, RunRecord, split_model_name, write_report};
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::inputs::{BenchInput, SuiteInputs, inputs_from_data, inputs_from_suite};
use crate::picture::{Finished, model_picture, panels_for};
use crate::settings::{ORACLE, Settings, base_method};

/// What a bench run does (the flags of `normalnet bench`).
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Folder with one sub-folder per model holding `Noisy.obj` and `Original.obj`.
    pub data: PathBuf,
    /// A validation suite instead of `data`.
    pub suite: Option<PathBuf>,
    /// Cache folder of the suite's generated meshes.
    pub cache: PathBuf,
    /// Methods (columns, variants `METHOD-NAME` included); empty: every
    /// method but the oracle.
    pub methods: Vec<String>,
    /// Models (folder or pair names); empty: all.
    pub models: Vec<String>,
    /// Settings file; `None`: `./configs/bench.toml` if present, else [`crate::BUILTIN_SETTINGS`].
    pub settings: Option<PathBuf>,
    /// Output folder (created if needed).
    pub out: PathBuf,
    /// Also write one picture per model.
    pub render: bool,
    /// Size of one picture panel, width and height.
    pub panel_size: (u32, u32),
    /// Camera azimuth and elevation of the pictures (a model's `view` in the settings wins).
    pub view: (f64, f64),
    /// Also save every result mesh as `OUT/MODEL/METHOD.obj`.
    pub save_meshes: bool,
    /// Keep the runs of an earlier `OUT/results.json` this run does not redo.
    pub merge: bool,
}

/// Where a bench run reports to.
pub trait BenchUi {
    /// One line for the user (a model's noisy figures, a method's result or failure).
    fn line(&self, text: &str);
    /// The progress display of one long step (a method's run, a suite's generation).
    fn progress(&self) -> Box<dyn Progress>;
    /// A mesh the bench read from `path` (the CLI warns about its outliers).
    fn mesh_read(&self, _path: &Path, _mesh: &Mesh) {}
}

/// Runs the bench `options` describes and writes its report
/// (`table.md`, `results.csv`, `results.json`, `index.html`, pictures) into
/// `options.out`, rewritten after each model.
///
/// # Errors
/// Bad settings, methods or inputs (before any run); an output that cannot
/// be written. A method that fails on a model is a failed cell, not an error.
pub fn run(options: &BenchOptions, ui: &dyn BenchUi) -> anyhow::Result<()> {
    let started = Instant::now();
    let settings = Settings::load(options.settings.as_deref())?;
    let methods = methods_of(&options.methods)?;
    let SuiteInputs {
        inputs,
        groups,
        noise_labels,
    } = match &options.suite {
        Some(suite) => inputs_from_suite(suite, &options.cache, &options.models, ui)?,
        None => SuiteInputs {
            inputs: inputs_from_data(&options.data, &options.models)?,
            groups: Vec::new(),
            noise_labels: Vec::new(),
        },
    };
    let models: Vec<String> = inputs.iter().map(|i| i.model.clone()).collect();
    std::fs::create_dir_all(&options.out)
        .with_context(|| format!("creating {}", options.out.display()))?;
    let mut report = start_report(options, &settings, &methods, &models)?;
    report.groups = groups;
    for (model, label) in noise_labels {
        report.noise_labels.retain(|(m, _)| m != &model);
        report.noise_labels.push((model, label));
    }
    let mut bench = Bench {
        options,
        ui,
        total_runs: models.len() * methods.len(),
        settings,
        methods,
        report,
        run_index: 0,
    };
    for input in &inputs {
        bench.model(input)?;
    }
    let Bench {
        mut report,
        options,
        ..
    } = bench;
    report.notes.push(format!(
        "whole bench: {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    save(&mut report, &options.out)?;
    ui.line(&format!(
        "wrote {}/table.md, results.csv, results.json, index.html",
        options.out.display()
    ));
    Ok(())
}

/// The columns asked for (lower case), checked; every method but the
/// oracle when none is.
fn methods_of(asked: &[String]) -> anyhow::Result<Vec<String>> {
    let methods: Vec<String> = if asked.is_empty() {
        METHODS
            .iter()
            .filter(|m| m.kind != Kind::Oracle)
            .map(|m| m.name.to_string())
            .collect()
    } else {
        asked
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
    Ok(methods)
}

/// The report this run starts from: new, or with `merge` the earlier
/// `results.json` (its notes kept as "earlier run"), with this run's models,
/// methods and notes (data, settings, threads) added.
fn start_report(
    options: &BenchOptions,
    settings: &Settings,
    methods: &[String],
    models: &[String],
) -> anyhow::Result<BenchReport> {
    let previous = if options.merge {
        previous_report(&options.out)?
    } else {
        None
    };
    let merged = previous.is_some();
    let mut report = previous.unwrap_or_default();
    report.title = "normalnet bench: E_a and E_v on noisy/clean pairs".into();
    for m in models {
        if !report.models.contains(m) {
            report.models.push(m.clone());
        }
    }
    for m in methods {
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
    match &options.suite {
        Some(suite) => report.notes.push(format!(
            "suite: {} (generated into {})",
            suite.display(),
            options.cache.display()
        )),
        None => report
            .notes
            .push(format!("data: {}", options.data.display())),
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
    Ok(report)
}

/// A bench under way: its report and how far it got.
struct Bench<'a> {
    options: &'a BenchOptions,
    ui: &'a dyn BenchUi,
    settings: Settings,
    methods: Vec<String>,
    report: BenchReport,
    /// runs (model × method) in all, and done so far
    total_runs: usize,
    run_index: usize,
}

impl Bench<'_> {
    /// Every method on one model's pair, its picture, the report saved.
    /// The runs redone here replace the earlier ones (model by model, so a
    /// stopped bench keeps the earlier runs of the models it did not reach).
    fn model(&mut self, input: &BenchInput) -> anyhow::Result<()> {
        let model = &input.model;
        let methods = &self.methods;
        self.report
            .records
            .retain(|r| !(&r.model == model && (r.method == NOISY || methods.contains(&r.method))));
        let Some((noisy, gt)) = self.load_pair(input) else {
            return Ok(());
        };
        let mut finished = Vec::new();
        for method in self.methods.clone() {
            if let Some(result) = self.method(model, &method, &noisy, &gt)? {
                finished.push(result);
            }
        }
        if self.options.render {
            self.picture(model, &noisy, &gt, finished);
        }
        // keep the files current so a long bench can be watched (and survives a stop)
        save(&mut self.report, &self.options.out)
    }

    /// The model's noisy input and ground truth, with the noisy input's
    /// record; `None` (every run of the model failed with the reason) when
    /// a file cannot be read.
    fn load_pair(&mut self, input: &BenchInput) -> Option<(Mesh, Mesh)> {
        let model = &input.model;
        let started = Instant::now();
        let read = |path: &Path| -> anyhow::Result<Mesh> {
            let mesh = normalnet_mesh::read_mesh(path)?;
            self.ui.mesh_read(path, &mesh);
            Ok(mesh)
        };
        let loaded = read(&input.noisy).and_then(|noisy| Ok((noisy, read(&input.clean)?)));
        let (noisy, gt) = match loaded {
            Ok(pair) => pair,
            Err(e) => {
                let secs = started.elapsed().as_secs_f64();
                let records = &mut self.report.records;
                records.push(failed(model, NOISY, String::new(), &e, secs));
                for m in &self.methods {
                    records.push(failed(model, m, String::new(), &e, 0.0));
                }
                self.run_index += self.methods.len();
                return None;
            }
        };
        match compare(&gt, &noisy) {
            Ok(m) => {
                let secs = started.elapsed().as_secs_f64();
                self.report
                    .records
                    .push(record_from(model, NOISY, String::new(), &m, None, secs));
                self.ui.line(&format!(
                    "{model}: {} faces, noisy E_a {:.2} deg, E_v/l_e {:.4}",
                    noisy.num_faces(),
                    m.e_a_deg,
                    m.e_v_over_le
                ));
            }
            Err(e) => {
                let e = anyhow::Error::from(e).context(format!(
                    "{model}: {} and {} do not match",
                    input.noisy.display(),
                    input.clean.display()
                ));
                self.report
                    .records
                    .push(failed(model, NOISY, String::new(), &e, 0.0));
            }
        }
        Some((noisy, gt))
    }

    /// Column `method` on `model`: skipped by the settings, or run with its
    /// settings (a panic or error is a failed cell), its record added and
    /// its result saved with `save_meshes`. The result, for the picture,
    /// when `render`.
    fn method(
        &mut self,
        model: &str,
        method: &str,
        noisy: &Mesh,
        gt: &Mesh,
    ) -> anyhow::Result<Option<Finished>> {
        self.run_index += 1;
        let at = format!("[{}/{}] {model} {method}", self.run_index, self.total_runs);
        if self.settings.skips(model, method) {
            self.ui.line(&format!("{at}: skipped by the settings"));
            self.report.records.push(RunRecord {
                skipped: Some(format!(
                    "{}: [models.\"{model}\"] skip",
                    self.settings.source
                )),
                ..record(model, method, String::new())
            });
            return Ok(None);
        }
        let started = Instant::now();
        let bar = self.ui.progress();
        let mut params = String::new();
        let outcome = guarded(method, || {
            let (denoiser, described) = self.settings.denoiser(model, method)?;
            params = described;
            let t = Instant::now();
            let result = denoiser.denoise(noisy, Some(gt), &*bar)?;
            let denoise_s = t.elapsed().as_secs_f64();
            let metrics = compare(gt, &result).context("metrics of the result")?;
            Ok((result, denoise_s, metrics))
        });
        bar.finish();
        let (result, denoise_s, metrics) = match outcome {
            Ok(done) => done,
            Err(e) => {
                self.ui.line(&format!("{at}: failed: {e:#}"));
                let secs = started.elapsed().as_secs_f64();
                self.report
                    .records
                    .push(failed(model, method, params, &e, secs));
                return Ok(None);
            }
        };
        self.ui.line(&format!(
            "{at}: E_a {:.2} deg, E_v/l_e {:.4}, {denoise_s:.2} s",
            metrics.e_a_deg, metrics.e_v_over_le
        ));
        if self.options.save_meshes {
            let dir = self.options.out.join(model);
            let path = dir.join(format!("{method}.obj"));
            std::fs::create_dir_all(&dir)?;
            normalnet_mesh::write_mesh(&path, &result)
                .with_context(|| format!("saving {}", path.display()))?;
        }
        let secs = started.elapsed().as_secs_f64();
        self.report.records.push(record_from(
            model,
            method,
            params,
            &metrics,
            Some(denoise_s),
            secs,
        ));
        Ok(self.options.render.then(|| Finished {
            method: method.to_string(),
            mesh: result,
            e_a: metrics.e_a_deg,
        }))
    }

    /// The model's picture (`MODEL.png`), or a note saying why it failed.
    fn picture(&mut self, model: &str, noisy: &Mesh, gt: &Mesh, finished: Vec<Finished>) {
        let options = self.options;
        let panels = panels_for(model, noisy, gt, finished, &self.report, &options.out);
        let view = self.settings.view(model).unwrap_or(options.view);
        let file = format!("{model}.png");
        self.report.pictures.retain(|(m, _)| m != model);
        match model_picture(model, &panels, gt, options.panel_size, view)
            .and_then(|img| img.write_png(options.out.join(&file)).map_err(Into::into))
        {
            Ok(()) => self.report.pictures.push((model.to_string(), file)),
            Err(e) => self
                .report
                .notes
                .push(format!("{model}: picture failed: {e:#}")),
        }
    }
}

/// Writes the report (its records labelled with their noise) into `out`.
fn save(report: &mut BenchReport, out: &Path) -> anyhow::Result<()> {
    label_noise(report);
    write_report(out, report).with_context(|| format!("writing the report into {}", out.display()))
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

/// The record of `method` on `model` with nothing measured yet.
fn record(model: &str, method: &str, params: String) -> RunRecord {
    RunRecord {
        model: model.to_string(),
        noise: split_model_name(model).1,
        method: method.to_string(),
        params,
        ..Default::default()
    }
}

/// The record of a run that gave metrics `m`.
fn record_from(
    model: &str,
    method: &str,
    params: String,
    m: &Metrics,
    denoise_s: Option<f64>,
    total_s: f64,
) -> RunRecord {
    RunRecord {
        e_a_deg: Some(m.e_a_deg),
        e_v: Some(m.e_v),
        e_v_over_le: Some(m.e_v_over_le),
        hausdorff: Some(m.hausdorff),
        flipped_faces: Some(m.flipped_faces),
        denoise_seconds: denoise_s,
        total_seconds: Some(total_s),
        ..record(model, method, params)
    }
}

/// The record of a run that failed with `error`.
fn failed(
    model: &str,
    method: &str,
    params: String,
    error: &anyhow::Error,
    total_s: f64,
) -> RunRecord {
    RunRecord {
        total_seconds: Some(total_s),
        error: Some(format!("{error:#}")),
        ..record(model, method, params)
    }
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
