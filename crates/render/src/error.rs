//! `RenderError`: what can go wrong rendering or writing a picture or report.

use std::path::PathBuf;

/// Errors of the render crate. Messages name the file, option or element.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// An option is out of its valid range.
    #[error("invalid render option {name}: {message}")]
    InvalidOption {
        /// the option's name
        name: &'static str,
        /// what is wrong
        message: String,
    },
    /// `face_colors` does not have one colour per face.
    #[error("face_colors has {got} entries but the mesh has {expected} faces")]
    FaceColorCount {
        /// number of faces of the mesh
        expected: usize,
        /// number of colours given
        got: usize,
    },
    /// PNG encoding or decoding failed.
    #[error("{path}: png: {message}")]
    Png {
        /// the file (or `<memory>`)
        path: PathBuf,
        /// the encoder's message
        message: String,
    },
    /// A material library or texture image could not be read.
    #[error("{path}: {message}")]
    Texture {
        /// the file
        path: PathBuf,
        /// what is wrong
        message: String,
    },
    /// Writing a file failed.
    #[error(transparent)]
    Mesh(#[from] normalnet_mesh::MeshError),
    /// Serialising a report failed.
    #[error("{path}: {message}")]
    Report {
        /// the file
        path: PathBuf,
        /// what is wrong
        message: String,
    },
}
