//! Iterative training of the six networks (paper §4, SPEC §8).
//!
//! `M_1` = noisy copies of the clean training sources. Network k (interval
//! `[a_k, b_k]` of [`INTERVALS`]) is trained on samples of the meshes
//! `M_{a_k}`: (voxel grid of face f with random yaw, the six GT-guided GNF
//! targets of f in the same frame), balanced over the four `A_p` categories
//! and built on the fly by loader threads (`normalnet_samples::Loader`). Loss
//! MSE, Adam (0.9, 0.999, 1e-8), lr `base · 0.96^(step / 5000)`, batch 80.
//! After network k is trained, `M_{a_{k+1}}` is made by running network k
//! (μ_g 0.4, N_v 20) `a_{k+1} − a_k` times on `M_{a_k}` — network k is the one
//! inference uses for those iterations.
//!
//! Deviations for a CPU budget (all recorded in the bundle manifest):
//! - meshes marked `regen` in the config (small ones) are regenerated with
//!   the CNN; the others (large meshes, validation meshes) with the *oracle*
//!   the CNN is trained to imitate: one GT-guided GNF pass at μ_g 0.4
//!   (σ_s = 2·d_s) + N_v 20 vertex updates per iteration;
//! - network k > 1 starts from network k−1's weights (warm start);
//! - step counts and wall-clock limits per network come from the config.
//!
//! The run is resumable: every few minutes the current weights, Adam state
//! and step are written to `OUT/checkpoint/step-S/` (and `OUT/state.toml`); the best weights (lowest
//! validation error) to `OUT/netK.safetensors`; the mesh states `M_k` to
//! `OUT/states/`, each as soon as it is made (moving a few million faces on
//! through a network takes hours on two cores: a run stopped in the middle
//! keeps the meshes it had moved on). `--resume` continues where it stopped;
//! a new run in the same folder removes the old states.

mod config;
mod pairs;
mod run;
mod validation;

pub use config::{
    MAX_COMPONENTS, MAX_MIXTURES, MIXTURE_SEED, SourceSpec, TEST_MODELS, TrainConfig,
    default_data_dir,
};
pub use pairs::noisy_pairs;
pub use run::train;

/// Output slot of μ_g 0.35, the one validated (SPEC §8).
const VALIDATION_SLOT: usize = 2;
/// μ_g used to regenerate the meshes M_k (SPEC §8).
const REGEN_MU_G: f64 = 0.4;
/// Vertex updates per regeneration iteration (SPEC §8).
const REGEN_VERTEX_ITERATIONS: usize = 20;
