//! Voxelization of face neighbourhoods (SPEC §5), procedural training shapes
//! and training samples (SPEC §8).
//!
//! The [`Voxelizer`] turns the neighbourhood of a face into the `[3, D, H, W]`
//! grid the NormalNet CNN reads (crate `normalnet-net`); [`samples`] pairs
//! grids with GT-guided GNF targets for training; [`shapes`] makes CAD-like
//! closed meshes to train on.

pub mod error;
pub mod frame;
pub mod inspect;
pub mod loader;
pub mod params;
pub mod sampler;
pub mod samples;
pub mod shapes;
pub mod tri_box_overlap;
pub mod voxelizer;

pub use error::VoxelError;
pub use frame::Frame;
pub use loader::{Batch, Loader, LoaderConfig};
pub use params::VoxelParams;
pub use sampler::{BalancedSampler, SampleRef};
pub use samples::{A_P_EDGES, MU_GS, SampleSource};
pub use voxelizer::{Scratch, SparseGrid, Voxelizer};
