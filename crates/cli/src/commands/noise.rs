//! `normalnet noise`: adds the literature's synthetic noise to a clean mesh
//! (SPEC §2, `normalnet_mesh::noise`): `σ = L·l_e`, Gaussian or impulsive,
//! along the clean vertex normals or random directions, seeded. The output
//! keeps what the input file carries, as with `denoise` (issue 38;
//! `--triangulate` for triangles instead of the input's polygons).

use super::info::{format_for, parse_format};
use crate::input::read_mesh_file_as;
use crate::mesh_output::write_result;
use anyhow::Context;
use normalnet_mesh::io::{FileWriteOptions, Format, check_encodable};
use normalnet_mesh::noise::{NoiseDirection, NoiseParams, add_noise_with_info};
use std::path::PathBuf;

/// Arguments of `normalnet noise`.
#[derive(clap::Args)]
pub struct Args {
    /// Clean input mesh.
    pub input: PathBuf,
    /// Noisy output mesh (format from the extension; written atomically).
    pub output: PathBuf,
    /// Noise level L: σ = L · mean edge length [default: 0.3].
    #[arg(long, allow_negative_numbers = true)]
    pub level: Option<f64>,
    /// Impulsive noise: move only this fraction of the vertices (0..1).
    #[arg(long, value_name = "FRACTION", allow_negative_numbers = true)]
    pub impulsive: Option<f64>,
    /// Displacement direction [default: normal].
    #[arg(long, value_enum)]
    pub direction: Option<Direction>,
    /// Random seed (same seed, same output bytes).
    #[arg(long)]
    pub seed: u64,
    /// Read the input as this format whatever its extension.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<Format>,
    /// Write PLY output as ASCII (default: a PLY input's encoding, binary
    /// for any other input).
    #[arg(long)]
    pub ply_ascii: bool,
    /// Write triangles instead of the input's polygons.
    #[arg(long)]
    pub triangulate: bool,
}

/// `--direction` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Direction {
    /// Along the clean vertex normal.
    Normal,
    /// Along a random unit vector per vertex.
    Random,
}

/// Runs `normalnet noise`.
pub fn run(args: Args, _quiet: bool) -> anyhow::Result<()> {
    crate::output::check_file(&args.output, crate::output::MESH, "output mesh")?;
    crate::output::check_not_input(&args.output, &[&args.input])?;
    let file = read_mesh_file_as(&args.input, format_for(&args.input, args.format)?)
        .with_context(|| format!("reading {}", args.input.display()))?;
    let clean = &file.mesh;
    let out_format = format_for(&args.output, None)?;
    check_encodable(&args.output, clean, out_format).with_context(|| {
        format!(
            "{}: its coordinates do not fit the output format",
            args.input.display()
        )
    })?;
    let defaults = NoiseParams::default();
    let params = NoiseParams {
        level: args.level.unwrap_or(defaults.level),
        impulsive_fraction: args.impulsive,
        direction: match args.direction {
            None => defaults.direction,
            Some(Direction::Normal) => NoiseDirection::Normal,
            Some(Direction::Random) => NoiseDirection::Random,
        },
        seed: args.seed,
    };
    let (noisy, info) = add_noise_with_info(clean, &params)
        .with_context(|| format!("adding noise to {}", args.input.display()))?;
    write_result(
        &args.output,
        out_format,
        &noisy,
        &file.attributes,
        &args.input,
        &FileWriteOptions {
            triangulate: args.triangulate,
            ply_ascii: args.ply_ascii,
        },
    )?;
    stderr_line!(
        "{}: {} noise, level {} (sigma {:.6} = {} x l_e {:.6}), {} of {} vertices moved along {:?}, seed {}",
        args.output.display(),
        if params.impulsive_fraction.is_some() {
            "impulsive"
        } else {
            "gaussian"
        },
        params.level,
        info.sigma,
        params.level,
        info.mean_edge_length,
        info.displaced,
        noisy.num_vertices(),
        params.direction,
        params.seed
    );
    Ok(())
}
