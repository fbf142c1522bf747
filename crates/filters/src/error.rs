//! `FilterError`: everything that can go wrong running a classical denoiser.

use normalnet_mesh::MeshError;

/// Errors of the filters crate. Messages name the parameter or element.
#[derive(Debug, thiserror::Error)]
pub enum FilterError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// the parameter's name (the params struct's field)
        name: &'static str,
        /// what is wrong
        message: String,
    },
    /// A per-face or per-vertex array has the wrong length.
    #[error("{what} has {found} entries, but the mesh has {expected}")]
    LengthMismatch {
        /// which array (e.g. "ground-truth normals")
        what: &'static str,
        /// the mesh's count
        expected: usize,
        /// the array's length
        found: usize,
    },
    /// A per-face input value is NaN or infinite.
    #[error("{what} of face {face} is not finite: {value:?}")]
    NonFinite {
        /// which array
        what: &'static str,
        /// the face index
        face: usize,
        /// the value
        value: [f64; 3],
    },
    /// The sparse linear solve of the L0 vertex step failed.
    #[error("L0 vertex step, iteration {iteration}: sparse Cholesky failed ({message})")]
    Solver {
        /// outer iteration (0-based)
        iteration: usize,
        /// the solver's message
        message: String,
    },
    /// An error from the mesh crate.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// Checks `value` is finite and within `[lo, hi]` (either bound optional);
/// the error names `name`.
pub(crate) fn check_range(
    name: &'static str,
    value: f64,
    lo: Option<f64>,
    hi: Option<f64>,
    strict_lo: bool,
) -> Result<(), FilterError> {
    let bad = |message: String| Err(FilterError::InvalidParameter { name, message });
    let (v, lo_text, hi_text) = (show(value), lo.map(show), hi.map(show));
    if !value.is_finite() {
        return bad(format!("{v} is not finite"));
    }
    if let (Some(lo), Some(lo_text)) = (lo, lo_text) {
        if strict_lo && value <= lo {
            return bad(format!("{v} must be greater than {lo_text}"));
        }
        if !strict_lo && value < lo {
            return bad(format!("{v} must be at least {lo_text}"));
        }
    }
    if let (Some(hi), Some(hi_text)) = (hi, hi_text)
        && value > hi
    {
        return bad(format!("{v} must be at most {hi_text}"));
    }
    Ok(())
}

/// `x` for a message: plain (`0.35`, `1000`), or in exponent form when the
/// plain one runs long (`1e300`, not three hundred digits).
fn show(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() > 12 {
        format!("{x:e}")
    } else {
        plain
    }
}
