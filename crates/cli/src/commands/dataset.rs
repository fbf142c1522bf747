//! `normalnet dataset`: exports training samples (SPEC §8) for inspection:
//! voxel grids, the six GT-guided targets in the grid frame, the `A_p`
//! categories, drawn with equal counts per category.
//!
//! Inputs: a directory holding `Noisy.*` and `Original.*` (the layout of
//! `data/gd`), a pair `NOISY,CLEAN`, or a single clean mesh, which gets
//! Gaussian noise of level `--noise` (SPEC §2). Output files in `--out`:
//! `grids.npy` `[N, 3, D, H, W]` f32, `targets.npy` `[N, 6, 3]` f32,
//! `categories.npy` `[N]` u8, `items.npy` `[N, 2]` u32 (source, face),
//! `yaws.npy` `[N]` f32 (radians), `manifest.json`, and with `--pictures K`
//! PNG pictures of the first K grids.

use crate::input::read_mesh;
use crate::progress::Bar;
use anyhow::{Context, bail};
use normalnet_mesh::Progress;
use normalnet_mesh::noise::{NoiseParams, add_noise};
use normalnet_samples::source::{NUM_CATEGORIES, TARGET_LEN};
use normalnet_samples::{BalancedSampler, Loader, LoaderConfig, MU_GS, SampleSource};
use normalnet_voxel::VoxelParams;
use normalnet_voxel::inspect::{grid_picture, write_npy, write_png};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Test models that must never feed training (data/SOURCES.md).
const TEST_MODELS: [&str; 5] = [
    "Fandisk0.3",
    "Fandisk0.7",
    "Block0.4",
    "Twelve0.5Impulsive",
    "Bunny0.2",
];

/// Arguments of `normalnet dataset`.
#[derive(clap::Args)]
pub struct Args {
    /// Directories with Noisy.* + Original.*, `NOISY,CLEAN` pairs, or clean meshes.
    #[arg(required = true)]
    pub inputs: Vec<String>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Number of samples (split evenly over the non-empty A_p categories).
    #[arg(long, default_value_t = 400)]
    pub count: usize,
    /// Grid preset: paper, lite or tiny.
    #[arg(long, default_value = "lite")]
    pub preset: String,
    /// Seed of the draw, the yaw angles and the noise of clean inputs.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Random yaw augmentation.
    #[arg(long)]
    pub yaw: bool,
    /// Gaussian noise level L (σ = L·l_e) for clean-only inputs.
    #[arg(long, default_value_t = 0.3)]
    pub noise: f64,
    /// Also write PNG pictures of the first K grids.
    #[arg(long, default_value_t = 0)]
    pub pictures: usize,
}

fn find_in(dir: &Path, stem: &str) -> Option<PathBuf> {
    ["obj", "off", "ply", "stl"]
        .iter()
        .map(|e| dir.join(format!("{stem}.{e}")))
        .find(|p| p.exists())
}

/// Reads one input into (name, noisy, clean).
fn load(
    input: &str,
    noise: f64,
    seed: u64,
) -> anyhow::Result<(String, normalnet_mesh::Mesh, normalnet_mesh::Mesh)> {
    if let Some((a, b)) = input.split_once(',') {
        return Ok((input.to_string(), read_mesh(a)?, read_mesh(b)?));
    }
    let path = Path::new(input);
    if path.is_dir() {
        let (Some(noisy), Some(clean)) = (find_in(path, "Noisy"), find_in(path, "Original")) else {
            bail!("{input}: a directory must hold Noisy.* and Original.* (obj, off, ply or stl)");
        };
        return Ok((input.to_string(), read_mesh(noisy)?, read_mesh(clean)?));
    }
    let clean = read_mesh(path)?;
    let params = NoiseParams {
        level: noise,
        seed,
        ..Default::default()
    };
    let noisy = add_noise(&clean, &params).with_context(|| format!("{input}: adding noise"))?;
    Ok((
        format!("{input} (Gaussian noise L = {noise}, seed {seed})"),
        noisy,
        clean,
    ))
}

/// Runs `normalnet dataset`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let params = VoxelParams::from_name(&args.preset)?;
    crate::output::check_dir(&args.out)?;
    for input in &args.inputs {
        if let Some(t) = TEST_MODELS.iter().find(|t| input.contains(*t)) {
            stderr_line!(
                "warning: {input} looks like the test model {t}: never train on it (data/SOURCES.md)"
            );
        }
    }
    let bar = Bar::new(quiet);
    bar.start("sources", args.inputs.len() as u64);
    let mut names = Vec::new();
    let mut sources = Vec::new();
    for (i, input) in args.inputs.iter().enumerate() {
        let (name, noisy, clean) = load(input, args.noise, args.seed.wrapping_add(i as u64))?;
        let src =
            SampleSource::new(noisy, &clean, params, &MU_GS).with_context(|| input.clone())?;
        names.push(name);
        sources.push(src);
        bar.advance(1);
    }
    bar.finish();
    let sampler = BalancedSampler::new(&sources);
    let items = sampler.draw_count_seeded(args.count, args.seed);
    if items.is_empty() {
        bail!("no sampleable faces in the inputs");
    }
    let n = items.len();
    let sources = Arc::new(sources);
    let config = LoaderConfig {
        batch_size: 64,
        workers: 2,
        seed: args.seed,
        yaw_augmentation: args.yaw,
        ..Default::default()
    };
    let grid_len = params.grid_len();
    let mut grids = Vec::with_capacity(n * grid_len);
    let mut targets = Vec::with_capacity(n * TARGET_LEN);
    let mut yaws = Vec::with_capacity(n);
    bar.start("samples", n as u64);
    for batch in Loader::new(Arc::clone(&sources), items.clone(), config)? {
        grids.extend_from_slice(&batch.grids);
        targets.extend_from_slice(&batch.targets);
        yaws.extend(batch.yaws.iter().map(|&y| y as f32));
        bar.advance(batch.len() as u64);
    }
    bar.finish();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let side = params.side();
    write_npy(
        &args.out.join("grids.npy"),
        &[n, 3, side, side, side],
        &grids,
    )?;
    write_npy(&args.out.join("targets.npy"), &[n, 6, 3], &targets)?;
    let cats: Vec<u8> = items.iter().map(|i| i.category).collect();
    write_npy(&args.out.join("categories.npy"), &[n], &cats)?;
    let pairs: Vec<u32> = items.iter().flat_map(|i| [i.source, i.face]).collect();
    write_npy(&args.out.join("items.npy"), &[n, 2], &pairs)?;
    write_npy(&args.out.join("yaws.npy"), &[n], &yaws)?;
    for k in 0..args.pictures.min(n) {
        let (w, h, rgb) = grid_picture(&grids[k * grid_len..(k + 1) * grid_len], params, 6);
        write_png(&args.out.join(format!("grid_{k:04}.png")), w, h, &rgb)?;
    }
    let per_cat: Vec<usize> = (0..NUM_CATEGORIES)
        .map(|c| cats.iter().filter(|&&x| x as usize == c).count())
        .collect();
    let manifest = serde_json::json!({
        "preset": args.preset,
        "t_s": params.t_s,
        "alpha_c": params.alpha_c,
        "layout": "grids [N, 3, D, H, W] with D = local x, H = local y (2-ring mean normal), W = local z",
        "mu_gs": MU_GS,
        "a_p_categories": [">80", "50-80", "20-50", "<=20"],
        "samples_per_category": per_cat,
        "seed": args.seed,
        "yaw_augmentation": args.yaw,
        "sources": names,
        "pool_sizes": sampler.category_sizes(),
    });
    let text = serde_json::to_string_pretty(&manifest)?;
    normalnet_mesh::io::write_atomically(&args.out.join("manifest.json"), |w| {
        w.write_all(text.as_bytes())
    })?;
    if !quiet {
        stderr_line!(
            "wrote {n} samples ({:?} per A_p category >80/50-80/20-50/<=20) from {} sources to {}",
            per_cat,
            sources.len(),
            args.out.display()
        );
    }
    Ok(())
}
