//! `normalnet train`: trains a NormalNet model bundle with the iterative
//! scheme of the paper (§4, SPEC §8); see `normalnet_net::training`.

use anyhow::Context;
use normalnet_net::training::{TrainConfig, train};
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
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Continue an interrupted run in --out.
    #[arg(long)]
    pub resume: bool,
}

/// Runs `normalnet train`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let mut config = match &args.config {
        Some(p) => TrainConfig::read(p).with_context(|| format!("reading {}", p.display()))?,
        None => anyhow::bail!("--config is required (see configs/train-lite.toml)"),
    };
    if let Some(p) = &args.preset {
        config.preset = p.clone();
    }
    crate::output::check_dir(&args.out)?;
    let bar = crate::progress::Bar::new(quiet);
    let manifest = train(&config, &args.out, args.resume, &bar)
        .with_context(|| format!("training into {}", args.out.display()))?;
    println!("bundle written to {}", args.out.display());
    for n in &manifest.networks {
        println!(
            "  {} iterations {:?}: {} steps, validation {:.2}° (input {:.2}°), {:.0} s",
            n.file,
            n.interval,
            n.steps,
            n.validation_error_deg,
            n.validation_baseline_deg,
            n.train_seconds
        );
    }
    Ok(())
}
