//! NormalNet (Zhao et al. 2019; SPEC §5–8) without a deep-learning
//! framework: the architecture and fresh weights ([`arch`]), weight files
//! ([`weights_file`], safetensors), model bundles of six trained networks
//! ([`bundle`]), the denoising pipeline ([`pipeline`]) and the iterative
//! training scheme ([`training`]), all running on the CPU engine of
//! `normalnet-cnn`.
//!
//! The feature `burn` adds the same network in burn ([`model`]), its
//! autodiff training step ([`step`]) and the conversions between the two
//! ([`export`], [`import`]): the reference the CPU engine is checked
//! against, the `engine = "burn"` training option, and the reader of
//! format-1 bundles (burn records).

pub mod arch;
pub mod bundle;
#[cfg(feature = "burn")]
pub mod convert;
pub mod data;
#[cfg(feature = "embedded-model")]
pub mod embedded;
pub mod error;
#[cfg(feature = "burn")]
pub mod export;
#[cfg(feature = "burn")]
pub mod import;
pub mod learner;
#[cfg(feature = "burn")]
pub mod model;
pub mod pipeline;
pub mod plot;
#[cfg(feature = "burn")]
pub mod step;
pub mod switch;
pub mod switch_fit;
pub mod switch_rows;
pub mod training;
pub mod weights_file;

pub use arch::{MU_GS, ModelConfig, NUM_OUTPUTS};
pub use bundle::{Bundle, Manifest};
pub use error::NetError;
#[cfg(feature = "burn")]
pub use model::NormalNet;
pub use normalnet_cnn::{Arithmetic, Int8Range};
pub use pipeline::{DenoiseParams, StageTimes, denoise};
