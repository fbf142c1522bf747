//! The NormalNet method of `normalnet denoise` (SPEC §7): loads a model
//! bundle (the one built into the program by default) and runs the
//! iterative pipeline.

use anyhow::Context;
use normalnet_mesh::{Mesh, Progress};
use normalnet_net::inference::StageTimes;
use normalnet_net::{Bundle, DenoiseParams};
use std::path::PathBuf;

/// Environment variable naming a bundle folder (overridden by `--model`).
pub const MODEL_ENV: &str = "NORMALNET_MODEL";

/// User choices for a NormalNet run; `None` means the SPEC §7 default
/// (N_f 10, N_v 20, μ_g 0.35, the shipped bundle).
#[derive(Clone, Debug, Default)]
pub struct NormalnetOptions {
    /// model bundle folder (`--model`)
    pub model: Option<PathBuf>,
    /// filtering iterations N_f (`--iterations`)
    pub iterations: Option<usize>,
    /// vertex-update passes per iteration N_v (`--vertex-iterations`)
    pub vertex_iterations: Option<usize>,
    /// μ_g: picks the nearest of the bundle's outputs (`--mu-g`)
    pub mu_g: Option<f64>,
    /// guided form from this iteration on, 0 = never (`--guided-from`)
    pub guided_from: Option<usize>,
    /// the fold guard of the vertex update (`--no-fold-guard` turns it off)
    pub fold_guard: Option<bool>,
    /// the guard's cone, cos of the largest turn (bench key `fold_guard_cos`)
    pub fold_guard_cos: Option<f64>,
}

/// The bundle folder to use: `--model`, else `$NORMALNET_MODEL`; `None`:
/// the shipped `models/lite`, built into the program.
pub fn model_path(options: &NormalnetOptions) -> Option<PathBuf> {
    if let Some(p) = &options.model {
        return Some(p.clone());
    }
    match std::env::var_os(MODEL_ENV) {
        Some(p) if !p.is_empty() => Some(PathBuf::from(p)),
        _ => None,
    }
}

/// The pipeline parameters: the options over the SPEC §7 defaults.
pub fn params(options: &NormalnetOptions) -> DenoiseParams {
    let d = DenoiseParams::default();
    DenoiseParams {
        iterations: options.iterations.unwrap_or(d.iterations),
        vertex_iterations: options.vertex_iterations.unwrap_or(d.vertex_iterations),
        mu_g: options.mu_g.unwrap_or(d.mu_g),
        batch: d.batch,
        guided_from: options.guided_from.unwrap_or(d.guided_from),
        fold_guard: match (options.fold_guard, options.fold_guard_cos) {
            (Some(false), _) => None,
            (_, Some(cos)) => Some(cos),
            _ => d.fold_guard,
        },
    }
}

/// Loads the bundle chosen by `options` and compiles its networks.
pub fn load_bundle(options: &NormalnetOptions) -> anyhow::Result<Bundle> {
    match model_path(options) {
        Some(path) => Bundle::load(&path)
            .with_context(|| format!("loading the NormalNet model bundle {}", path.display())),
        None => normalnet_net::embedded::lite().context("the built-in NormalNet model"),
    }
}

/// Denoises `mesh` with NormalNet.
pub fn denoise(
    mesh: &Mesh,
    options: &NormalnetOptions,
    progress: &dyn Progress,
) -> anyhow::Result<Mesh> {
    denoise_with_stages(mesh, options, progress).map(|(m, _)| m)
}

/// [`denoise`] that also returns the seconds spent per stage (voxelize /
/// CNN / vertex update), for `--json` reports.
pub fn denoise_with_stages(
    mesh: &Mesh,
    options: &NormalnetOptions,
    progress: &dyn Progress,
) -> anyhow::Result<(Mesh, StageTimes)> {
    let bundle = load_bundle(options)?;
    let params = params(options);
    normalnet_net::denoise(mesh, &bundle, &params, progress)
        .with_context(|| format!("NormalNet with bundle {}", bundle.path.display()))
}
