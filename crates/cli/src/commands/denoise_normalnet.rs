//! The NormalNet method of `normalnet denoise` (SPEC §7): loads a model
//! bundle (the shipped one by default) and runs the iterative pipeline.

use normalnet_mesh::{Mesh, Progress};
use std::path::PathBuf;

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
}

/// Denoises `mesh` with NormalNet.
pub fn denoise(
    _mesh: &Mesh,
    _options: &NormalnetOptions,
    _progress: &dyn Progress,
) -> anyhow::Result<Mesh> {
    anyhow::bail!("the NormalNet method is not implemented yet")
}
