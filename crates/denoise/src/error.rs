//! Errors of `normalnet-denoise`: unknown names, bad parameters (naming the
//! method and the parameter), a missing ground truth, a mesh too large for
//! f64, and the errors of the methods themselves.

/// Everything that can go wrong in choosing or running a denoiser.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    /// `NORMALNET_ISA` names no kernel path, or one this CPU does not run.
    #[error("{0}")]
    Isa(#[from] normalnet_isa::IsaError),
    /// No registered method has this name.
    #[error("unknown method {name:?} (known: {known})")]
    UnknownMethod {
        /// the name asked for
        name: String,
        /// the registered names, comma-separated
        known: String,
    },
    /// A parameter is unknown, of the wrong type or out of range.
    #[error("{method}: {message}")]
    Parameter {
        /// the method's name
        method: &'static str,
        /// what is wrong, naming the parameter
        message: String,
    },
    /// The method reads the ground truth and none was given.
    #[error("{method} reads the ground truth: give the clean mesh")]
    NeedsGroundTruth {
        /// the method's name
        method: &'static str,
    },
    /// The mesh's bounding box overflows f64 (its diagonal is infinite):
    /// no exact change of unit brings it into range.
    #[error(
        "the mesh's extent overflows f64 (coordinates up to {largest:e}, bounding-box diagonal \
         infinite): scale it down before denoising"
    )]
    ExtentOverflow {
        /// the largest absolute coordinate
        largest: f64,
    },
    /// A validation suite is invalid or could not be generated
    /// ([`crate::suite`]).
    #[error("{}: {message}", path.display())]
    Suite {
        /// the suite file (or the cache folder, when generating)
        path: std::path::PathBuf,
        /// what is wrong, naming the pair
        message: String,
    },
    /// A training recipe is invalid or one of its stages failed
    /// ([`crate::recipe`]).
    #[error("{}: {message}", path.display())]
    Recipe {
        /// the recipe file, or the stage's folder
        path: std::path::PathBuf,
        /// what is wrong, naming the stage
        message: String,
    },
    /// A classical filter failed.
    #[error(transparent)]
    Filter(#[from] normalnet_filters::FilterError),
    /// NormalNet failed (bundle, network, inference).
    #[error(transparent)]
    Net(#[from] normalnet_net::NetError),
    /// A mesh operation failed.
    #[error(transparent)]
    Mesh(#[from] normalnet_mesh::MeshError),
}
