//! The noisy/clean pairs a run trains and validates on, and how they move
//! from one network's state to the next.

use std::path::PathBuf;

use normalnet_cnn::Cnn;
use normalnet_filters::{GtGuidedGnfParams, gt_guided_gnf};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::noise::add_noise_mixture;
use normalnet_mesh::vec3::Vec3;
use normalnet_mesh::{Mesh, NoProgress, NoiseParams, Progress, Topology};
use normalnet_samples::SampleSource;
use normalnet_voxel::VoxelParams;

use super::{MIXTURE_SEED, REGEN_MU_G, REGEN_VERTEX_ITERATIONS, SourceSpec, TrainConfig};
use crate::NetError;
use crate::arch::MU_GS;
use crate::pipeline::filtered_normals;

/// A noisy/clean pair and its current state M_k.
pub(super) struct Pair {
    pub(super) name: String,
    pub(super) clean: Mesh,
    pub(super) gt: Vec<Vec3>,
    pub(super) state: Mesh,
    pub(super) regen: bool,
}

fn load_source(config: &TrainConfig, spec: &SourceSpec) -> Result<Mesh, NetError> {
    if let Some(rest) = spec.mesh.strip_prefix("shape:") {
        let bad = || NetError::BadConfig {
            path: PathBuf::from("<config>"),
            message: format!("{}: expected shape:SEED or shape:KIND:SEED", spec.mesh),
        };
        // shape:SEED (the kind the seed picks) or shape:KIND:SEED
        let (kind, seed) = match rest.split_once(':') {
            Some((kind, seed)) => (
                Some(normalnet_voxel::shapes::ShapeKind::from_name(kind)?),
                seed,
            ),
            None => (None, rest),
        };
        let seed: u64 = seed.parse().map_err(|_| bad())?;
        Ok(match kind {
            Some(kind) => normalnet_voxel::shapes::generate(kind, seed, config.shape_faces)?,
            None => normalnet_voxel::shapes::generate_seeded(seed, config.shape_faces)?,
        })
    } else {
        Ok(normalnet_mesh::read_mesh(
            config.data_dir().join(&spec.mesh),
        )?)
    }
}

/// The noisy copies of `specs` as `make_pairs` builds them for training
/// (same names, noise levels and seeds): `(name, clean, noisy)`. Other
/// learned methods (CNR) train on exactly NormalNet's data through it.
pub fn noisy_pairs(
    config: &TrainConfig,
    specs: &[SourceSpec],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<(String, Mesh, Mesh)>, NetError> {
    Ok(make_pairs(config, specs, seed, progress)?
        .into_iter()
        .map(|p| (p.name, p.clean, p.state))
        .collect())
}

pub(super) fn make_pairs(
    config: &TrainConfig,
    specs: &[SourceSpec],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<Pair>, NetError> {
    let mut pairs = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        progress.message(&format!("loading {}", spec.mesh));
        let clean = load_source(config, spec)?;
        let gt = face_normals(&clean);
        let mut copies: Vec<(String, Vec<NoiseParams>)> = Vec::new();
        for (j, &l) in spec.gaussian.iter().enumerate() {
            copies.push((
                format!("{} gaussian L={l}", spec.mesh),
                vec![NoiseParams {
                    level: l,
                    seed: seed + 1000 * i as u64 + j as u64,
                    ..NoiseParams::default()
                }],
            ));
        }
        for (j, &[l, p]) in spec.impulsive.iter().enumerate() {
            copies.push((
                format!("{} impulsive L={l} p={p}", spec.mesh),
                vec![NoiseParams {
                    level: l,
                    impulsive_fraction: Some(p),
                    seed: seed + 1000 * i as u64 + 500 + j as u64,
                    ..NoiseParams::default()
                }],
            ));
        }
        for (j, copy) in spec.noise.iter().enumerate() {
            let base = seed + 1000 * i as u64 + MIXTURE_SEED + 10 * j as u64;
            let components: Vec<NoiseParams> = copy
                .iter()
                .enumerate()
                .map(|(k, c)| NoiseParams {
                    seed: base + k as u64 + c.seed,
                    ..*c
                })
                .collect();
            copies.push((format!("{} noise {}", spec.mesh, j + 1), components));
        }
        for (name, noise) in copies {
            let (noisy, _) = add_noise_mixture(&clean, &noise)?;
            pairs.push(Pair {
                name,
                clean: clean.clone(),
                gt: gt.clone(),
                state: noisy,
                regen: spec.regen,
            });
        }
    }
    Ok(pairs)
}

/// The pairs' names joined for the manifest ("none" when there are none).
pub(super) fn names<'a>(pairs: impl Iterator<Item = &'a Pair>) -> String {
    let list: Vec<&str> = pairs.map(|p| p.name.as_str()).collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join("; ")
    }
}

/// Runs `passes` filtering iterations on every pair's state: network `net`
/// for pairs marked `regen`, the GT-guided oracle for the others.
#[allow(clippy::too_many_arguments)]
pub(super) fn regenerate(
    pairs: &mut [Pair],
    net: &Cnn,
    residual: bool,
    voxel: VoxelParams,
    passes: usize,
    batch: usize,
    progress: &dyn Progress,
) -> Result<(), NetError> {
    let slot = crate::bundle::nearest_mu_g(&MU_GS, REGEN_MU_G);
    for p in pairs.iter_mut() {
        progress.message(&format!("regenerating {} ({} passes)", p.name, passes));
        if p.regen {
            let topology = Topology::new(p.state.num_vertices(), &p.state.faces);
            let mut positions = p.state.positions.clone();
            let mut buffers = normalnet_filters::VertexUpdateBuffers::default();
            for _ in 0..passes {
                let current = p.state.with_positions(positions.clone());
                let (normals, _) = filtered_normals(
                    &current,
                    &topology,
                    net,
                    residual,
                    voxel,
                    slot,
                    batch,
                    None,
                    &NoProgress,
                )?;
                normalnet_filters::vertex_update_in_place(
                    &mut positions,
                    &p.state.faces,
                    &topology,
                    &normals,
                    REGEN_VERTEX_ITERATIONS,
                    &mut buffers,
                );
            }
            p.state = p.state.with_positions(positions);
        } else {
            let params = GtGuidedGnfParams {
                mu_g: REGEN_MU_G,
                iterations: passes,
                vertex_iterations: REGEN_VERTEX_ITERATIONS,
                ..GtGuidedGnfParams::default()
            };
            p.state = gt_guided_gnf(&p.state, &p.gt, &params, &NoProgress)?;
        }
    }
    Ok(())
}

/// The training samples of `pairs` at their current states (targets as
/// residuals with `residual`).
pub(super) fn sample_sources(
    pairs: &[Pair],
    voxel: VoxelParams,
    residual: bool,
) -> Result<Vec<SampleSource>, NetError> {
    Ok(pairs
        .iter()
        .map(|p| {
            SampleSource::new(p.state.clone(), &p.clean, voxel, &MU_GS)
                .map(|s| s.with_residual(residual))
        })
        .collect::<Result<_, _>>()?)
}
