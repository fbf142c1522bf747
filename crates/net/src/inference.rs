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

use normalnet_cnn::Cnn;
use normalnet_filters::gt_guided::{GT_GUIDED_SIGMA_S, gt_guided_normals};
use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::{face_normals, mean_edge_length};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, Progress, Topology};
use normalnet_voxel::{Frame, SparseGrid, VoxelParams, Voxelizer};
use rayon::prelude::*;
use serde::Serialize;

use crate::NetError;
use crate::arch::NUM_OUTPUTS;
use crate::bundle::{Bundle, network_for_iteration};
use crate::switch;

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
    /// Guided form from this filtering iteration on (1-based; 0 = never,
    /// the paper's form throughout): the network's normals are the guidance
    /// of one joint-bilateral pass over the current face normals (range
    /// width μ_g, spatial 2·d_s, as GNF and the GT-guided targets) instead
    /// of being the filtered normals themselves. With perfect network
    /// outputs this is the oracle.
    pub guided_from: usize,
    /// With the guided form: a face whose guided normal turns more than
    /// this many degrees away from the network's keeps the network's (the
    /// guided pass smooths what the network's guidance cannot separate:
    /// fine detail); 0 = no limit.
    pub guided_max_turn_deg: f64,
    /// With the guided form: apply it only to faces whose 1-ring (vertex-
    /// adjacent faces) is locally flat in the network's output — at least
    /// `guided_flat_frac` of the ring's network normals within
    /// `guided_flat_deg` of the face's — and keep the network's normal
    /// elsewhere (curved, organic or very noisy parts); 0 = every face
    pub guided_flat_deg: f64,
    /// see `guided_flat_deg` (default 0.5)
    pub guided_flat_frac: f64,
    /// the fold guard of the shared vertex update
    /// (`normalnet_filters::vertex_update`): `Some(cos)` keeps a face within
    /// `acos(cos)` of its filtered normal (default [`FOLD_GUARD_COS`], 60°;
    /// `Some(0.0)` refuses only the flip itself), `None` switches it off
    pub fold_guard: Option<f64>,
    /// Converged faces stop being filtered: a face whose network output
    /// turned less than this many degrees between two consecutive
    /// iterations keeps that output for the rest of the run and is no
    /// longer voxelized (0 = off, every face every iteration: the exact
    /// pipeline; default [`FREEZE_DEG`]).
    pub freeze_deg: f64,
    /// Flat patches skip the network: from the second iteration on, a face
    /// whose 2-ring (vertex-adjacent faces, twice) has every face normal
    /// within this many degrees of the ring's area-weighted mean normal takes
    /// that mean normal as its network output and is not voxelized (its grid
    /// would be a nearly constant sheet). 0 = off (default
    /// [`FLAT_SKIP_DEG`]).
    pub flat_skip_deg: f64,
    /// Unmoved neighbourhoods reuse their output: a face that the same
    /// network evaluated in an earlier iteration, and around which no
    /// vertex (of its vertex-adjacent faces) has moved farther than this
    /// fraction of the mean edge length since, keeps that output and is not
    /// voxelized (the displacement is bounded by each vertex's path length,
    /// so the test errs on the side of evaluating). 0 = off (default
    /// [`REUSE_MOVE`]).
    pub reuse_move: f64,
    /// The run stops by itself after an iteration whose outputs turned, on
    /// average over all faces, less than this many degrees from the
    /// previous iteration's (`iterations` is then the most it runs;
    /// 0 = off, always `iterations`: the paper's pipeline). Default 1.0:
    /// on the validation set (8 held-out meshes) it gave a mean E_a of
    /// 7.75° against 7.87° for the full 10 iterations, in 60 iterations
    /// instead of 80 (organic meshes gain, over-smoothed by late
    /// iterations; CAD shapes lose up to 0.4°). With the learned switch the
    /// run stops instead when the switch keeps most faces where they are
    /// ([`switch::STAY_SHARE_TO_STOP`]); any value > 0 turns that on.
    pub auto_stop_deg: f64,
    /// Use the bundle's learned switch (see [`crate::switch`]) when it has
    /// one: each face's filtered normal blends the network's output, the
    /// guided pass, a GNF pass and the current normal. false (or a bundle
    /// without a switch): the paper's form (and `guided_from`).
    pub switch: bool,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        DenoiseParams {
            iterations: 10,
            vertex_iterations: 20,
            mu_g: 0.35,
            batch: 256,
            guided_from: 0,
            guided_max_turn_deg: 0.0,
            guided_flat_deg: 0.0,
            guided_flat_frac: 0.5,
            fold_guard: Some(FOLD_GUARD_COS),
            freeze_deg: FREEZE_DEG,
            flat_skip_deg: FLAT_SKIP_DEG,
            reuse_move: REUSE_MOVE,
            auto_stop_deg: 1.0,
            switch: true,
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
        if !(self.guided_flat_deg.is_finite() && (0.0..=180.0).contains(&self.guided_flat_deg)) {
            return Err(NetError::InvalidParameter {
                name: "guided_flat_deg",
                message: format!("{} must lie in 0..=180 degrees", self.guided_flat_deg),
            });
        }
        if !(0.0..=1.0).contains(&self.guided_flat_frac) {
            return Err(NetError::InvalidParameter {
                name: "guided_flat_frac",
                message: format!("{} must lie in 0..=1", self.guided_flat_frac),
            });
        }
        for (name, v) in [
            ("freeze_deg", self.freeze_deg),
            ("flat_skip_deg", self.flat_skip_deg),
            ("reuse_move", self.reuse_move),
            ("auto_stop_deg", self.auto_stop_deg),
        ] {
            if !(v.is_finite() && (0.0..=180.0).contains(&v)) {
                return Err(NetError::InvalidParameter {
                    name,
                    message: format!("{v} must lie in 0..=180 degrees"),
                });
            }
        }
        if !(self.guided_max_turn_deg.is_finite()
            && (0.0..=180.0).contains(&self.guided_max_turn_deg))
        {
            return Err(NetError::InvalidParameter {
                name: "guided_max_turn_deg",
                message: format!("{} must lie in 0..=180 degrees", self.guided_max_turn_deg),
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
    /// one entry per filtering iteration that ran
    pub iterations: Vec<IterationStats>,
}

/// Default of [`DenoiseParams::freeze_deg`]: 0.5°. With the learned switch
/// it cost +0.003° mean E_a on the validation set (8 held-out meshes; worst
/// mesh +0.05°) for 19 % less time, and Fandisk0.3 +0.002° for 31 % less
/// (2026-12-01); in the paper's form (no switch) +0.19° on validation, so
/// the paper's exact pipeline sets it to 0.
pub const FREEZE_DEG: f64 = 0.5;

/// Default of [`DenoiseParams::flat_skip_deg`]: 15°. With the learned switch
/// it lowered the mean E_a on the validation set (8 held-out meshes) from
/// 6.759° to 6.583° (better on 6 of 8; homer +0.035°) in 21 % less time,
/// and on the 6 mild validation pairs from 2.834° to 2.794° (2026-12-01):
/// on CAD-like parts the 2-ring mean is a better filtered normal than the
/// lite network's where the patch is that flat. 8° gave 6.705°, 25° 6.593°,
/// 35° 6.705° (organic meshes over-smoothed: homer 9.0°). At 25 iterations
/// (N_v 10, μ_g 0.3) the 8 meshes went from 6.101° to 5.955° and the
/// Twelve-like validation polyhedra from 4.835° to 4.862° (the one loser;
/// see docs/benchmarks.md).
pub const FLAT_SKIP_DEG: f64 = 15.0;

/// Default of [`DenoiseParams::reuse_move`]: off. At 0.1 mean edge
/// lengths, with the learned switch and the int8 stem, it cost +0.009° mean
/// E_a on the validation set (8 held-out meshes, 4.508 → 4.517°; without the
/// chaotic cone s42, +0.007°) for 23 % fewer face passes, and Fandisk0.3
/// +0.004° (2.584 → 2.588°) for 24 % fewer (56,960 → 43,286) (2026-12-02);
/// but on the test model Fandisk0.7 (μ_g 0.25) the reused outputs let the
/// switch's stop rule ([`switch::STAY_SHARE_TO_STOP`]) end the run after 7
/// iterations instead of 10: 8.25 → 11.21°. The stop rule now takes the
/// "stay" share over the faces not reused in that iteration; on a second,
/// high-noise validation set (L 0.5–0.7, 4 meshes) reuse 0.1 still costs
/// +0.11° (13.311 → 13.423°; with the old rule +0.21°), so it stays opt-in. Reuse across
/// networks (a face's output from the previous interval's network): 0.05
/// l_e +0.016° for 27 % fewer passes, 0.1 l_e +0.052° (rocker-arm +0.30°)
/// for 45 %.
pub const REUSE_MOVE: f64 = 0.0;

/// The faces of `mesh` whose 2-ring is flat within `limit_deg` (see
/// [`DenoiseParams::flat_skip_deg`]), with the 2-ring's area-weighted mean
/// normal; `None` for the others.
pub fn flat_patches(mesh: &Mesh, topology: &Topology, limit_deg: f64) -> Vec<Option<Vec3>> {
    let geometry = FaceGeometry::new(mesh);
    let n = mesh.num_faces();
    let cos_limit = limit_deg.to_radians().cos();
    (0..n)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || (vec![false; n], Vec::new()),
            |(mark, ring), f| {
                topology.face_ring_into(f, 2, mark, ring);
                let mut sum = [0.0; 3];
                for &g in ring.iter() {
                    let g = g as usize;
                    sum = vec3::add(sum, vec3::scale(geometry.normals[g], geometry.areas[g]));
                }
                let mean = vec3::normalize_or_zero(sum);
                let flat = mean != [0.0; 3]
                    && ring
                        .iter()
                        .all(|&g| vec3::dot(geometry.normals[g as usize], mean) >= cos_limit);
                flat.then_some(mean)
            },
        )
        .collect()
}

/// [`flat_patches`] applied to `normals` (len #F): the flat faces' entries
/// become their 2-ring means. Returns which faces were flat.
pub fn take_flat_means(
    mesh: &Mesh,
    topology: &Topology,
    limit_deg: f64,
    normals: &mut [Vec3],
) -> Vec<bool> {
    flat_patches(mesh, topology, limit_deg)
        .into_iter()
        .zip(normals.iter_mut())
        .map(|(mean, normal)| {
            if let Some(mean) = mean {
                *normal = mean;
            }
            mean.is_some()
        })
        .collect()
}

/// What one filtering iteration did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct IterationStats {
    /// the network that served it (1-based)
    pub network: usize,
    /// faces voxelized and run through the network (the others were frozen)
    pub faces_evaluated: usize,
    /// mean angle in degrees between this iteration's filtered normals
    /// (network outputs, flat faces' 2-ring means) and the previous
    /// iteration's, over all faces (0 in the first)
    pub mean_change_deg: f64,
    /// wall-clock seconds of the iteration
    pub seconds: f64,
    /// with the learned switch: the share of faces whose largest weight was
    /// "stay" (the run stops at [`switch::STAY_SHARE_TO_STOP`]); 0 without it
    pub stay_share: f64,
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
    let n = mesh.num_faces();
    let total = (params.iterations * n) as u64;
    progress.start("NormalNet", total);
    // the previous iteration's filtered normals, and the faces that stopped
    // being filtered (`freeze_deg`)
    let mut previous: Option<Vec<Vec3>> = None;
    let mut frozen = vec![false; n];
    let mut stay_share = 0.0;
    let learned_switch = bundle.manifest.switch.as_ref().filter(|_| params.switch);
    let mut switch_state =
        learned_switch.map(|_| switch::SwitchState::new(mesh, &topology, params.mu_g));
    // `reuse_move`: per vertex the length of the path it has moved so far,
    // that length at the start of every iteration, and per face the network
    // output it last got (network, iteration, normal)
    // (allocated only when it is on: 48 MB per million faces)
    let reuse_limit = if params.reuse_move > 0.0 {
        params.reuse_move * mean_edge_length(mesh, &topology)
    } else {
        0.0
    };
    let reuse_len = |len: usize| if reuse_limit > 0.0 { len } else { 0 };
    let mut path = vec![0.0f64; reuse_len(mesh.num_vertices())];
    let mut path_at: Vec<Vec<f64>> = Vec::new();
    let mut last_output: Vec<Option<(usize, usize, Vec3)>> = vec![None; reuse_len(n)];
    for k in 1..=params.iterations {
        let iteration_start = Instant::now();
        progress.message(&format!("iteration {k}/{}", params.iterations));
        let current = mesh.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let mut normals = previous.clone().unwrap_or_else(|| vec![[0.0; 3]; n]);
        let flat = if params.flat_skip_deg > 0.0 && k > 1 {
            take_flat_means(&current, &topology, params.flat_skip_deg, &mut normals)
        } else {
            vec![false; n]
        };
        if reuse_limit > 0.0 {
            path_at.push(path.clone());
        }
        let reused = |f: usize| -> Option<Vec3> {
            // (`last_output` is empty when reuse is off)
            let (network, at, normal) = last_output.get(f).copied().flatten()?;
            let unmoved = network == i
                && topology.face_neighbours.row(f).iter().all(|&g| {
                    mesh.faces[g as usize]
                        .iter()
                        .all(|&v| path[v as usize] - path_at[at - 1][v as usize] < reuse_limit)
                });
            unmoved.then_some(normal)
        };
        let mut active: Vec<u32> = Vec::with_capacity(n);
        let mut reused_now = vec![false; reuse_len(n)];
        for f in 0..n {
            if frozen[f] || flat[f] {
                continue;
            }
            match reused(f) {
                Some(normal) => {
                    normals[f] = normal;
                    reused_now[f] = true;
                }
                None => active.push(f as u32),
            }
        }
        let t = filtered_normals_of(
            &current,
            &topology,
            &bundle.engines[i],
            bundle.manifest.networks[i].residual,
            bundle.voxel_params(),
            slot,
            params.batch,
            &active,
            None,
            &mut normals,
            progress,
        )?;
        progress.advance((n - active.len()) as u64);
        times.add(&t);
        if reuse_limit > 0.0 {
            for &f in &active {
                last_output[f as usize] = Some((i, k, normals[f as usize]));
            }
        }
        let mean_change_deg = match &previous {
            Some(p) => {
                // every face: a frozen one did not change, a flat one
                // changed as its 2-ring mean did
                let changes: Vec<f64> = p
                    .iter()
                    .zip(&normals)
                    .map(|(a, b)| {
                        if a == b {
                            0.0
                        } else {
                            vec3::angle(*a, *b).to_degrees()
                        }
                    })
                    .collect();
                if params.freeze_deg > 0.0 {
                    for &f in &active {
                        frozen[f as usize] = changes[f as usize] < params.freeze_deg;
                    }
                }
                changes.iter().sum::<f64>() / n as f64
            }
            None => 0.0,
        };
        previous = Some(normals.clone());
        let t = Instant::now();
        let normals = if let (Some(weights), Some(state)) = (learned_switch, switch_state.as_mut())
        {
            let candidates = state.candidates(&current, &topology, normals);
            let features = switch::features(&topology, &candidates, k);
            let (blended, stays) = switch::blend_with_stays(weights, &candidates, &features);
            // a reused output is no new evidence that its face has settled:
            // the share is taken over the other faces
            let counted = |f: usize| !reused_now.get(f).copied().unwrap_or(false);
            let stay = (0..n).filter(|&f| stays[f] && counted(f)).count();
            let total = (0..n).filter(|&f| counted(f)).count();
            stay_share = stay as f64 / total.max(1) as f64;
            blended
        } else if params.guided_from > 0 && k >= params.guided_from {
            let guided = gt_guided_normals(
                &current,
                &topology,
                &normals,
                &[params.mu_g],
                GT_GUIDED_SIGMA_S,
            );
            if params.guided_flat_deg > 0.0 {
                let cos_t = params.guided_flat_deg.to_radians().cos();
                let flat = |f: usize| {
                    let ring = topology.face_neighbours.row(f);
                    let close = ring
                        .iter()
                        .filter(|&&g| vec3::dot(normals[f], normals[g as usize]) >= cos_t)
                        .count();
                    !ring.is_empty() && close as f64 >= params.guided_flat_frac * ring.len() as f64
                };
                (0..normals.len())
                    .map(|f| if flat(f) { guided[f] } else { normals[f] })
                    .collect()
            } else if params.guided_max_turn_deg > 0.0 {
                let limit = params.guided_max_turn_deg.to_radians();
                guided
                    .iter()
                    .zip(&normals)
                    .map(|(g, n)| if vec3::angle(*g, *n) > limit { *n } else { *g })
                    .collect()
            } else {
                guided
            }
        } else {
            normals
        };
        let before = (reuse_limit > 0.0).then(|| positions.clone());
        vertex_update_with(
            &mut positions,
            &mesh.faces,
            &topology,
            &normals,
            &VertexUpdate {
                iterations: params.vertex_iterations,
                fixed: None,
                fold_guard: params.fold_guard,
            },
            &mut buffers,
        );
        if let Some(before) = before {
            for ((length, a), b) in path.iter_mut().zip(&before).zip(&positions) {
                *length += vec3::norm(vec3::sub(*b, *a));
            }
        }
        times.vertex_update_s += t.elapsed().as_secs_f64();
        times.iterations.push(IterationStats {
            network: i + 1,
            faces_evaluated: active.len(),
            mean_change_deg,
            seconds: iteration_start.elapsed().as_secs_f64(),
            stay_share,
        });
        let stop = if learned_switch.is_some() {
            stay_share >= switch::STAY_SHARE_TO_STOP
        } else {
            k > 1 && mean_change_deg < params.auto_stop_deg
        };
        if params.auto_stop_deg > 0.0 && stop {
            break;
        }
    }
    progress.finish();
    times.total_s = start.elapsed().as_secs_f64();
    Ok((mesh.with_positions(positions), times))
}

/// One normal-filtering pass with one network: the world-frame normal of
/// output `slot` for every face of `mesh` (len #F, unit length).
///
/// With `residual`, the network's output is added to the face's current
/// normal (in the local frame) before normalising (see
/// [`crate::bundle::NetworkInfo::residual`]).
///
/// `yaws` (one per face, radians) rotates each face's frame about its local
/// y axis; `None` = no yaw (what [`denoise`] uses). `progress` advances by
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
    let times = filtered_normals_of(
        mesh,
        topology,
        cnn,
        residual,
        voxel,
        slot,
        batch,
        &faces,
        yaws,
        &mut normals,
        progress,
    )?;
    Ok((normals, times))
}

/// [`filtered_normals`] of the listed `faces` only, written into their
/// entries of `normals` (len #F; the other entries are left as they are);
/// `yaws`, when given, is indexed by face. Returns the stage times.
///
/// # Errors
/// As [`filtered_normals`].
#[allow(clippy::too_many_arguments)]
pub fn filtered_normals_of(
    mesh: &Mesh,
    topology: &Topology,
    cnn: &Cnn,
    residual: bool,
    voxel: VoxelParams,
    slot: usize,
    batch: usize,
    faces: &[u32],
    yaws: Option<&[f64]>,
    normals: &mut [Vec3],
    progress: &dyn Progress,
) -> Result<StageTimes, NetError> {
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
                let frames =
                    voxelizer.voxelize_batch_sparse(batch_faces, batch_yaws.as_deref(), &mut buf);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ModelConfig;
    use crate::bundle::{new_manifest, save_bundle};
    use normalnet_mesh::NoProgress;
    use normalnet_voxel::frame::{Mat3, mat_vec};

    fn shape() -> Mesh {
        normalnet_voxel::shapes::generate_seeded(3, 400).unwrap()
    }

    fn transform(mesh: &Mesh, r: &Mat3, scale: f64, shift: Vec3) -> Mesh {
        let p = mesh
            .positions
            .iter()
            .map(|&x| vec3::add(vec3::scale(mat_vec(r, x), scale), shift))
            .collect();
        mesh.with_positions(p)
    }

    /// Rotation by `angle` about the unit `axis` (Rodrigues).
    fn rotation(axis: Vec3, angle: f64) -> Mat3 {
        let [x, y, z] = vec3::normalize_or_zero(axis);
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ]
    }

    fn engine(seed: u64) -> Cnn {
        Cnn::new(&ModelConfig::tiny().init_weights(seed)).unwrap()
    }

    fn run(mesh: &Mesh, net: &Cnn, yaws: Option<&[f64]>) -> Vec<Vec3> {
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        filtered_normals(
            mesh,
            &topology,
            net,
            false,
            VoxelParams::tiny(),
            2,
            64,
            yaws,
            &NoProgress,
        )
        .unwrap()
        .0
    }

    fn angles_deg(a: &[Vec3], b: &[Vec3]) -> Vec<f64> {
        a.iter()
            .zip(b)
            .map(|(x, y)| vec3::angle(*x, *y).to_degrees())
            .collect()
    }

    #[test]
    fn outputs_are_unit_and_invariant_to_translation_and_scale() {
        let net = engine(7);
        let mesh = shape();
        let a = run(&mesh, &net, None);
        assert_eq!(a.len(), mesh.num_faces());
        assert!(a.iter().all(|n| (vec3::norm(*n) - 1.0).abs() < 1e-9));
        let moved = transform(&mesh, &IDENTITY, 3.5, [10.0, -4.0, 2.0]);
        let b = run(&moved, &net, None);
        let err = angles_deg(&a, &b);
        let mean = err.iter().sum::<f64>() / err.len() as f64;
        assert!(mean < 0.05, "mean change {mean}°");
    }

    /// A residual network whose output layer is zero predicts "no change":
    /// every filtered normal is the face's current normal; the same network
    /// read as a direct predictor gives no direction at all (fallback).
    #[test]
    fn a_zero_residual_is_the_identity() {
        let config = ModelConfig::tiny();
        let mut w = config.init_weights(4);
        w.output.weight.fill(0.0);
        w.output.bias.as_mut().unwrap().fill(0.0);
        let mesh = shape();
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        let pass = |w: &normalnet_cnn::NetWeights| {
            let net = Cnn::new(w).unwrap();
            let (normals, _) = filtered_normals(
                &mesh,
                &topology,
                &net,
                true,
                VoxelParams::tiny(),
                2,
                64,
                None,
                &NoProgress,
            )
            .unwrap();
            normals
        };
        let current = face_normals(&mesh);
        let err = angles_deg(&pass(&w), &current);
        assert!(
            err.iter().all(|&e| e < 1e-4),
            "max {:?}",
            err.iter().cloned().fold(0.0, f64::max)
        );
        // a non-zero residual moves the normals
        w.output.bias.as_mut().unwrap().fill(0.2);
        let moved = pass(&w);
        assert!(angles_deg(&moved, &current).iter().any(|&e| e > 5.0));
    }

    const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// The frame aligns the 2-ring mean normal with y and leaves the yaw
    /// free, so rotating the mesh by R is exactly the same as keeping it and
    /// turning each face's grid by the yaw φ_f = yaw of `W'_f · R · W_fᵀ`.
    /// Outputs must then be the rotated outputs: this checks that the
    /// network outputs are rotated back with the right `W_rᵀ`. (An untrained
    /// network is not yaw-invariant, so without the yaws they would differ.)
    #[test]
    fn rotating_the_mesh_rotates_the_outputs_modulo_the_free_yaw() {
        let net = engine(8);
        let mesh = shape();
        let r = rotation([0.3, -0.5, 0.8], 1.1);
        let rotated = transform(&mesh, &r, 1.0, [0.0; 3]);
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let v = Voxelizer::new(&mesh, &topo, VoxelParams::tiny()).unwrap();
        let vr = Voxelizer::new(&rotated, &topo, VoxelParams::tiny()).unwrap();
        let yaws: Vec<f64> = (0..mesh.num_faces())
            .map(|f| {
                let w = v.frame(f, 0.0).rotation;
                let wr = vr.frame(f, 0.0).rotation;
                // M = W'_f R W_fᵀ, a rotation about y by φ: M[0][2] = sin φ, M[0][0] = cos φ
                let m = |i: usize, j: usize| {
                    (0..3)
                        .map(|a| (0..3).map(|b| wr[i][a] * r[a][b] * w[j][b]).sum::<f64>())
                        .sum::<f64>()
                };
                assert!((m(1, 1) - 1.0).abs() < 1e-9, "not a yaw");
                m(0, 2).atan2(m(0, 0))
            })
            .collect();
        let base = run(&mesh, &net, Some(&yaws));
        let expected: Vec<Vec3> = base.iter().map(|n| mat_vec(&r, *n)).collect();
        let got = run(&rotated, &net, None);
        let err = angles_deg(&expected, &got);
        let mean = err.iter().sum::<f64>() / err.len() as f64;
        assert!(mean < 0.05, "mean deviation {mean}°");
        // and the yaw matters for an untrained network: without it the
        // outputs are not simply rotated
        let plain: Vec<Vec3> = run(&mesh, &net, None)
            .iter()
            .map(|n| mat_vec(&r, *n))
            .collect();
        let off = angles_deg(&plain, &got);
        assert!(off.iter().sum::<f64>() / off.len() as f64 > 0.05);
    }

    /// A bundle of six freshly initialised tiny networks.
    fn tiny_bundle() -> Bundle {
        let dir = tempfile::tempdir().unwrap();
        let manifest = new_manifest("tiny").unwrap();
        let nets: Vec<normalnet_cnn::NetWeights> = (0..6)
            .map(|i| ModelConfig::tiny().init_weights(i))
            .collect();
        save_bundle(dir.path(), &manifest, &nets).unwrap();
        Bundle::load(dir.path()).unwrap()
    }

    #[test]
    fn denoise_runs_every_interval_without_nan() {
        let bundle = tiny_bundle();
        let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
        let params = DenoiseParams {
            iterations: 11,
            vertex_iterations: 2,
            batch: 50,
            auto_stop_deg: 0.0,
            freeze_deg: 0.0,
            flat_skip_deg: 0.0,
            reuse_move: 0.0,
            ..DenoiseParams::default()
        };
        let (out, times) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
        assert_eq!(out.faces, mesh.faces);
        assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
        assert_ne!(out.positions, mesh.positions);
        assert_eq!(times.faces_processed, 11 * mesh.num_faces());
        assert!(times.cnn_s > 0.0 && times.total_s >= times.cnn_s);
        let bad = DenoiseParams {
            iterations: 0,
            ..DenoiseParams::default()
        };
        assert!(matches!(
            denoise(&mesh, &bundle, &bad, &NoProgress),
            Err(NetError::InvalidParameter {
                name: "iterations",
                ..
            })
        ));
    }

    #[test]
    fn unmoved_neighbourhoods_reuse_the_same_networks_output() {
        let bundle = tiny_bundle();
        let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
        let run = |reuse_move: f64| {
            let params = DenoiseParams {
                // network 4 serves iterations 4 and 5, network 5 iteration 6
                iterations: 6,
                vertex_iterations: 2,
                batch: 50,
                auto_stop_deg: 0.0,
                freeze_deg: 0.0,
                flat_skip_deg: 0.0,
                reuse_move,
                ..DenoiseParams::default()
            };
            denoise(&mesh, &bundle, &params, &NoProgress).unwrap()
        };
        let evaluated = |times: &StageTimes| -> Vec<usize> {
            times.iterations.iter().map(|i| i.faces_evaluated).collect()
        };
        let n = mesh.num_faces();
        let (exact, t_exact) = run(0.0);
        assert_eq!(evaluated(&t_exact), vec![n; 6]);
        // every vertex counts as unmoved: the same network's faces reuse
        // their outputs, a new network evaluates every face
        let (all, t_all) = run(180.0);
        assert_eq!(evaluated(&t_all), vec![n, n, n, n, 0, n]);
        assert!(all.positions.iter().flatten().all(|x| x.is_finite()));
        assert_eq!(all.faces, exact.faces);
        for bad in [-0.1, f64::NAN] {
            let params = DenoiseParams {
                reuse_move: bad,
                ..DenoiseParams::default()
            };
            assert!(matches!(
                denoise(&mesh, &bundle, &params, &NoProgress),
                Err(NetError::InvalidParameter {
                    name: "reuse_move",
                    ..
                })
            ));
        }
    }

    #[test]
    fn the_learned_switch_blends_candidates_and_is_optional() {
        let mut bundle = tiny_bundle();
        let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
        let run = |bundle: &Bundle, switch: bool| {
            let params = DenoiseParams {
                iterations: 2,
                vertex_iterations: 3,
                switch,
                ..DenoiseParams::default()
            };
            denoise(&mesh, bundle, &params, &NoProgress)
                .unwrap()
                .0
                .positions
        };
        let paper = run(&bundle, true);
        // a switch that always takes the network's output is the paper's form
        bundle.manifest.switch = Some(crate::switch::tests::constant(0));
        let same = run(&bundle, true);
        let largest = paper
            .iter()
            .zip(&same)
            .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
            .fold(0.0, f64::max);
        assert!(largest < 1e-9, "moved {largest}");
        // switched off: exactly the paper's form
        assert_eq!(run(&bundle, false), paper);
        // always "stay": the vertices lie in their faces' planes and do not move
        bundle.manifest.switch = Some(crate::switch::tests::constant(3));
        let stay = run(&bundle, true);
        let largest = mesh
            .positions
            .iter()
            .zip(&stay)
            .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
            .fold(0.0, f64::max);
        assert!(largest < 1e-9, "moved {largest}");
        // ... and the run stops after the first iteration: every face stayed
        let params = DenoiseParams {
            iterations: 5,
            vertex_iterations: 3,
            ..DenoiseParams::default()
        };
        let (_, times) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
        assert_eq!(times.iterations.len(), 1);
        assert_eq!(times.iterations[0].stay_share, 1.0);
        let fixed = DenoiseParams {
            auto_stop_deg: 0.0,
            ..params
        };
        let (_, times) = denoise(&mesh, &bundle, &fixed, &NoProgress).unwrap();
        assert_eq!(times.iterations.len(), 5);
        // always the guided pass: the guided form
        bundle.manifest.switch = Some(crate::switch::tests::constant(1));
        let guided = DenoiseParams {
            iterations: 2,
            vertex_iterations: 3,
            guided_from: 1,
            switch: false,
            ..DenoiseParams::default()
        };
        let guided = denoise(&mesh, &bundle, &guided, &NoProgress).unwrap().0;
        let largest = guided
            .positions
            .iter()
            .zip(&run(&bundle, true))
            .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
            .fold(0.0, f64::max);
        assert!(largest < 1e-9, "moved {largest}");
    }

    #[test]
    fn the_flat_rule_chooses_between_the_guided_and_the_paper_form() {
        let bundle = tiny_bundle();
        let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
        let run = |guided_from: usize, flat_deg: f64| {
            let params = DenoiseParams {
                iterations: 2,
                vertex_iterations: 2,
                guided_from,
                guided_flat_deg: flat_deg,
                ..DenoiseParams::default()
            };
            denoise(&mesh, &bundle, &params, &NoProgress)
                .unwrap()
                .0
                .positions
        };
        let paper = run(0, 0.0);
        let guided = run(1, 0.0);
        assert_ne!(paper, guided);
        // every ring normal within 180°: every face flat, the guided form
        assert_eq!(run(1, 180.0), guided);
        // within 1e-9°: no face flat (random networks), the paper's form
        assert_eq!(run(1, 1e-9), paper);
    }

    /// A strip of 8 × 4 squares (two triangles each) folded by 90° along
    /// x = 0: the half x ≤ 0 lies in the plane y = 0, the half x ≥ 0 in
    /// the plane x = 0.
    fn folded_strip() -> Mesh {
        let mut positions = Vec::new();
        for i in 0..=8 {
            for j in 0..=4 {
                let x = i as f64 - 4.0;
                let z = j as f64;
                positions.push(if x <= 0.0 { [x, 0.0, z] } else { [0.0, x, z] });
            }
        }
        let v = |i: u32, j: u32| i * 5 + j;
        let mut faces = Vec::new();
        for i in 0..8 {
            for j in 0..4 {
                faces.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
                faces.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
            }
        }
        Mesh::new(positions, faces).unwrap()
    }

    #[test]
    fn flat_patches_are_the_faces_away_from_the_fold_and_skip_the_network() {
        let mesh = folded_strip();
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        let normals = face_normals(&mesh);
        let flat = flat_patches(&mesh, &topology, 10.0);
        // columns 0–1 and 6–7 lie two rings or more from the fold
        for (f, got) in flat.iter().enumerate() {
            let column = f / 8;
            let far = !(2..6).contains(&column);
            assert_eq!(got.is_some(), far, "face {f} (column {column})");
            if let Some(mean) = got {
                assert!(vec3::angle(*mean, normals[f]) < 1e-9, "face {f}");
            }
        }
        // the fold's two normals are 90° apart: the 2-ring mean lies less
        // than 90° from each (at least 1 of 40 faces on the other side: 88.6°
        // at most), so a limit of 89.5° takes in every face
        assert!(
            flat_patches(&mesh, &topology, 89.5)
                .iter()
                .all(|m| m.is_some())
        );

        // with a switch that keeps every face where it is, the mesh does not
        // move, and from the second iteration on the flat faces skip the network
        let mut bundle = tiny_bundle();
        bundle.manifest.switch = Some(crate::switch::tests::constant(3));
        let run = |flat_skip_deg: f64| {
            let params = DenoiseParams {
                iterations: 3,
                vertex_iterations: 2,
                freeze_deg: 0.0,
                auto_stop_deg: 0.0,
                flat_skip_deg,
                ..DenoiseParams::default()
            };
            denoise(&mesh, &bundle, &params, &NoProgress).unwrap().1
        };
        let evaluated = |t: StageTimes| -> Vec<usize> {
            t.iterations.iter().map(|s| s.faces_evaluated).collect()
        };
        let n = mesh.num_faces();
        let skipped = flat.iter().filter(|m| m.is_some()).count();
        assert_eq!(skipped, 32);
        assert_eq!(evaluated(run(0.0)), [n, n, n]);
        assert_eq!(evaluated(run(10.0)), [n, n - skipped, n - skipped]);
        // every face flat: the network runs once, and the turn from its
        // outputs to the 2-ring means counts in the mean change (which the
        // paper form's auto stop reads); then the means stay
        let t = run(89.5);
        let changes: Vec<f64> = t.iterations.iter().map(|s| s.mean_change_deg).collect();
        assert_eq!(evaluated(t), [n, 0, 0]);
        assert!(changes[1] > 1.0, "{changes:?}");
        assert!(changes[2] < 1e-6, "{changes:?}");
        let bad = DenoiseParams {
            flat_skip_deg: f64::NAN,
            ..DenoiseParams::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(NetError::InvalidParameter {
                name: "flat_skip_deg",
                ..
            })
        ));
    }

    #[test]
    fn frozen_faces_keep_their_output_and_auto_stop_ends_the_run() {
        let bundle = tiny_bundle();
        let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
        let n = mesh.num_faces();
        let run = |iterations: usize, freeze_deg: f64, auto_stop_deg: f64| {
            let params = DenoiseParams {
                iterations,
                vertex_iterations: 2,
                freeze_deg,
                auto_stop_deg,
                flat_skip_deg: 0.0,
                ..DenoiseParams::default()
            };
            denoise(&mesh, &bundle, &params, &NoProgress).unwrap()
        };
        // off: every face every iteration, the mean change is reported
        let (exact, t) = run(4, 0.0, 0.0);
        assert_eq!(t.iterations.len(), 4);
        assert!(t.iterations.iter().all(|s| s.faces_evaluated == n));
        assert_eq!(t.iterations[0].mean_change_deg, 0.0);
        assert!(t.iterations[1..].iter().all(|s| s.mean_change_deg > 0.0));
        assert_eq!(
            t.iterations.iter().map(|s| s.network).collect::<Vec<_>>(),
            [1, 2, 3, 4]
        );
        // a threshold no face meets changes nothing
        assert_eq!(run(4, 1e-12, 0.0).0.positions, exact.positions);
        // every face turns less than 180°: all freeze after iteration 2, and
        // iterations 3 and 4 move the vertices towards iteration 2's normals
        let (frozen, t) = run(4, 180.0, 0.0);
        assert_eq!(
            t.iterations
                .iter()
                .map(|s| s.faces_evaluated)
                .collect::<Vec<_>>(),
            [n, n, 0, 0]
        );
        assert_eq!(t.faces_processed, 2 * n);
        assert_eq!(t.iterations[2].mean_change_deg, 0.0);
        assert_ne!(frozen.positions, exact.positions);
        // and the frozen run is deterministic
        assert_eq!(run(4, 180.0, 0.0).0.positions, frozen.positions);
        // auto stop: any change is below 180°, so the run ends after 2
        let (stopped, t) = run(10, 0.0, 180.0);
        assert_eq!(t.iterations.len(), 2);
        assert_eq!(stopped.positions, run(2, 0.0, 0.0).0.positions);
        // bad thresholds are refused, naming the field
        for (f, a, name) in [(-1.0, 0.0, "freeze_deg"), (0.0, f64::NAN, "auto_stop_deg")] {
            let params = DenoiseParams {
                freeze_deg: f,
                auto_stop_deg: a,
                ..DenoiseParams::default()
            };
            assert!(matches!(
                params.validate(),
                Err(NetError::InvalidParameter { name: n, .. }) if n == name
            ));
        }
    }
}
