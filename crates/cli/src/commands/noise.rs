//! `normalnet noise`: adds the literature's synthetic noise to a clean mesh
//! (SPEC §2, `normalnet_mesh::noise`): `σ = L·l_e`, Gaussian or impulsive,
//! along the clean vertex normals or random directions, seeded; and
//! scanner-like noise: along a viewing direction with depth-dependent σ,
//! spatially correlated (low-frequency), and mixtures of components. The
//! output keeps what the input file carries, as with `denoise` (issue 38;
//! `--triangulate` for triangles instead of the input's polygons).

use super::info::{format_for, parse_format};
use crate::input::read_mesh_file_as;
use crate::mesh_output::write_result;
use anyhow::Context;
use normalnet_mesh::io::{FileWriteOptions, Format, check_encodable};
use normalnet_mesh::noise::{NoiseDirection, NoiseParams, add_noise_mixture};
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
    /// View direction X,Y,Z of `--direction view` [default: drawn from the seed].
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_negative_numbers = true)]
    pub view_dir: Option<[f64; 3]>,
    /// Depth-dependent σ for `--direction view`: σ_i = L·l_e·(1 + K·depth_i), depth from 0 (the
    /// vertex nearest the viewer) to 1 (the farthest) along the view direction [default: 0].
    #[arg(long, value_name = "K")]
    pub depth_gain: Option<f64>,
    /// Spatially correlated, low-frequency noise: a smooth random field with correlation length
    /// LAMBDA mean edge lengths (Gaussian covariance), instead of independent offsets per vertex.
    #[arg(long, value_name = "LAMBDA")]
    pub correlation: Option<f64>,
    /// Add another noise component (a mixture; repeatable), e.g. `impulsive=0.1,level=1.5`. Keys:
    /// level, impulsive, direction (normal|random|view), view=X:Y:Z, depth_gain, correlation, seed
    /// [default seed: --seed + the component's position]. Each is computed on the clean mesh and
    /// the displacements add up.
    #[arg(long, value_name = "SPEC")]
    pub mix: Vec<String>,
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
    /// Along one view direction (--view-dir, or drawn from the seed), like a range scanner.
    View,
}

fn parse_vec3(text: &str) -> Result<[f64; 3], String> {
    let c: Vec<f64> = text
        .split(',')
        .map(|c| {
            c.trim()
                .parse::<f64>()
                .map_err(|_| format!("{c:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    c.try_into()
        .map_err(|_| format!("expected X,Y,Z (three numbers), got {text:?}"))
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
            Some(Direction::View) => NoiseDirection::View,
        },
        seed: args.seed,
        view_direction: args.view_dir,
        depth_gain: args.depth_gain.unwrap_or(defaults.depth_gain),
        correlation_length: args.correlation,
    };
    let mut components = vec![params];
    for (k, spec) in args.mix.iter().enumerate() {
        let base = NoiseParams {
            seed: args.seed.wrapping_add(k as u64 + 1),
            ..defaults
        };
        components
            .push(NoiseParams::parse_spec(spec, &base).with_context(|| format!("--mix {spec}"))?);
    }
    let (noisy, infos) = add_noise_mixture(clean, &components)
        .with_context(|| format!("adding noise to {}", args.input.display()))?;
    let info = infos[0];
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
    for (c, i) in components.iter().zip(&infos).skip(1) {
        stderr_line!("  + {c:?}: {} vertices moved", i.displaced);
    }
    Ok(())
}
