//! Burn-free CPU inference and training of the NormalNet CNN (SPEC §6).
//!
//! Inference ([`Cnn`]) and training ([`Trainer`]: forward,
//! backward and Adam, what `normalnet train` runs; burn stays only behind
//! `normalnet-net`'s feature as a cross-check) run with no deep-learning
//! stack: batch norm is folded into the
//! preceding convolution or linear layer, the first 5³ convolution reads
//! only the occupied voxels (a face neighbourhood is a surface sheet: a few %
//! of the grid; on AVX-512 and AVX2 as 1D convolutions of the grid rows that
//! cross it, in the scalar path as a scatter of the occupied cubes), later layers compute only the cubes whose receptive field
//! reaches an occupied voxel (every other cube equals the activation of an
//! empty grid, computed once), and the 3³ convolutions run channels-last with the
//! output channels held in registers, compiled for AVX-512 / AVX2+FMA and
//! chosen at run time. Samples of a batch run in parallel (rayon), each one
//! start to finish on one thread, so results do not depend on the thread count.
//!
//! Data flow: `normalnet-net` exports a trained model as [`NetWeights`] (plain
//! arrays in burn's layouts), [`Cnn::new`] compiles them, [`Cnn::forward`]
//! maps `[3, D, H, W]` grids from `normalnet-voxel` to 18 outputs per face.

mod conv;
mod conv_int8;
#[cfg(target_arch = "x86_64")]
mod conv_int8_avx2;
mod error;
mod network;
mod sparse_conv;
mod stem_rows;
mod train;
mod weights;

pub use conv_int8::Int8Range;
pub use error::CnnError;
pub use network::{Arithmetic, Cnn, LayerTimes};
pub use normalnet_isa::Isa;
pub use train::{AdamConfig, Loss, Trainer};
pub use weights::{BatchNormWeights, BlockWeights, ConvWeights, LinearWeights, NetWeights};
