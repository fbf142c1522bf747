//! `VoxelError`: everything that can go wrong voxelizing, generating shapes
//! or writing inspection files.

use normalnet_mesh::MeshError;
use std::path::PathBuf;

/// Errors of the voxel crate. Messages name the parameter, face or file.
#[derive(Debug, thiserror::Error)]
pub enum VoxelError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// the parameter's name
        name: &'static str,
        /// what is wrong
        message: String,
    },
    /// The mesh has no pair of edge-adjacent faces, so `d_s` (and the cube
    /// side `L_c = d_s / α_c`) is zero or not finite.
    #[error(
        "cannot voxelize: mean centre distance d_s = {d_s} (the mesh needs edge-adjacent, non-degenerate faces)"
    )]
    NoScale {
        /// the measured d_s
        d_s: f64,
    },
    /// The topology was built for another mesh.
    #[error(
        "topology has {topology_faces} faces and {topology_vertices} vertices, the mesh {mesh_faces} and {mesh_vertices}"
    )]
    TopologyMismatch {
        /// faces in the topology
        topology_faces: usize,
        /// vertices in the topology
        topology_vertices: usize,
        /// faces in the mesh
        mesh_faces: usize,
        /// vertices in the mesh
        mesh_vertices: usize,
    },
    /// A face index is out of range.
    #[error("face {face} out of range (the mesh has {num_faces} faces)")]
    FaceOutOfRange {
        /// the face index
        face: usize,
        /// number of faces
        num_faces: usize,
    },
    /// A generated shape failed its own validity check (a bug in the generator).
    #[error("generated shape {kind} (seed {seed}) is invalid: {message}")]
    InvalidShape {
        /// shape kind
        kind: String,
        /// generator seed
        seed: u64,
        /// what is wrong
        message: String,
    },
    /// A mesh error (construction, I/O).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// An I/O error with the file it happened on.
    #[error("{path}: {source}")]
    Io {
        /// the file
        path: PathBuf,
        /// the underlying error
        source: std::io::Error,
    },
}
