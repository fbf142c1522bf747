//! `MeshError`: everything that can go wrong building, reading or writing a mesh.

use std::path::PathBuf;

/// Errors of the mesh crate. Messages name the file, line or element.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The mesh has no vertices or no faces.
    #[error("empty mesh: {vertices} vertices, {faces} faces")]
    Empty {
        /// number of vertices
        vertices: usize,
        /// number of faces
        faces: usize,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the mesh has {num_vertices} vertices")]
    IndexOutOfRange {
        /// face index (after triangulation)
        face: usize,
        /// the bad vertex index
        index: u64,
        /// number of vertices
        num_vertices: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value:?}")]
    NonFinite {
        /// vertex index
        vertex: usize,
        /// the coordinates
        value: [f64; 3],
    },
    /// More vertices or faces than a u32 index can hold.
    #[error("too many elements for u32 indices: {0}")]
    TooLarge(usize),
    /// A parse error in an input file.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// the file
        path: PathBuf,
        /// 1-based line number (0 for binary files or the header as a whole)
        line: usize,
        /// what is wrong
        message: String,
    },
    /// An I/O error with the file it happened on.
    #[error("{path}: {source}")]
    Io {
        /// the file
        path: PathBuf,
        /// the underlying error
        source: std::io::Error,
    },
    /// The format could not be chosen from the extension.
    #[error("{path}: unknown mesh format (expected .obj, .off, .ply, .stl, .gltf or .glb)")]
    UnknownFormat {
        /// the file
        path: PathBuf,
    },
    /// Two meshes that must share connectivity do not.
    #[error("meshes do not match: {0}")]
    Mismatch(String),
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// the parameter's name
        name: &'static str,
        /// what is wrong
        message: String,
    },
}
