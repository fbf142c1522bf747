//! `CnnError`: weights that do not fit together, or buffers of the wrong size.

/// Errors of the CPU inference engine.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum CnnError {
    /// A weight array does not have the length its layer's shape requires.
    #[error("layer {layer}: {what} has {actual} values, expected {expected}")]
    WeightShape {
        /// which layer (e.g. `block 2 conv_a`)
        layer: String,
        /// which array
        what: &'static str,
        /// its length
        actual: usize,
        /// the length its shape requires
        expected: usize,
    },
    /// Consecutive layers disagree on a channel count or size.
    #[error("layer {layer}: {message}")]
    Mismatch {
        /// which layer
        layer: String,
        /// what does not fit
        message: String,
    },
    /// A sparse input sample ([`crate::Cnn::forward_sparse`]) is malformed.
    #[error("sparse input sample {sample}: {message}")]
    SparseSample {
        /// its position in the batch
        sample: usize,
        /// what is wrong
        message: String,
    },
    /// A kernel path this CPU does not run ([`crate::Cnn::set_isa`]).
    #[error("kernel path {asked}: this CPU does not run it (the best it runs is {detected})")]
    Isa {
        /// the path asked for
        asked: &'static str,
        /// the best path this CPU runs
        detected: &'static str,
    },
    /// An input or output buffer has the wrong length.
    #[error("{what} has {actual} values, expected {expected}")]
    BufferSize {
        /// which buffer
        what: &'static str,
        /// its length
        actual: usize,
        /// the required length
        expected: usize,
    },
}
