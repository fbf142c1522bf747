//! Denoising with NormalNet (paper §3, SPEC §7): for each filtering iteration
//! k = 1..N_f, voxelize every face of the current mesh, run the network of
//! k's interval in batches, take the output for the user's μ_g (nearest of
//! the six), normalise it, rotate it back with `W_rᵀ` (the face frame's
//! `to_world`), then move the vertices N_v times (Sun et al. 2007).
//!
//! Voxelization and the CNN overlap: a producer thread voxelizes batch b+1
//! (in parallel over its faces) while the network runs on batch b. Only a
//! few batches of grids exist at any time (the buffers are recycled), so a
//! mesh of a million faces needs the same grid memory as a small one.

use std::sync::mpsc::sync_channel;
use std::time::Instant;

use burn::tensor::Device;
use normalnet_filters::{VertexUpdateBuffers, vertex_update_in_place};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Progress, Topology};
use normalnet_voxel::{Frame, VoxelParams, Voxelizer};
use serde::Serialize;

use crate::NetError;
use crate::bundle::{Bundle, network_for_iteration};
use crate::data::{grids_tensor, tensor_to_vec};
use crate::model::{NUM_OUTPUTS, NormalNet};

/// Settings of [`denoise`]; `Default` is SPEC §7.
#[derive(Clone, Debug, PartialEq)]
pub struct DenoiseParams {
    /// N_f, filtering iterations (default 10)
    pub iterations: usize,
    /// N_v, vertex-update passes per iteration (default 20)
    pub vertex_iterations: usize,
    /// μ_g; the nearest of the bundle's six outputs is used (default 0.35)
    pub mu_g: f64,
    /// faces per network batch (default 256)
    pub batch: usize,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        DenoiseParams {
            iterations: 10,
            vertex_iterations: 20,
            mu_g: 0.35,
            batch: 256,
        }
    }
}

impl DenoiseParams {
    /// Checks the ranges; the error names the field.
    pub fn validate(&self) -> Result<(), NetError> {
        if self.iterations == 0 {
            return Err(NetError::InvalidParameter {
                name: "iterations",
                message: "N_f must be at least 1".into(),
            });
        }
        if !(self.mu_g.is_finite() && self.mu_g > 0.0) {
            return Err(NetError::InvalidParameter {
                name: "mu_g",
                message: format!("μ_g = {} must be finite and positive", self.mu_g),
            });
        }
        if self.batch == 0 {
            return Err(NetError::InvalidParameter {
                name: "batch",
                message: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// Wall-clock seconds per stage, summed over iterations.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// building the voxelizer and voxelizing (producer thread; overlaps the CNN)
    pub voxelize_s: f64,
    /// network forward passes and output conversion
    pub cnn_s: f64,
    /// vertex updates
    pub vertex_update_s: f64,
    /// whole run
    pub total_s: f64,
    /// faces voxelized and run through the network (all iterations)
    pub faces_processed: usize,
}

impl StageTimes {
    fn add(&mut self, other: &StageTimes) {
        self.voxelize_s += other.voxelize_s;
        self.cnn_s += other.cnn_s;
        self.vertex_update_s += other.vertex_update_s;
        self.faces_processed += other.faces_processed;
    }
}

/// Denoises `mesh` with the bundle's networks (SPEC §7). Returns the mesh
/// (same vertex and face order) and the time spent per stage.
///
/// # Errors
/// Invalid parameters, a mesh the voxelizer rejects (no edge-adjacent faces),
/// or a non-finite network output.
pub fn denoise(
    mesh: &Mesh,
    bundle: &Bundle,
    params: &DenoiseParams,
    progress: &dyn Progress,
) -> Result<(Mesh, StageTimes), NetError> {
    params.validate()?;
    let start = Instant::now();
    let slot = bundle.output_for_mu_g(params.mu_g);
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut positions = mesh.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let mut times = StageTimes::default();
    let total = (params.iterations * mesh.num_faces()) as u64;
    progress.start("NormalNet", total);
    for k in 1..=params.iterations {
        progress.message(&format!("iteration {k}/{}", params.iterations));
        let current = mesh.with_positions(positions.clone());
        let net = &bundle.networks[network_for_iteration(k)];
        let (normals, t) = filtered_normals(
            &current,
            &topology,
            net,
            bundle.voxel_params(),
            slot,
            params.batch,
            &bundle.device,
            None,
            progress,
        )?;
        times.add(&t);
        let t = Instant::now();
        vertex_update_in_place(
            &mut positions,
            &mesh.faces,
            &topology,
            &normals,
            params.vertex_iterations,
            &mut buffers,
        );
        times.vertex_update_s += t.elapsed().as_secs_f64();
    }
    progress.finish();
    times.total_s = start.elapsed().as_secs_f64();
    Ok((mesh.with_positions(positions), times))
}

/// One normal-filtering pass with one network: the world-frame normal of
/// output `slot` for every face of `mesh` (len #F, unit length).
///
/// `yaws` (one per face, radians) rotates each face's frame about its local
/// y axis; `None` = no yaw (what [`denoise`] uses). `progress` advances by
/// one per face.
///
/// # Errors
/// Voxelizer errors (degenerate scale) and [`NetError::NonFiniteOutput`].
#[allow(clippy::too_many_arguments)]
pub fn filtered_normals(
    mesh: &Mesh,
    topology: &Topology,
    net: &NormalNet,
    voxel: VoxelParams,
    slot: usize,
    batch: usize,
    device: &Device,
    yaws: Option<&[f64]>,
    progress: &dyn Progress,
) -> Result<(Vec<Vec3>, StageTimes), NetError> {
    let mut times = StageTimes::default();
    let t = Instant::now();
    let voxelizer = Voxelizer::new(mesh, topology, voxel)?;
    let fallback = face_normals(mesh);
    times.voxelize_s += t.elapsed().as_secs_f64();
    let n = mesh.num_faces();
    let side = voxel.side();
    let grid_len = voxel.grid_len();
    let batch = batch.max(1);
    let mut normals = vec![[0.0; 3]; n];
    // two buffers in flight: one being voxelized, one in the network
    let (full_tx, full_rx) = sync_channel::<(usize, Vec<f32>, Vec<Frame>, f64)>(1);
    let (empty_tx, empty_rx) = sync_channel::<Vec<f32>>(3);
    for _ in 0..2 {
        empty_tx
            .send(Vec::with_capacity(batch.min(n) * grid_len))
            .ok();
    }
    let faces: Vec<u32> = (0..n as u32).collect();
    let result = std::thread::scope(|scope| -> Result<(), NetError> {
        let voxelizer = &voxelizer;
        let faces = &faces;
        // owned here so that an early error return drops them and the
        // producer stops instead of blocking
        let full_rx = full_rx;
        let empty_tx = empty_tx;
        scope.spawn(move || {
            for start in (0..n).step_by(batch) {
                let Ok(mut buf) = empty_rx.recv() else { return };
                let end = (start + batch).min(n);
                let t = Instant::now();
                buf.clear();
                buf.resize((end - start) * grid_len, 0.0);
                let frames = voxelizer.voxelize_batch_yaw(
                    &faces[start..end],
                    yaws.map(|y| &y[start..end]),
                    &mut buf,
                );
                let dt = t.elapsed().as_secs_f64();
                if full_tx.send((start, buf, frames, dt)).is_err() {
                    return;
                }
            }
        });
        for (start, buf, frames, dt) in full_rx.iter() {
            times.voxelize_s += dt;
            let t = Instant::now();
            let len = frames.len();
            let out = tensor_to_vec(net.forward(grids_tensor(&buf, len, side, device)));
            empty_tx.send(buf).ok();
            for (i, frame) in frames.iter().enumerate() {
                let f = start + i;
                let o = &out[i * NUM_OUTPUTS + 3 * slot..i * NUM_OUTPUTS + 3 * slot + 3];
                let local = [o[0] as f64, o[1] as f64, o[2] as f64];
                if !local.iter().all(|v| v.is_finite()) {
                    return Err(NetError::NonFiniteOutput { face: f });
                }
                let unit = vec3::normalize_or_zero(local);
                normals[f] = if unit == [0.0; 3] {
                    fallback[f]
                } else {
                    frame.to_world(unit)
                };
            }
            times.cnn_s += t.elapsed().as_secs_f64();
            times.faces_processed += len;
            progress.advance(len as u64);
        }
        Ok(())
    });
    result?;
    Ok((normals, times))
}
