//! `normalnet train`: trains a NormalNet model bundle with the iterative
//! scheme of the paper (§4, SPEC §8); see `normalnet_net::training`.

use anyhow::Context;
use normalnet_mesh::Progress;
use normalnet_net::training::{TrainConfig, train};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

/// Arguments of `normalnet train`.
#[derive(clap::Args)]
pub struct Args {
    /// Network size: paper, lite or tiny (overrides the config's `preset`).
    #[arg(long)]
    pub preset: Option<String>,
    /// Output folder: the bundle (net1..6.bpk, manifest.toml), train_log.csv,
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
    let log = LogLines::new(quiet || std::io::stderr().is_terminal());
    let both = Both(&bar, &log);
    let manifest = train(&config, &args.out, args.resume, &both)
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

/// Progress as plain lines on stderr at most every 15 s (for logs written
/// under nohup, where the bar is hidden).
struct LogLines {
    off: bool,
    last: Mutex<Option<Instant>>,
    start: Instant,
}

impl LogLines {
    fn new(off: bool) -> LogLines {
        LogLines {
            off,
            last: Mutex::new(None),
            start: Instant::now(),
        }
    }
}

impl Progress for LogLines {
    fn start(&self, label: &str, total: u64) {
        if !self.off {
            eprintln!(
                "[{:>6.0} s] {label}: {total} steps",
                self.start.elapsed().as_secs_f64()
            );
        }
    }
    fn message(&self, text: &str) {
        if self.off {
            return;
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_none_or(|t| t.elapsed().as_secs_f64() >= 15.0) {
            eprintln!("[{:>6.0} s] {text}", self.start.elapsed().as_secs_f64());
            *last = Some(Instant::now());
        }
    }
}

struct Both<'a>(&'a dyn Progress, &'a dyn Progress);

impl Progress for Both<'_> {
    fn start(&self, label: &str, total: u64) {
        self.0.start(label, total);
        self.1.start(label, total);
    }
    fn advance(&self, n: u64) {
        self.0.advance(n);
        self.1.advance(n);
    }
    fn message(&self, text: &str) {
        self.0.message(text);
        self.1.message(text);
    }
    fn finish(&self) {
        self.0.finish();
        self.1.finish();
    }
}
