//! The normal-filter + vertex-update skeleton shared by every classical
//! denoiser (SPEC §4, §9): a [`NormalFilter`] computes one normal-filtering
//! pass; [`run_filter`] alternates passes with the Sun et al. (2007) vertex
//! update of [`mod@crate::vertex_update`].
//!
//! Two schedules exist because the reference implementations differ:
//! - [`Schedule::Interleaved`] (GNF, Zhang et al. 2015): every normal pass
//!   reads the normals of the current mesh and is followed by `N_v` vertex
//!   passes.
//! - [`Schedule::NormalsThenVertices`] (Sun et al. 2007; Zheng et al. 2011's
//!   local scheme): `N_f` passes on the input geometry, each reading the
//!   previous pass's normals, then `N_v` vertex passes once.

use crate::vertex_update::{VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::vec3::Vec3;
use normalnet_mesh::{FaceGeometry, Mesh, Progress, Topology};

/// One normal-filtering pass of a method. Topology-only precomputation
/// (neighbourhoods) happens when the filter is built; `pass` does the
/// per-pass work and may keep scratch buffers in `self`.
pub trait NormalFilter {
    /// Filters `normals` (one per face, len #F) given the current face
    /// `geometry` (centres and areas of the current positions) and writes one
    /// unit (or zero) normal per face into `out` (len #F).
    fn pass(
        &mut self,
        topology: &Topology,
        geometry: &FaceGeometry,
        normals: &[Vec3],
        out: &mut [Vec3],
    );
}

/// When the vertices move (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Schedule {
    /// normal pass, `N_v` vertex passes; repeated `N_f` times
    Interleaved,
    /// `N_f` normal passes on fixed geometry, then `N_v` vertex passes
    NormalsThenVertices,
}

/// How [`run_filter`] arranges the passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Passes {
    /// N_f: normal-filtering passes
    pub normal_iterations: usize,
    /// N_v: vertex-update passes (per normal pass when interleaved)
    pub vertex_iterations: usize,
    /// when vertices move
    pub schedule: Schedule,
    /// keep boundary vertices in place
    pub fix_boundary: bool,
    /// the fold guard's cone ([`crate::vertex_update::VertexUpdate::fold_guard`]);
    /// `None` off
    pub fold_guard: Option<f64>,
}

impl Passes {
    /// N_f normal passes, each followed by N_v vertex passes, with the
    /// standard fold guard ([`crate::vertex_update::FOLD_GUARD_COS`]) when
    /// `fold_guard`: the schedule of most methods.
    pub fn interleaved(
        [normal_iterations, vertex_iterations]: [usize; 2],
        fix_boundary: bool,
        fold_guard: bool,
    ) -> Passes {
        Passes {
            normal_iterations,
            vertex_iterations,
            schedule: Schedule::Interleaved,
            fix_boundary,
            fold_guard: fold_guard.then_some(crate::vertex_update::FOLD_GUARD_COS),
        }
    }
}

/// Runs `filter` on `mesh` with the passes of `passes`. Reports one progress
/// unit per normal pass under `label`.
pub fn run_filter(
    filter: &mut dyn NormalFilter,
    mesh: &Mesh,
    topology: &Topology,
    passes: Passes,
    label: &str,
    progress: &dyn Progress,
) -> Mesh {
    let Passes {
        normal_iterations,
        vertex_iterations,
        schedule,
        fix_boundary,
        fold_guard,
    } = passes;
    let boundary = fix_boundary.then(|| topology.boundary_vertices());
    let update = VertexUpdate {
        iterations: vertex_iterations,
        fixed: boundary.as_deref(),
        fold_guard,
    };
    let n_faces = mesh.num_faces();
    let mut positions = mesh.positions.clone();
    let mut geometry = FaceGeometry::new(mesh);
    let mut filtered = vec![[0.0; 3]; n_faces];
    let mut buffers = VertexUpdateBuffers::default();
    progress.start(label, normal_iterations as u64);
    match schedule {
        Schedule::Interleaved => {
            let mut current = mesh.clone();
            for k in 0..normal_iterations {
                if k > 0 {
                    current.positions.clone_from(&positions);
                    geometry.update(&current);
                }
                filter.pass(topology, &geometry, &geometry.normals, &mut filtered);
                vertex_update_with(
                    &mut positions,
                    &mesh.faces,
                    topology,
                    &filtered,
                    &update,
                    &mut buffers,
                );
                progress.advance(1);
            }
        }
        Schedule::NormalsThenVertices => {
            let mut previous = geometry.normals.clone();
            for _ in 0..normal_iterations {
                filter.pass(topology, &geometry, &previous, &mut filtered);
                std::mem::swap(&mut previous, &mut filtered);
                progress.advance(1);
            }
            vertex_update_with(
                &mut positions,
                &mesh.faces,
                topology,
                &previous,
                &update,
                &mut buffers,
            );
        }
    }
    progress.finish();
    mesh.with_positions(positions)
}
