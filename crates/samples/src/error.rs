//! `SampleError`: everything that can go wrong building training samples
//! and loading them.

use normalnet_filters::FilterError;
use normalnet_mesh::MeshError;
use normalnet_voxel::VoxelError;

/// Errors of the sample crate. Messages name the parameter, face or source.
#[derive(Debug, thiserror::Error)]
pub enum SampleError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// the parameter's name
        name: &'static str,
        /// what is wrong
        message: String,
    },
    /// The noisy and the clean mesh of a training pair differ in connectivity.
    #[error("noisy and clean meshes do not match: {0}")]
    PairMismatch(String),
    /// Voxelizing the noisy mesh failed.
    #[error(transparent)]
    Voxel(#[from] VoxelError),
    /// A filter error (the GT-guided targets).
    #[error(transparent)]
    Filter(#[from] FilterError),
    /// A mesh error.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}
