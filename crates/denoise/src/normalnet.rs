//! NormalNet (paper §3, SPEC §7) as a registered denoiser: the model bundle
//! is loaded and its networks compiled once, when the denoiser is built.
//! The bundle: parameter `model` (a folder), else `$NORMALNET_MODEL`, else
//! the shipped `models/lite` built into the library.

use std::path::PathBuf;

use normalnet_filters::GnfParams;
use normalnet_mesh::outliers::denoise_around;
use normalnet_mesh::{Mesh, Progress};
use normalnet_net::{Arithmetic, Bundle, DenoiseParams};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::DenoiseError;
use crate::cnr::model::CnrModel;
use crate::cnr::{load_model, run_cascade};
use crate::params::{Params, defaults_of, resolve};
use crate::registry::{Kind, Method, MethodInfo, Outcome};

/// Environment variable naming a bundle folder (the `model` parameter wins).
pub const MODEL_ENV: &str = "NORMALNET_MODEL";

/// The registry entry.
pub const INFO: MethodInfo = MethodInfo {
    name: "normalnet",
    aliases: &[],
    summary: "NormalNet: voxelized neighbourhoods, a 3D CNN predicts the filtered normals (Zhao et al. 2019)",
    kind: Kind::Learned,
    flags: &[
        ("iterations", "iterations"),
        ("vertex-iterations", "vertex_iterations"),
        ("mu-g", "mu_g"),
        ("model", "model"),
        ("guided-from", "guided_from"),
        ("no-fold-guard", "fold_guard"),
        ("auto-stop", "auto_stop_deg"),
        ("no-switch", "switch"),
        ("f32", "int8"),
    ],
    defaults: defaults_of::<NormalnetParams>,
    build,
};

/// NormalNet's parameters; `Default` is SPEC §7. The pipeline's settings
/// are [`DenoiseParams`]'s fields (flattened: one key each, written and
/// documented once, in `normalnet_net::pipeline::params`); around them the
/// bundle, the GNF passes after it and the arithmetic.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NormalnetParams {
    /// model bundle folder; none: `$NORMALNET_MODEL`, else the built-in one
    pub model: Option<PathBuf>,
    /// the pipeline (iterations, μ_g, form, skips, stop rule, fold guard)
    #[serde(flatten)]
    pub pipeline: DenoiseParams,
    /// stages of the built-in CNR model (cascaded normal regression, 20
    /// vertex passes each) run on the input before NormalNet (0 = none, the
    /// paper's form; an experiment of issue 34)
    pub cnr_before: usize,
    /// GNF normal passes (reference settings but μ_g = `mu_g`, 10 vertex
    /// passes each) run on NormalNet's result (0 = none, the paper's form)
    pub gnf_after: usize,
    /// the arithmetic of the networks
    #[serde(flatten)]
    pub arithmetic: Arithmetic,
}

impl NormalnetParams {
    /// Checks the ranges (before any bundle is loaded).
    pub fn check(&self) -> Result<(), DenoiseError> {
        let bad = |message: String| DenoiseError::Parameter {
            method: INFO.name,
            message,
        };
        if self.pipeline.vertex_iterations == 0 {
            return Err(bad(
                "vertex_iterations = 0 would run the whole network and return the input unchanged \
                 (NormalNet moves vertices only in its vertex-update passes); give at least 1 \
                 (default 20)"
                    .into(),
            ));
        }
        self.pipeline.validate().map_err(|e| bad(e.to_string()))
    }

    /// The bundle folder to load; `None`: the built-in bundle.
    pub fn model_path(&self) -> Option<PathBuf> {
        if let Some(p) = &self.model {
            return Some(p.clone());
        }
        match std::env::var_os(MODEL_ENV) {
            Some(p) if !p.is_empty() => Some(PathBuf::from(p)),
            _ => None,
        }
    }

    /// Loads the bundle these parameters name.
    pub fn load_bundle(&self) -> Result<Bundle, DenoiseError> {
        Ok(match self.model_path() {
            Some(path) => Bundle::load(path)?,
            None => normalnet_net::embedded::lite()?,
        })
    }
}

struct NormalNet {
    params: NormalnetParams,
    bundle: Bundle,
    /// the arithmetic the networks run on this CPU (what the parameters
    /// asked for where the kernel path and networks allow)
    arithmetic: Arithmetic,
    /// the built-in CNR model where `cnr_before` asks for its stages
    cnr: Option<CnrModel>,
}

fn build(name: &'static str, given: &Params) -> Result<Box<dyn Method>, DenoiseError> {
    let params: NormalnetParams = resolve(name, given)?;
    params.check()?;
    let mut bundle = params.load_bundle()?;
    let arithmetic = bundle.set_arithmetic(params.arithmetic);
    let cnr = match params.cnr_before {
        0 => None,
        _ => Some(load_model(None)?.0),
    };
    Ok(Box::new(NormalNet {
        params,
        bundle,
        arithmetic,
        cnr,
    }))
}

impl Method for NormalNet {
    fn parameters(&self) -> Value {
        let mut v = serde_json::to_value(&self.params).unwrap_or(Value::Null);
        // say which bundle ran, the built-in one included
        v["model"] = Value::String(self.bundle.path.display().to_string());
        // and the arithmetic that ran (int8 falls back to f32 without AVX2)
        v["int8"] = Value::Bool(self.arithmetic.int8);
        v["int8_stem"] = Value::Bool(self.arithmetic.int8_stem);
        v["int8_shortcut"] = Value::Bool(self.arithmetic.int8_shortcut);
        // the integer ranges they ran with (null with f32 blocks)
        v["int8_range"] = match self.bundle.engines[0].int8_range_in_use() {
            Some(range) => Value::String(range.name().into()),
            None => Value::Null,
        };
        // and the kernel path (NORMALNET_ISA, else the best this CPU runs)
        v["isa"] = Value::String(self.bundle.engines[0].instruction_set().into());
        v
    }

    fn run(
        &self,
        mesh: &Mesh,
        _gt: Option<&Mesh>,
        progress: &dyn Progress,
    ) -> Result<Outcome, DenoiseError> {
        let params = &self.params.pipeline;
        let mut stages = None;
        let mesh = denoise_around(mesh, |m| {
            let before;
            let m = match &self.cnr {
                Some(model) => {
                    let guard = params.fold_guard.then_some(params.fold_guard_cos);
                    let passes = normalnet_filters::cnr::VERTEX_ITERATIONS;
                    before = run_cascade(model, m, self.params.cnr_before, passes, guard, progress);
                    &before
                }
                None => m,
            };
            let (out, times) = normalnet_net::denoise(m, &self.bundle, params, progress)?;
            stages = Some(times);
            if self.params.gnf_after == 0 {
                return Ok::<_, DenoiseError>(out);
            }
            let gnf = GnfParams {
                mu_g: params.mu_g,
                normal_iterations: self.params.gnf_after,
                fold_guard: params.fold_guard,
                ..GnfParams::default()
            };
            Ok(normalnet_filters::gnf(&out, &gnf, progress)?)
        })?;
        Ok(Outcome {
            mesh,
            stages,
            folds: None,
        })
    }
}
