//! The fixed validation faces of each network and its error on them.

use normalnet_mesh::vec3;
use normalnet_samples::BalancedSampler;
use normalnet_voxel::VoxelParams;

use super::pairs::{Pair, sample_sources};
use super::{TrainConfig, VALIDATION_SLOT};
use crate::NetError;
use crate::arch::NUM_OUTPUTS;
use crate::data::SampleBatch;

/// Fixed validation faces of one stage: grids (yaw 0) and targets.
pub(super) struct ValidationSet {
    batch: SampleBatch,
    /// the mean angle of the faces' current normals to their targets
    pub(super) baseline_deg: f64,
    /// with residual targets: each face's input normal in its local frame
    /// (added to outputs and targets before comparing)
    inputs: Option<Vec<[f32; 3]>>,
}

/// The validation faces of network `k` (0-based): drawn balanced from the
/// validation meshes at their current states, seeded per network.
pub(super) fn validation_set(
    pairs: &[Pair],
    voxel: VoxelParams,
    config: &TrainConfig,
    k: usize,
    residual: bool,
) -> Result<ValidationSet, NetError> {
    let sources = sample_sources(pairs, voxel, residual)?;
    let mut inputs = Vec::new();
    let mut scratch = normalnet_voxel::Scratch::new();
    let sampler = BalancedSampler::new(sources.iter());
    let items = sampler.draw_count_seeded(config.validation_faces, config.seed + 99 + k as u64);
    let mut batch = SampleBatch::with_capacity(voxel.side(), items.len());
    let grid_len = voxel.grid_len();
    let mut baseline = 0.0;
    for it in &items {
        let src = &sources[it.source as usize];
        let start = batch.grids.len();
        batch.grids.resize(start + grid_len, 0.0);
        let (t, frame) = src.sample_with(
            &mut scratch,
            it.face as usize,
            0.0,
            &mut batch.grids[start..],
        );
        batch.targets.extend_from_slice(&t);
        inputs.push(src.local_input(&frame, it.face as usize));
        let current = src.voxelizer().geometry().normals[it.face as usize];
        let target = src.world_targets(it.face as usize)[VALIDATION_SLOT];
        baseline += vec3::angle(current, target).to_degrees();
    }
    batch.len = items.len();
    Ok(ValidationSet {
        baseline_deg: baseline / items.len().max(1) as f64,
        batch,
        inputs: residual.then_some(inputs),
    })
}

/// Mean angle (degrees) between the μ_g-0.35 output and its target, on the
/// CPU inference engine (same outputs as burn's inference mode).
pub(super) fn validation_error(cnn: &normalnet_cnn::Cnn, val: &ValidationSet) -> f64 {
    if val.batch.len == 0 {
        return f64::NAN;
    }
    let mut out = vec![0.0f32; val.batch.len * NUM_OUTPUTS];
    if cnn.forward(&val.batch.grids, &mut out).is_err() {
        return f64::NAN;
    }
    let mut sum = 0.0;
    for i in 0..val.batch.len {
        let o = &out[i * NUM_OUTPUTS + 3 * VALIDATION_SLOT..][..3];
        let t = &val.batch.targets[i * NUM_OUTPUTS + 3 * VALIDATION_SLOT..][..3];
        let base = val.inputs.as_ref().map_or([0.0; 3], |v| v[i]);
        let o = [
            (o[0] + base[0]) as f64,
            (o[1] + base[1]) as f64,
            (o[2] + base[2]) as f64,
        ];
        let t = [
            (t[0] + base[0]) as f64,
            (t[1] + base[1]) as f64,
            (t[2] + base[2]) as f64,
        ];
        sum += if vec3::norm(o) == 0.0 || !vec3::norm(o).is_finite() {
            90.0
        } else {
            vec3::angle(o, t).to_degrees()
        };
    }
    sum / val.batch.len as f64
}
