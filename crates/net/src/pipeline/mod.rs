//! Denoising with NormalNet (paper §3, SPEC §7), as a loop of stages. For
//! each filtering iteration k = 1..N_f:
//! 1. **select** ([`skips`]): the faces the network must evaluate (frozen,
//!    flat and reused faces keep a normal without it);
//! 2. **evaluate** ([`evaluate`]): voxelize them, run the network of k's
//!    interval in batches, take the output for the user's μ_g (nearest of
//!    the six), rotate it back with `W_rᵀ`;
//! 3. **choose** ([`form`]): the filtered normal in the run's [`Form`] (the
//!    paper's, guided, or the learned switch);
//! 4. **update**: move the vertices N_v times (Sun et al. 2007, with the
//!    fold guard);
//! 5. **stop?** ([`StopRule`]).
//!
//! The settings are one struct, [`DenoiseParams`]; where two of them
//! interact, [`Form::of`] and [`StopRule::of`] say which one wins.

pub mod evaluate;
pub mod form;
pub mod params;
pub mod skips;
pub mod stats;

pub use evaluate::{NetworkPass, filtered_normals};
pub use params::{
    DenoiseParams, FLAT_SKIP_DEG, FREEZE_DEG, Form, GuidedLimit, REUSE_MOVE, StopRule, YAW_VIEWS,
    YAW_VIEWS_FROM_NOISE, YAW_VIEWS_UNTIL,
};
pub use skips::{flat_patches, take_flat_means};
pub use stats::{IterationStats, StageTimes};

use std::time::Instant;

use normalnet_filters::{VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Progress, Topology};

use crate::NetError;
use crate::bundle::{Bundle, network_for_iteration};
use form::Chooser;
use skips::Skips;

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
    let (n, slot) = (mesh.num_faces(), bundle.output_for_mu_g(params.mu_g));
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let form = Form::of(params, bundle);
    let stop = StopRule::of(params, &form);
    let mut chooser = Chooser::new(form, mesh, &topology, params.mu_g);
    let mut skips = Skips::new(mesh, &topology, params);
    let mut positions = mesh.positions.clone();
    let mut updater = Updater::new(mesh, params);
    let mut times = StageTimes::default();
    let mut previous: Option<Vec<Vec3>> = None;
    let views = yaw_views(params, mesh, &topology);
    progress.start("NormalNet", (params.iterations * n) as u64);
    for k in 1..=params.iterations {
        let iteration_start = Instant::now();
        progress.message(&format!("iteration {k}/{}", params.iterations));
        let current = mesh.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let mut normals = previous.clone().unwrap_or_else(|| vec![[0.0; 3]; n]);
        let selection = skips.select(k, i, &current, &mut normals);
        let pass = NetworkPass::of_bundle(bundle, i, slot, params.batch);
        let active = &selection.active;
        times.add(&pass.normals_of(&current, &topology, active, None, &mut normals, progress)?);
        let views_now = match params.yaw_views_until == 0 || k <= params.yaw_views_until {
            true => views,
            false => 1,
        };
        if views_now > 1 {
            times.add(&evaluate::mean_over_yaws(
                &pass,
                &current,
                &topology,
                active,
                views_now,
                &mut normals,
            )?);
        }
        progress.advance((n - active.len()) as u64);
        let changes = previous.as_ref().map(|p| changes_deg(p, &normals));
        skips.record(k, i, &selection, &normals, changes.as_deref());
        let mean_change_deg = changes.map_or(0.0, |c| c.iter().sum::<f64>() / n as f64);
        previous = Some(normals.clone());
        let t = Instant::now();
        let choice = chooser.choose(k, &current, &topology, normals, &selection);
        updater.run(&mut positions, &topology, &choice.normals, &mut skips);
        times.vertex_update_s += t.elapsed().as_secs_f64();
        times.iterations.push(IterationStats {
            network: i + 1,
            faces_evaluated: active.len(),
            mean_change_deg,
            seconds: iteration_start.elapsed().as_secs_f64(),
            stay_share: choice.stay_share,
            folded_share: choice.folded_share,
            yaw_views: views_now,
        });
        if stop.stops(k, mean_change_deg, choice.stay_share) {
            break;
        }
    }
    progress.finish();
    times.total_s = start.elapsed().as_secs_f64();
    Ok((mesh.with_positions(positions), times))
}

/// The yaw views of this run: `params.yaw_views`, or 1 where the input's
/// noise level is below `params.yaw_views_from_noise`.
fn yaw_views(params: &DenoiseParams, mesh: &Mesh, topology: &Topology) -> usize {
    if params.yaw_views <= 1 || params.yaw_views_from_noise <= 0.0 {
        return params.yaw_views;
    }
    let normals = normalnet_mesh::geometry::face_normals(mesh);
    match crate::switch::noise_level(topology, &normals) >= params.yaw_views_from_noise {
        true => params.yaw_views,
        false => 1,
    }
}

/// The update stage: N_v vertex updates towards the filtered normals, with
/// the fold guard (SPEC §4).
struct Updater<'m> {
    faces: &'m [[u32; 3]],
    update: VertexUpdate<'m>,
    buffers: VertexUpdateBuffers,
}

impl<'m> Updater<'m> {
    fn new(mesh: &'m Mesh, params: &DenoiseParams) -> Updater<'m> {
        let update = VertexUpdate {
            iterations: params.vertex_iterations,
            fixed: None,
            fold_guard: params.fold_guard_cone(),
        };
        Updater {
            faces: &mesh.faces,
            update,
            buffers: VertexUpdateBuffers::default(),
        }
    }

    /// Moves `positions` towards `normals`; the skips learn how far the
    /// vertices moved.
    fn run(
        &mut self,
        positions: &mut Vec<Vec3>,
        topology: &Topology,
        normals: &[Vec3],
        skips: &mut Skips,
    ) {
        let before = skips.tracks_moves().then(|| positions.clone());
        vertex_update_with(
            positions,
            self.faces,
            topology,
            normals,
            &self.update,
            &mut self.buffers,
        );
        if let Some(before) = before {
            skips.moved(&before, positions);
        }
    }
}

/// Per face the angle in degrees between two iterations' filtered normals
/// (a frozen face did not change; a flat one changed as its 2-ring mean did).
fn changes_deg(previous: &[Vec3], normals: &[Vec3]) -> Vec<f64> {
    previous
        .iter()
        .zip(normals)
        .map(|(a, b)| {
            if a == b {
                0.0
            } else {
                vec3::angle(*a, *b).to_degrees()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
