//! NormalNet's 3D CNN in burn (Zhao et al. 2019; SPEC §5–8): the network
//! ([`model`]), batching voxel grids into tensors ([`data`]), model bundles of
//! six trained networks ([`bundle`]), the denoising pipeline ([`inference`])
//! and the iterative training scheme ([`training`]). The CLI picks the device
//! (`Device::flex()` on CPU) and calls [`inference::denoise`] / training.

pub mod bundle;
pub mod data;
pub mod error;
pub mod model;
pub mod step;

pub use bundle::{Bundle, Manifest};
pub use error::NetError;
pub use model::{MU_GS, ModelConfig, NormalNet};
