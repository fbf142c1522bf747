//! Training samples of NormalNet (paper §4, SPEC §8): the voxel grid of a
//! face of a noisy mesh paired with its GT-guided GNF target normals
//! ([`SampleSource`]), drawn balanced over the `A_p` categories
//! ([`BalancedSampler`]) and built on worker threads ([`Loader`]).
//!
//! Here, not in `normalnet-voxel`, because the targets come from a filter:
//! the voxelizer depends on the mesh crate only, this crate on both.

pub mod error;
pub mod loader;
pub mod sampler;
pub mod source;

pub use error::SampleError;
pub use loader::{Batch, Loader, LoaderConfig};
pub use sampler::{BalancedSampler, SampleRef};
pub use source::{A_P_EDGES, MU_GS, SampleSource};
