//! The network stage: the filtered normals of a set of faces from one
//! network (voxelize in batches on a producer thread, run the CNN on the
//! batch before, rotate the outputs back to the world frame).
//!
//! Voxelization and the CNN overlap: a producer thread voxelizes batch b+1
//! (in parallel over its faces) while the network runs on batch b. Only a
//! few batches of grids exist at any time (the buffers are recycled), so a
//! mesh of a million faces needs the same grid memory as a small one.

use std::sync::mpsc::sync_channel;
use std::time::Instant;

use normalnet_cnn::Cnn;
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Progress, Topology};
use normalnet_voxel::{Frame, SparseGrid, VoxelParams, Voxelizer};

use super::StageTimes;
use crate::NetError;
use crate::arch::NUM_OUTPUTS;
use crate::bundle::Bundle;

/// One normal-filtering pass with one network: the world-frame normal of
/// output `slot` for every face of `mesh` (len #F, unit length).
///
/// With `residual`, the network's output is added to the face's current
/// normal (in the local frame) before normalising (see
/// [`crate::bundle::NetworkInfo::residual`]).
///
/// `yaws` (one per face, radians) rotates each face's frame about its local
/// y axis; `None` = no yaw (what [`super::denoise`] uses). `progress` advances by
/// one per face. The network runs on the CPU engine of `normalnet-cnn`.
///
/// # Errors
/// Voxelizer errors (degenerate scale) and [`NetError::NonFiniteOutput`].
#[allow(clippy::too_many_arguments)]
pub fn filtered_normals(
    mesh: &Mesh,
    topology: &Topology,
    cnn: &Cnn,
    residual: bool,
    voxel: VoxelParams,
    slot: usize,
    batch: usize,
    yaws: Option<&[f64]>,
    progress: &dyn Progress,
) -> Result<(Vec<Vec3>, StageTimes), NetError> {
    let mut normals = vec![[0.0; 3]; mesh.num_faces()];
    let faces: Vec<u32> = (0..mesh.num_faces() as u32).collect();
    let pass = NetworkPass {
        cnn,
        residual,
        voxel,
        slot,
        batch,
    };
    let times = pass.normals_of(mesh, topology, &faces, yaws, &mut normals, progress)?;
    Ok((normals, times))
}

/// One network as a filtering pass runs it.
#[derive(Clone, Copy, Debug)]
pub struct NetworkPass<'a> {
    /// the compiled network
    pub cnn: &'a Cnn,
    /// it predicts the residual to the face's current normal
    pub residual: bool,
    /// the grid it reads
    pub voxel: VoxelParams,
    /// the output (μ_g) taken
    pub slot: usize,
    /// faces per network batch
    pub batch: usize,
}

impl<'a> NetworkPass<'a> {
    /// Network `i` (0-based) of `bundle`, output `slot`.
    pub fn of_bundle(bundle: &'a Bundle, i: usize, slot: usize, batch: usize) -> NetworkPass<'a> {
        NetworkPass {
            cnn: &bundle.engines[i],
            residual: bundle.manifest.networks[i].residual,
            voxel: bundle.voxel_params(),
            slot,
            batch,
        }
    }

    /// [`filtered_normals`] of the listed `faces` only, written into their
    /// entries of `normals` (len #F; the other entries are left as they
    /// are); `yaws`, when given, is indexed by face. Returns the stage
    /// times.
    ///
    /// # Errors
    /// As [`filtered_normals`].
    pub fn normals_of(
        &self,
        mesh: &Mesh,
        topology: &Topology,
        faces: &[u32],
        yaws: Option<&[f64]>,
        normals: &mut [Vec3],
        progress: &dyn Progress,
    ) -> Result<StageTimes, NetError> {
        let NetworkPass {
            cnn,
            residual,
            voxel,
            slot,
            batch,
        } = *self;
        let mut times = StageTimes::default();
        let t = Instant::now();
        let voxelizer = Voxelizer::new(mesh, topology, voxel)?;
        if cnn.grid_len() != voxel.grid_len() {
            return Err(NetError::InvalidParameter {
                name: "network",
                message: format!(
                    "the network reads grids of {} values, the voxelizer writes {}",
                    cnn.grid_len(),
                    voxel.grid_len()
                ),
            });
        }
        let fallback = face_normals(mesh);
        times.voxelize_s += t.elapsed().as_secs_f64();
        let n = faces.len();
        let batch = batch.max(1);
        // two batches in flight: one being voxelized, one in the network; the
        // grids go sparse (only their occupied cubes) from one to the other
        let (full_tx, full_rx) = sync_channel::<(usize, Vec<SparseGrid>, Vec<Frame>, f64)>(1);
        let (empty_tx, empty_rx) = sync_channel::<Vec<SparseGrid>>(3);
        for _ in 0..2 {
            empty_tx.send(Vec::new()).ok();
        }
        let result = std::thread::scope(|scope| -> Result<(), NetError> {
            let voxelizer = &voxelizer;
            // owned here so that an early error return drops them and the
            // producer stops instead of blocking
            let full_rx = full_rx;
            let empty_tx = empty_tx;
            scope.spawn(move || {
                for start in (0..n).step_by(batch) {
                    let Ok(mut buf) = empty_rx.recv() else { return };
                    let end = (start + batch).min(n);
                    let t = Instant::now();
                    let batch_faces = &faces[start..end];
                    let batch_yaws: Option<Vec<f64>> =
                        yaws.map(|y| batch_faces.iter().map(|&f| y[f as usize]).collect());
                    let frames = voxelizer.voxelize_batch_sparse(
                        batch_faces,
                        batch_yaws.as_deref(),
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
                let mut out = vec![0.0f32; len * NUM_OUTPUTS];
                let samples: Vec<(&[u32], &[f32])> =
                    buf.iter().map(|g| (&g.cells[..], &g.values[..])).collect();
                cnn.forward_sparse(&samples, &mut out)
                    .map_err(|e| NetError::InvalidParameter {
                        name: "network",
                        message: e.to_string(),
                    })?;
                empty_tx.send(buf).ok();
                for (i, frame) in frames.iter().enumerate() {
                    let f = faces[start + i] as usize;
                    let o = &out[i * NUM_OUTPUTS + 3 * slot..i * NUM_OUTPUTS + 3 * slot + 3];
                    let mut local = [o[0] as f64, o[1] as f64, o[2] as f64];
                    if residual {
                        local = vec3::add(local, frame.to_local(fallback[f]));
                    }
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
        Ok(times)
    }
}

/// Turns the network outputs of `faces` in `normals` (those of yaw 0) into
/// the normalised mean over `views` yaws, 360°/`views` apart: evaluates
/// the other `views − 1` yaws. A face whose views cancel keeps yaw 0's.
///
/// # Errors
/// As [`filtered_normals`].
pub fn mean_over_yaws(
    pass: &NetworkPass<'_>,
    mesh: &Mesh,
    topology: &Topology,
    faces: &[u32],
    views: usize,
    normals: &mut [Vec3],
) -> Result<StageTimes, NetError> {
    let mut times = StageTimes::default();
    if views <= 1 {
        return Ok(times);
    }
    let mut sums: Vec<Vec3> = faces.iter().map(|&f| normals[f as usize]).collect();
    let mut turned = normals.to_vec();
    for v in 1..views {
        let yaw = std::f64::consts::TAU * v as f64 / views as f64;
        let yaws = vec![yaw; mesh.num_faces()];
        let progress = normalnet_mesh::progress::NoProgress;
        times.add(&pass.normals_of(mesh, topology, faces, Some(&yaws), &mut turned, &progress)?);
        for (sum, &f) in sums.iter_mut().zip(faces) {
            *sum = vec3::add(*sum, turned[f as usize]);
        }
    }
    for (sum, &f) in sums.iter().zip(faces) {
        let unit = vec3::normalize_or_zero(*sum);
        if unit != [0.0; 3] {
            normals[f as usize] = unit;
        }
    }
    Ok(times)
}
