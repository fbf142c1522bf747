//! `normalnet train`: trains a NormalNet model bundle with the iterative
//! scheme of the paper (§4, SPEC §8; `normalnet_net::training`), or, with
//! `--method cnr`, a CNR model (SPEC §9.1; `normalnet_denoise::cnr::train`)
//! on the same training sources and validation meshes. With `--recipe`,
//! every stage of a recipe (`configs/recipes/*.toml`,
//! `normalnet_denoise::recipe`): networks, switch rows and fits, the
//! evaluation, resumed where an earlier run in `--out` stopped.

use anyhow::Context;
use normalnet_denoise::cnr::train::{CnrTrainSettings, train_from_config};
use normalnet_net::training::{TrainConfig, train};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `normalnet train`.
#[derive(clap::Args)]
pub struct Args {
    /// Network size: paper, lite or tiny (overrides the config's `preset`).
    #[arg(long)]
    pub preset: Option<String>,
    /// Output folder: the bundle (net1..6.safetensors, manifest.toml), train_log.csv,
    /// loss.png, checkpoints.
    #[arg(long)]
    pub out: PathBuf,
    /// Training configuration (TOML; see configs/train-lite.toml).
    #[arg(long, conflicts_with = "recipe")]
    pub config: Option<PathBuf>,
    /// A recipe (configs/recipes/*.toml): runs every stage that makes a
    /// bundle; run again with the same --out it continues where it stopped.
    #[arg(long)]
    pub recipe: Option<PathBuf>,
    /// With --recipe: print what a run on --out would do with each stage
    /// (done, continue, run, changed: cleared and run again) and stop
    #[arg(long, requires = "recipe")]
    pub plan: bool,
    /// Continue an interrupted run in --out (normalnet).
    #[arg(long)]
    pub resume: bool,
    /// What to train: normalnet (a bundle) or cnr (OUT/cnr.json; the
    /// config's sources, validation and seed).
    #[arg(long, default_value = "normalnet", value_parser = ["normalnet", "cnr"])]
    pub method: String,
    /// CNR: hidden width of each regressor.
    #[arg(long, default_value_t = CnrTrainSettings::default().hidden)]
    pub hidden: usize,
    /// CNR: clusters per stage.
    #[arg(long, default_value_t = CnrTrainSettings::default().clusters)]
    pub clusters: usize,
    /// CNR: passes over each cluster's faces.
    #[arg(long, default_value_t = CnrTrainSettings::default().epochs)]
    pub epochs: usize,
    /// CNR: the descriptor's neighbourhood in vertex rings (SPEC: 1).
    #[arg(long, default_value_t = CnrTrainSettings::default().ring)]
    pub ring: usize,
    /// CNR: cascade stages.
    #[arg(long, default_value_t = CnrTrainSettings::default().stages)]
    pub stages: usize,
    /// CNR: training faces per stage at most (a seeded subsample of all).
    #[arg(long, default_value_t = CnrTrainSettings::default().max_samples)]
    pub max_samples: usize,
}

/// `normalnet train --method cnr`.
fn train_cnr(args: &Args, config: &TrainConfig, quiet: bool) -> anyhow::Result<()> {
    let bar = crate::progress::Bar::new(quiet);
    let settings = CnrTrainSettings {
        hidden: args.hidden,
        clusters: args.clusters,
        epochs: args.epochs,
        ring: args.ring,
        stages: args.stages,
        max_samples: args.max_samples,
        seed: config.seed,
        ..CnrTrainSettings::default()
    };
    settings
        .validate()
        .map_err(|e| anyhow::anyhow!("--{}", e.replace('_', "-")))?;
    let start = std::time::Instant::now();
    let mut model = train_from_config(config, &settings, &bar)?;
    model.training.push(format!(
        "trained by `normalnet train --method cnr` with {} in {:.0} s",
        args.config
            .as_ref()
            .map_or("<none>".into(), |p| p.display().to_string()),
        start.elapsed().as_secs_f64()
    ));
    std::fs::create_dir_all(&args.out)?;
    let path = args.out.join("cnr.json");
    model
        .write(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "CNR model written to {}", path.display())?;
    for line in &model.training {
        writeln!(out, "  {line}")?;
    }
    Ok(())
}

/// `normalnet train --recipe`.
fn train_recipe(recipe: &std::path::Path, args: &Args, quiet: bool) -> anyhow::Result<()> {
    if args.preset.is_some() || args.resume || args.method != "normalnet" {
        anyhow::bail!(
            "--recipe takes no --preset, --resume or --method: the recipe says what to train, and a run always resumes"
        );
    }
    if args.plan {
        let mut out = std::io::stdout().lock();
        for (stage, what) in normalnet_denoise::recipe::plan(recipe, &args.out)? {
            writeln!(out, "  {stage}: {what}")?;
        }
        return Ok(());
    }
    crate::output::check_dir(&args.out)?;
    let bar = crate::progress::Bar::new(quiet);
    let start = std::time::Instant::now();
    let outcome = normalnet_denoise::recipe::run(recipe, &args.out, &bar)?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{} written to {} ({:.0} s)",
        if outcome.manifest.is_some() {
            "bundle"
        } else {
            "CNR model (cnr.json)"
        },
        args.out.display(),
        start.elapsed().as_secs_f64()
    )?;
    for (stage, ran) in &outcome.stages {
        writeln!(
            out,
            "  {stage}: {}",
            if *ran { "ran" } else { "done before" }
        )?;
    }
    if let Some(e) = outcome
        .manifest
        .as_ref()
        .and_then(|m| m.evaluation.as_ref())
    {
        writeln!(out, "  validation ({}): all {:.3}°", e.suite, e.all_deg)?;
        for (group, deg) in &e.groups {
            writeln!(out, "    {group} {deg:.3}°")?;
        }
    }
    Ok(())
}

/// Runs `normalnet train`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    if let Some(recipe) = &args.recipe {
        return train_recipe(recipe, &args, quiet);
    }
    let mut config = match &args.config {
        Some(p) => TrainConfig::read(p).with_context(|| format!("reading {}", p.display()))?,
        None => anyhow::bail!("--config is required (see configs/train-lite.toml)"),
    };
    if let Some(p) = &args.preset {
        config.preset = p.clone();
    }
    crate::output::check_dir(&args.out)?;
    if args.method == "cnr" {
        return train_cnr(&args, &config, quiet);
    }
    let bar = crate::progress::Bar::new(quiet);
    let manifest = train(&config, &args.out, args.resume, &bar)
        .with_context(|| format!("training into {}", args.out.display()))?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "bundle written to {}", args.out.display())?;
    for n in &manifest.networks {
        writeln!(
            out,
            "  {} iterations {:?}: {} steps, validation {:.2}° (input {:.2}°), {:.0} s",
            n.file,
            n.interval,
            n.steps,
            n.validation_error_deg,
            n.validation_baseline_deg,
            n.train_seconds
        )?;
    }
    Ok(())
}
