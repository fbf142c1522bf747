//! CNR, cascaded normal regression (Wang, Liu & Tong 2016; SPEC §9.1), the
//! learned baseline of the paper's comparison: per stage, each face's
//! filtered facet normal descriptor ([`descriptor`]) is mapped to its
//! normal by the regressor of its cluster ([`model`]), then the vertices
//! follow the normals (Sun et al., N_v 20, with the shared fold guard);
//! 3 stages. Training: [`train`]. The shipped model (`models/cnr/cnr.json`)
//! is built into the library.

pub mod descriptor;
pub mod model;
pub mod train;

use std::path::PathBuf;

use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::mean_edge_length;
use normalnet_mesh::outliers::denoise_around;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Csr, FaceGeometry, Mesh, Progress, Topology};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::DenoiseError;
use crate::params::{Params, defaults_of, resolve};
use crate::registry::{Kind, Method, MethodInfo, Outcome};
use descriptor::{apply_transposed, descriptors};
use model::{CnrModel, Stage};

/// What the built-in model is called in messages.
pub const BUILTIN_LABEL: &str = "<built-in models/cnr/cnr.json>";

static BUILTIN: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../models/cnr/cnr.json"
));

/// The registry entry.
pub const INFO: MethodInfo = MethodInfo {
    name: "cnr",
    aliases: &[],
    summary: "cascaded normal regression: per-cluster regressors on filtered facet normal descriptors (Wang et al. 2016)",
    kind: Kind::Learned,
    flags: &[
        ("vertex-iterations", "vertex_iterations"),
        ("model", "model"),
        ("no-fold-guard", "fold_guard"),
    ],
    defaults: defaults_of::<CnrParams>,
    build,
};

/// CNR's parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CnrParams {
    /// model file (JSON); none: the built-in one
    pub model: Option<PathBuf>,
    /// stages to run (at most the model's; 0 = all)
    pub stages: usize,
    /// vertex-update passes after each stage (20)
    pub vertex_iterations: usize,
    /// the fold guard of the vertex update (on)
    pub fold_guard: bool,
}

impl Default for CnrParams {
    fn default() -> Self {
        CnrParams {
            model: None,
            stages: 0,
            vertex_iterations: 20,
            fold_guard: true,
        }
    }
}

/// Loads the model `params` names.
pub fn load_model(model: Option<&PathBuf>) -> Result<(CnrModel, String), DenoiseError> {
    let bad = |message: String| DenoiseError::Parameter {
        method: INFO.name,
        message,
    };
    match model {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| bad(format!("{}: {e}", path.display())))?;
            let label = path.display().to_string();
            Ok((CnrModel::parse(&text, &label).map_err(bad)?, label))
        }
        None => Ok((
            CnrModel::parse(BUILTIN, BUILTIN_LABEL).map_err(bad)?,
            BUILTIN_LABEL.to_string(),
        )),
    }
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

struct Cnr {
    params: CnrParams,
    model: CnrModel,
    label: String,
}

fn build(name: &'static str, given: &Params) -> Result<Box<dyn Method>, DenoiseError> {
    let params: CnrParams = resolve(name, given)?;
    if params.vertex_iterations == 0 {
        return Err(DenoiseError::Parameter {
            method: name,
            message: "vertex_iterations = 0 would return the input unchanged; give at least 1 (default 20)".into(),
        });
    }
    let (model, label) = load_model(params.model.as_ref())?;
    Ok(Box::new(Cnr {
        params,
        model,
        label,
    }))
}

impl Method for Cnr {
    fn parameters(&self) -> Value {
        let mut v = serde_json::to_value(&self.params).unwrap_or(Value::Null);
        v["model"] = Value::String(self.label.clone());
        v
    }

    fn run(
        &self,
        mesh: &Mesh,
        _gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        let p = &self.params;
        let guard = p.fold_guard.then_some(FOLD_GUARD_COS);
        let mesh = denoise_around(mesh, |m| {
            Ok::<_, DenoiseError>(run_cascade(
                &self.model,
                m,
                p.stages,
                p.vertex_iterations,
                guard,
                progress,
            ))
        })?;
        Ok(Outcome {
            mesh,
            stages: None,
            folds: None,
        })
    }
}
