//! The oracle: GT-guided GNF (guidance = the ground truth's face normals,
//! σ_s 2·d_s; SPEC §8), NormalNet's training target run as a denoiser — the
//! ceiling a perfect network would reach (MEASURED.md). It reads the ground
//! truth, so it is a reference, never a result. Also called `gt-gnf`.

use normalnet_filters::{GtGuidedGnfParams, gt_guided_gnf};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::{Mesh, Progress};
use serde_json::Value;

use crate::DenoiseError;
use crate::params::{Params, defaults_of, resolve};
use crate::registry::{Kind, Method, MethodInfo, Outcome};

/// The registry entry.
pub const INFO: MethodInfo = MethodInfo {
    name: "oracle",
    aliases: &["gt-gnf"],
    summary: "GNF guided by the ground truth's normals: NormalNet's training target, the ceiling of a perfect network (reads the ground truth)",
    kind: Kind::Oracle,
    flags: &[
        ("iterations", "iterations"),
        ("vertex-iterations", "vertex_iterations"),
        ("mu-g", "mu_g"),
        ("sigma-s", "sigma_s_over_ds"),
    ],
    defaults: defaults_of::<GtGuidedGnfParams>,
    build,
};

struct Oracle {
    params: GtGuidedGnfParams,
}

fn build(name: &'static str, given: &Params) -> Result<Box<dyn Method>, DenoiseError> {
    let params: GtGuidedGnfParams = resolve(name, given)?;
    params.validate().map_err(|e| DenoiseError::Parameter {
        method: name,
        message: e.to_string(),
    })?;
    Ok(Box::new(Oracle { params }))
}

impl Method for Oracle {
    fn parameters(&self) -> Value {
        serde_json::to_value(&self.params).unwrap_or(Value::Null)
    }

    fn run(
        &self,
        mesh: &Mesh,
        gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        let gt = gt.ok_or(DenoiseError::NeedsGroundTruth { method: INFO.name })?;
        if gt.num_faces() != mesh.num_faces() {
            return Err(DenoiseError::Parameter {
                method: INFO.name,
                message: format!(
                    "the ground truth has {} faces, the mesh {}: the guidance is face by face",
                    gt.num_faces(),
                    mesh.num_faces()
                ),
            });
        }
        Ok(Outcome {
            mesh: gt_guided_gnf(mesh, &face_normals(gt), &self.params, progress)?,
            stages: None,
            folds: None,
        })
    }
}
