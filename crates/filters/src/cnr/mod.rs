//! CNR's inference, cascaded normal regression (Wang, Liu & Tong 2016; SPEC
//! §9.1), the learned baseline of the paper's comparison: per stage, each
//! face's filtered facet normal descriptor ([`descriptor`]) is mapped to its
//! normal by the regressor of its cluster ([`model`]), then the vertices
//! follow the normals (Sun et al., with the shared fold guard). A plain
//! regression on geometry, so it lives with the filters: `normalnet-denoise`
//! registers it as a method and trains it, NormalNet's switch reads its
//! normals as a candidate. The shipped model (`models/cnr/cnr.json`) is
//! built in ([`builtin`]).

pub mod descriptor;
pub mod model;

use normalnet_mesh::geometry::mean_edge_length;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Csr, FaceGeometry, Mesh, Progress, Topology};
use rayon::prelude::*;
use std::sync::OnceLock;

use crate::{VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use descriptor::{apply_transposed, descriptors};
use model::{CnrModel, Stage};

/// What the built-in model is called in messages.
pub const BUILTIN_LABEL: &str = "<built-in models/cnr/cnr.json>";

static BUILTIN: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../models/cnr/cnr.json"
));

/// Vertex-update passes after each stage (CNR's default).
pub const VERTEX_ITERATIONS: usize = 20;

/// The built-in model (`models/cnr/cnr.json`, parsed once).
pub fn builtin() -> Result<&'static CnrModel, String> {
    static MODEL: OnceLock<Result<CnrModel, String>> = OnceLock::new();
    MODEL
        .get_or_init(|| CnrModel::parse(BUILTIN, BUILTIN_LABEL))
        .as_ref()
        .map_err(Clone::clone)
}

/// The normals one stage regresses for every face of `mesh`.
pub fn stage_normals(stage: &Stage, mesh: &Mesh, topology: &Topology, rings: &Csr) -> Vec<Vec3> {
    let geometry = FaceGeometry::new(mesh);
    let l_e = mean_edge_length(mesh, topology);
    descriptors(&geometry, rings, l_e)
        .par_iter()
        .zip(&geometry.normals)
        .map(|((d, r), &own)| {
            let y = vec3::normalize_or_zero(stage.predict(d));
            if y == [0.0; 3] || !y.iter().all(|v| v.is_finite()) {
                own
            } else {
                apply_transposed(r, y)
            }
        })
        .collect()
}

/// Runs `stages` of `model` on `mesh` (all when 0).
pub fn run_cascade(
    model: &CnrModel,
    mesh: &Mesh,
    stages: usize,
    vertex_iterations: usize,
    fold_guard: Option<f64>,
    progress: &dyn Progress,
) -> Mesh {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let rings = topology.face_rings(model.ring);
    let count = if stages == 0 {
        model.stages.len()
    } else {
        stages.min(model.stages.len())
    };
    let mut positions = mesh.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let update = VertexUpdate {
        iterations: vertex_iterations,
        fixed: None,
        fold_guard,
    };
    progress.start("CNR", count as u64);
    for stage in &model.stages[..count] {
        let current = mesh.with_positions(positions.clone());
        let normals = stage_normals(stage, &current, &topology, &rings);
        vertex_update_with(
            &mut positions,
            &mesh.faces,
            &topology,
            &normals,
            &update,
            &mut buffers,
        );
        progress.advance(1);
    }
    progress.finish();
    mesh.with_positions(positions)
}
