//! Voxelization of face neighbourhoods (SPEC §5) and procedural training
//! shapes.
//!
//! The [`Voxelizer`] turns the neighbourhood of a face into the `[3, D, H, W]`
//! grid the NormalNet CNN reads (crate `normalnet-net`); [`shapes`] makes
//! CAD-like closed meshes to train on. Training samples (grids paired with
//! GT-guided targets) are built in `normalnet-samples`, so this crate
//! depends on the mesh crate only.

pub mod error;
pub mod frame;
pub mod inspect;
pub mod params;
pub mod shapes;
pub mod tri_box_overlap;
pub mod voxelizer;

pub use error::VoxelError;
pub use frame::Frame;
pub use params::VoxelParams;
pub use voxelizer::{Scratch, SparseGrid, Voxelizer};
