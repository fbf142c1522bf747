//! Errors of the NormalNet crate: bundles (files, manifest, shapes), inference
//! and training inputs. Messages name the file, field or face involved.

use std::path::PathBuf;

/// Everything that can go wrong in `normalnet-net`.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// A file or folder could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// the file or folder
        path: PathBuf,
        /// the underlying error
        source: std::io::Error,
    },
    /// The bundle folder lacks a file it needs.
    #[error("model bundle {bundle}: missing file {file}")]
    MissingFile {
        /// the bundle folder
        bundle: PathBuf,
        /// the file name inside the bundle
        file: String,
    },
    /// `manifest.toml` could not be parsed or has invalid fields.
    #[error("{path}: bad manifest: {message}")]
    BadManifest {
        /// the manifest file
        path: PathBuf,
        /// what is wrong
        message: String,
    },
    /// A weight file does not match the architecture the manifest names.
    #[error("{path}: weights do not fit the {preset} network: {message}")]
    WeightMismatch {
        /// the weight file
        path: PathBuf,
        /// the preset named in the manifest
        preset: String,
        /// burn's description of the mismatch
        message: String,
    },
    /// A parameter is out of range (name and value in the message).
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// the parameter's name
        name: &'static str,
        /// what is wrong
        message: String,
    },
    /// A network output was not finite (NaN or infinite) for this face.
    #[error("network output for face {face} is not finite")]
    NonFiniteOutput {
        /// the face index
        face: usize,
    },
    /// The training configuration is invalid.
    #[error("training config {path}: {message}")]
    BadConfig {
        /// the config file (or `<defaults>`)
        path: PathBuf,
        /// what is wrong
        message: String,
    },
    /// An error from the mesh crate (reading a training mesh, ...).
    #[error(transparent)]
    Mesh(#[from] normalnet_mesh::MeshError),
    /// An error from the voxel crate (voxelizer, shapes).
    #[error(transparent)]
    Voxel(#[from] normalnet_voxel::VoxelError),
    /// An error building training samples.
    #[error(transparent)]
    Samples(#[from] normalnet_samples::SampleError),
    /// An error from the filters crate.
    #[error(transparent)]
    Filter(#[from] normalnet_filters::FilterError),
    /// Saving or loading burn records failed.
    #[error("{path}: {message}")]
    Record {
        /// the record file
        path: PathBuf,
        /// burn's message
        message: String,
    },
}

impl NetError {
    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> NetError {
        NetError::Io {
            path: path.into(),
            source,
        }
    }
}
