//! The change of unit around every method (`Denoiser::run`): a mesh whose
//! bounding-box diagonal lies outside `normalnet_mesh::scale`'s safe range
//! (`2^-40 ..= 2^40`) is denoised scaled by an exact power of two `2^k`
//! and the result scaled back by `2^-k`; a mesh inside it is denoised as it
//! is. Every method parameter is relative (multiples of `d_s`, `l_e`, `l_e²`,
//! angles, cosines, counts), so none changes with the unit.

use normalnet_mesh::Mesh;
use normalnet_mesh::scale::{
    SAFE_DIAGONAL_MAX, SAFE_DIAGONAL_MIN, bounding_box_diagonal, exponent, normalising_exponent,
};

use crate::DenoiseError;

/// The largest coordinate exponent a scaled mesh may reach (`2^1000`): room
/// for the sums of a pass without overflow.
const MAX_SCALED_EXPONENT: i32 = 1000;

/// The share of vertices whose extent sets the unit: the same 99th
/// percentile as `normalnet_mesh::outliers` (up to 1 % of the vertices may
/// be anywhere).
const ROBUST_QUANTILE: f64 = 0.99;

/// The `k` that `mesh` is denoised at (positions times `2^k`), `None` to
/// denoise it as it is: its bounding-box diagonal lies in the safe range,
/// or the robust radius below does, or it is a single point.
///
/// `k` brings the robust radius (the 99th percentile over vertices of the
/// largest coordinate difference to the per-coordinate median; no squares,
/// so it neither underflows nor overflows) to `[1, 2)`, or the diagonal
/// where that radius is 0: a stray vertex at 1e300 must not push the rest
/// of a unit-sized mesh down to 1e-300, where its normals underflow. `k` is
/// capped so that no coordinate exceeds `2^1000`.
///
/// # Errors
/// [`DenoiseError::ExtentOverflow`] when the bounding-box diagonal is
/// infinite (coordinates of both signs near ±1.8e308): no power of two
/// brings it into range.
pub(crate) fn working_exponent(mesh: &Mesh) -> Result<Option<i32>, DenoiseError> {
    let largest = || {
        mesh.positions
            .iter()
            .flatten()
            .fold(0.0f64, |m, c| m.max(c.abs()))
    };
    let diagonal = bounding_box_diagonal(mesh);
    if diagonal.is_infinite() {
        return Err(DenoiseError::ExtentOverflow { largest: largest() });
    }
    let Some(k_box) = normalising_exponent(diagonal) else {
        return Ok(None);
    };
    let radius = robust_radius(mesh);
    let k = if radius > 0.0 {
        if (SAFE_DIAGONAL_MIN..=SAFE_DIAGONAL_MAX).contains(&radius) {
            return Ok(None);
        }
        -exponent(radius)
    } else {
        k_box
    };
    let k = k.min(MAX_SCALED_EXPONENT - exponent(largest()));
    Ok((k != 0).then_some(k))
}

/// The [`ROBUST_QUANTILE`] of `max_k |x_k − m_k|` over the vertices, `m`
/// the per-coordinate median (nearest rank).
fn robust_radius(mesh: &Mesh) -> f64 {
    let n = mesh.num_vertices();
    let rank = |q: f64| ((q * (n - 1) as f64).floor() as usize).min(n - 1);
    let mut values: Vec<f64> = Vec::with_capacity(n);
    let mut centre = [0.0; 3];
    for (k, c) in centre.iter_mut().enumerate() {
        values.clear();
        values.extend(mesh.positions.iter().map(|p| p[k]));
        *c = *values.select_nth_unstable_by(rank(0.5), f64::total_cmp).1;
    }
    values.clear();
    values.extend(
        mesh.positions
            .iter()
            .map(|p| (0..3).fold(0.0f64, |m, k| m.max((p[k] - centre[k]).abs()))),
    );
    *values
        .select_nth_unstable_by(rank(ROBUST_QUANTILE), f64::total_cmp)
        .1
}
