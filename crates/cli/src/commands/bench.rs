//! `normalnet bench`: its flags, parsed into the bench engine's options
//! (`normalnet_bench`, where the settings, runs, merge and pictures live),
//! and the terminal it reports to.

use crate::commands::render::{parse_size, parse_view};
use crate::input::warn_outliers;
use crate::progress::Bar;
use normalnet_bench::{BenchOptions, BenchUi};
use normalnet_mesh::{Mesh, Progress};
use std::path::{Path, PathBuf};

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

/// Runs `normalnet bench`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let options = BenchOptions {
        data: args.data,
        suite: args.suite,
        cache: args.cache,
        methods: args.methods,
        models: args.models,
        settings: args.settings,
        out: args.out,
        render: args.render,
        panel_size: args.panel_size,
        view: args.view,
        save_meshes: args.save_meshes,
        merge: args.merge,
    };
    normalnet_bench::run(&options, &Terminal { quiet })
}

/// Lines and progress bars on stderr (none with `--quiet`).
struct Terminal {
    quiet: bool,
}

impl BenchUi for Terminal {
    fn line(&self, text: &str) {
        if !self.quiet {
            stderr_line!("{text}");
        }
    }

    fn progress(&self) -> Box<dyn Progress> {
        Box::new(Bar::new(self.quiet))
    }

    fn mesh_read(&self, path: &Path, mesh: &Mesh) {
        warn_outliers(path, mesh);
    }
}
