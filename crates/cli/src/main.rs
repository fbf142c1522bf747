//! `normalnet`: mesh denoising with NormalNet and the classical filters.
//! One subcommand per file under `commands/`. Commands write their report
//! to stdout through a handle (`writeln!`, not `println!`), so that a closed
//! stdout (`normalnet info x.obj | head -1`) is an error the command returns
//! and [`main`] ends quietly with 141 (128 + SIGPIPE, what a shell reports
//! for a program the pipe killed), instead of a panic. Lines on stderr go
//! through `stderr_line!` (`stderr.rs`), which cannot panic either.
#![deny(clippy::print_stderr)]

#[macro_use]
mod stderr;
mod commands;
mod input;
mod mesh_output;
mod output;
mod progress;

use clap::{Parser, Subcommand};

/// Mesh denoising: NormalNet (learned normal filtering) and classical filters.
#[derive(Parser)]
#[command(name = "normalnet", version, about, long_about = None)]
struct Cli {
    /// No progress bars.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Worker threads (default: every core, or $RAYON_NUM_THREADS). Results
    /// do not depend on it.
    #[arg(long, short = 'j', global = true, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Denoise a mesh (NormalNet by default, or a classical method).
    Denoise(Box<commands::denoise::Args>),
    /// Denoise every mesh of a folder or pattern (resumable, with a summary).
    Batch(Box<commands::batch::Args>),
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
    /// Compare two bench runs of one suite: per group the mean E_a of each,
    /// the difference and who wins.
    Compare(commands::compare::Args),
    /// Render a mesh to PNG (optionally coloured by error against GT).
    Render(commands::render::Args),
    /// Describe a NormalNet model bundle (the built-in one by default), or
    /// convert an old one.
    Models(commands::models::Args),
}

fn main() {
    let cli = Cli::parse();
    let quiet = cli.quiet;
    if let Some(n) = cli.threads {
        // Only fails when a pool already exists, which cannot be the case
        // before any work.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(usize::from(n))
            .build_global();
    }
    // SIGINT / SIGTERM end the process without running destructors, so a
    // temporary output file being written would stay behind: sweep this
    // process's temporary files from the checked output folders, then exit
    // as a shell expects (128 + SIGINT). Best effort: without a handler the
    // signal kills the process as before.
    // The message is best effort too: a closed stderr must not stop the
    // exit.
    let _ = ctrlc::set_handler(|| {
        let removed = output::remove_temp_files();
        if removed > 0 {
            stderr_line!("interrupted: removed {removed} temporary file(s)");
        } else {
            stderr_line!("interrupted");
        }
        std::process::exit(130);
    });
    // a forced kernel path the CPU lacks is refused before any work
    let result = normalnet_denoise::isa::from_env()
        .map_err(anyhow::Error::from)
        .and_then(|_| run(cli.command, quiet));
    if let Err(e) = result {
        if is_broken_pipe(&e) {
            // the reader of stdout is gone: nothing to tell, nobody to tell
            std::process::exit(141);
        }
        stderr_line!("error: {}", error_chain(&e));
        std::process::exit(1);
    }
}

/// Runs one subcommand.
fn run(command: Command, quiet: bool) -> anyhow::Result<()> {
    match command {
        // bench creates its folder before any work itself; checked here so
        // that an interruption also sweeps its temporary files
        Command::Bench(a) => {
            output::check_dir(&a.out).and_then(|()| commands::bench::run(a, quiet))
        }
        Command::Compare(a) => commands::compare::run(a, quiet),
        Command::Denoise(a) => commands::denoise::run(*a, quiet),
        Command::Batch(a) => output::check_dir(&a.out).and_then(|()| {
            // a rerun after a SIGKILL: the killed run's temporary file goes
            let removed = output::remove_stale_temp_files(&a.out);
            if removed > 0 {
                stderr_line!(
                    "{}: removed {removed} temporary file(s) of an interrupted run",
                    a.out.display()
                );
            }
            commands::batch::run(*a, quiet)
        }),
        Command::Noise(a) => commands::noise::run(a, quiet),
        Command::Metrics(a) => commands::metrics::run(a, quiet),
        Command::Info(a) => commands::info::run(a, quiet),
        Command::Voxelize(a) => commands::voxelize::run(a, quiet),
        Command::Shapes(a) => commands::shapes::run(a, quiet),
        Command::Dataset(a) => commands::dataset::run(a, quiet),
        Command::Train(a) => commands::train::run(a, quiet),
        Command::Render(a) => commands::render::run(a, quiet),
        Command::Models(a) => commands::models::run(a, quiet),
    }
}

/// Whether `e` comes from writing to a closed pipe.
fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The error and its causes, `: `-separated like anyhow's `{:#}`, without a
/// cause whose text its parent already ends with: library errors such as
/// `MeshError::Io` print their OS error and also return it as their source,
/// which `{:#}` printed twice ("x.obj: No such file or directory (os error
/// 2): No such file or directory (os error 2)").
fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issue_14_os_errors_are_printed_once() {
        let e = normalnet_mesh::read_mesh("/nonexistent/x.obj").unwrap_err();
        let e = anyhow::Error::new(e).context("reading /nonexistent/x.obj");
        let text = error_chain(&e);
        assert_eq!(text.matches("os error").count(), 1, "{text}");
        assert!(
            text.starts_with("reading /nonexistent/x.obj: /nonexistent/x.obj: "),
            "{text}"
        );
        // Distinct causes are all kept.
        let e = anyhow::anyhow!("inner").context("middle").context("outer");
        assert_eq!(error_chain(&e), "outer: middle: inner");
    }
}
