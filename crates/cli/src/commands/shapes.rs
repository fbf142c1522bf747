//! `normalnet shapes`: procedural CAD-like training shapes (SPEC §8) as OBJ
//! files, optionally with a PNG contact sheet.

use crate::progress::Bar;
use anyhow::Context;
use normalnet_mesh::Progress;
use normalnet_mesh::io::write_mesh;
use normalnet_voxel::shapes::{self, ShapeKind};
use rayon::prelude::*;
use std::path::PathBuf;

/// Arguments of `normalnet shapes`.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory (created if missing).
    pub outdir: PathBuf,
    /// Number of shapes.
    #[arg(long, default_value_t = 10)]
    pub count: u64,
    /// First seed; shape i uses seed + i (its kind cycles with the seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Approximate faces per shape.
    #[arg(long, default_value_t = shapes::DEFAULT_FACES)]
    pub faces: usize,
    /// Only this kind (box, cylinder, cone, prism, chamfered, bevelled,
    /// notched, ruled, blob, union).
    #[arg(long)]
    pub kind: Option<String>,
    /// Also write a PNG contact sheet of the shapes.
    #[arg(long)]
    pub preview: Option<PathBuf>,
}

/// Runs `normalnet shapes`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let kind = args.kind.as_deref().map(ShapeKind::from_name).transpose()?;
    crate::output::check_dir(&args.outdir)?;
    if let Some(preview) = &args.preview {
        crate::output::check_file(preview, crate::output::PNG, "contact sheet")?;
    }
    std::fs::create_dir_all(&args.outdir)
        .with_context(|| format!("{}: cannot create directory", args.outdir.display()))?;
    let bar = Bar::new(quiet);
    bar.start("shapes", args.count);
    let seeds: Vec<u64> = (0..args.count).map(|i| args.seed + i).collect();
    let made = seeds
        .par_iter()
        .map(|&seed| {
            let k = kind.unwrap_or_else(|| ShapeKind::from_seed(seed));
            let mesh = shapes::generate(k, seed, args.faces)?;
            let path = args
                .outdir
                .join(format!("shape_{seed:05}_{}.obj", k.name()));
            write_mesh(&path, &mesh)?;
            bar.advance(1);
            Ok((path, k, mesh))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    bar.finish();
    let faces: usize = made.iter().map(|(_, _, m)| m.num_faces()).sum();
    if let Some(preview) = &args.preview {
        let options = normalnet_render::RenderOptions {
            width: 320,
            height: 320,
            supersample: 2,
            ..Default::default()
        };
        let images = made
            .iter()
            .map(|(_, _, m)| normalnet_render::render(m, &options))
            .collect::<Result<Vec<_>, _>>()?;
        let labels: Vec<String> = made
            .iter()
            .map(|(p, _, m)| {
                format!(
                    "{} {}F",
                    p.file_stem().unwrap_or_default().to_string_lossy(),
                    m.num_faces()
                )
            })
            .collect();
        let sheet = normalnet_render::compose_grid(&images, 5.min(images.len().max(1)), &labels);
        let png = sheet.encode_png()?;
        normalnet_mesh::io::write_atomically(preview, |w| w.write_all(&png))?;
    }
    if !quiet {
        stderr_line!(
            "wrote {} shapes ({} faces in all, {:.0} per shape) to {}",
            made.len(),
            faces,
            faces as f64 / made.len().max(1) as f64,
            args.outdir.display()
        );
    }
    Ok(())
}
