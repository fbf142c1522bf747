//! CNR, cascaded normal regression (Wang, Liu & Tong 2016; SPEC §9.1), the
//! learned baseline of the paper's comparison: per stage, each face's
//! filtered facet normal descriptor ([`descriptor`]) is mapped to its
//! normal by the regressor of its cluster ([`model`]), then the vertices
//! follow the normals (Sun et al., N_v 20, with the shared fold guard);
//! 3 stages. Training: [`train`]. The shipped model (`models/cnr/cnr.json`)
//! is built into the library.

pub mod train;

pub use normalnet_filters::cnr::{BUILTIN_LABEL, descriptor, model, run_cascade, stage_normals};

use std::path::PathBuf;

use normalnet_filters::FOLD_GUARD_COS;
use normalnet_mesh::outliers::denoise_around;
use normalnet_mesh::{Mesh, Progress};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::DenoiseError;
use crate::params::{Params, defaults_of, resolve};
use crate::registry::{Kind, Method, MethodInfo, Outcome};
use model::CnrModel;

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
            vertex_iterations: normalnet_filters::cnr::VERTEX_ITERATIONS,
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
            normalnet_filters::cnr::builtin().map_err(bad)?.clone(),
            BUILTIN_LABEL.to_string(),
        )),
    }
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
