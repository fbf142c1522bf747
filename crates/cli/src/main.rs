//! `normalnet`: mesh denoising with NormalNet and the classical filters.
//! One subcommand per file under `commands/`.

mod commands;
mod progress;

use clap::{Parser, Subcommand};

/// Mesh denoising: NormalNet (learned normal filtering) and classical filters.
#[derive(Parser)]
#[command(name = "normalnet", version, about, long_about = None)]
struct Cli {
    /// No progress bars.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Denoise a mesh (NormalNet by default, or a classical method).
    Denoise(commands::denoise::Args),
    /// Add synthetic noise to a clean mesh (SPEC §2).
    Noise(commands::noise::Args),
    /// Error metrics of a result against ground truth (E_a, E_v, ...).
    Metrics(commands::metrics::Args),
    /// Counts, bounding box, edge length, defects of a mesh.
    Info(commands::info::Args),
    /// Write the voxel grid the network sees for one face.
    Voxelize(commands::voxelize::Args),
    /// Generate procedural CAD-like training shapes.
    Shapes(commands::shapes::Args),
    /// Export a small set of training samples to disk for inspection.
    Dataset(commands::dataset::Args),
    /// Train a NormalNet model bundle.
    Train(commands::train::Args),
    /// Run methods over noisy/clean pairs and write the comparison table.
    Bench(commands::bench::Args),
    /// Render a mesh to PNG (optionally coloured by error against GT).
    Render(commands::render::Args),
}

fn main() {
    let cli = Cli::parse();
    let quiet = cli.quiet;
    let result = match cli.command {
        Command::Denoise(a) => commands::denoise::run(a, quiet),
        Command::Noise(a) => commands::noise::run(a, quiet),
        Command::Metrics(a) => commands::metrics::run(a, quiet),
        Command::Info(a) => commands::info::run(a, quiet),
        Command::Voxelize(a) => commands::voxelize::run(a, quiet),
        Command::Shapes(a) => commands::shapes::run(a, quiet),
        Command::Dataset(a) => commands::dataset::run(a, quiet),
        Command::Train(a) => commands::train::run(a, quiet),
        Command::Bench(a) => commands::bench::run(a, quiet),
        Command::Render(a) => commands::render::run(a, quiet),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
