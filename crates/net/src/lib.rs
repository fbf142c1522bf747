//! NormalNet's 3D CNN in burn (Zhao et al. 2019; SPEC §5–8): the network
//! ([`model`]), batching voxel grids into tensors ([`data`]), model bundles of
//! six trained networks ([`bundle`]), the denoising pipeline ([`inference`])
//! and the iterative training scheme ([`training`]). The CLI picks the device
//! (`Device::flex()` on CPU) and calls [`inference::denoise`] / training.

pub mod bundle;
pub mod data;
pub mod error;
pub mod export;
pub mod import;
pub mod inference;
pub mod learner;
pub mod model;
pub mod plot;
pub mod step;
pub mod training;

pub use bundle::{Bundle, Manifest};
pub use error::NetError;
pub use inference::{DenoiseParams, StageTimes, denoise};
pub use model::{MU_GS, ModelConfig, NormalNet};

/// burn's device handle, re-exported so callers need no direct burn dependency.
pub use burn::tensor::Device;

/// The CPU device (burn's Flex backend), for inference.
pub fn cpu_device() -> Device {
    Device::flex()
}
