//! The change of unit around every method (`Denoiser::run`): a mesh whose
//! robust radius lies outside `normalnet_mesh::scale`'s safe range
//! (`2^-40 ..= 2^40`) is denoised scaled by an exact power of two `2^k`
//! and the result scaled back by `2^-k`; a mesh inside it is denoised as it
//! is. Every method parameter is relative (multiples of `d_s`, `l_e`, `l_e²`,
//! angles, cosines, counts), so none changes with the unit.

use normalnet_mesh::Mesh;
use normalnet_mesh::scale::{bounding_box_diagonal, largest_coordinate};

use crate::DenoiseError;

/// The largest coordinate exponent a scaled mesh may reach (`2^1000`): room
/// for the sums of a pass without overflow.
const MAX_SCALED_EXPONENT: i32 = 1000;

/// The `k` that `mesh` is denoised at (positions times `2^k`), `None` to
/// denoise it as it is: `normalnet_mesh::scale::working_exponent`, which
/// brings the mesh's robust radius (ignoring 1 % of the vertices) to
/// `[1, 2)` when that radius lies outside the safe range, whatever the
/// bounding box says. A stray vertex at 1e300 must not push the rest of a
/// unit-sized mesh down to 1e-300, where its normals underflow, and one
/// near 1 must not keep a body of extent 1e-80 at its scale (issue 39).
/// `k` is capped so that no coordinate exceeds `2^1000`.
///
/// # Errors
/// [`DenoiseError::ExtentOverflow`] when the bounding-box diagonal is
/// infinite (coordinates of both signs near ±1.8e308): no power of two
/// brings it into range.
pub(crate) fn working_exponent(mesh: &Mesh) -> Result<Option<i32>, DenoiseError> {
    if bounding_box_diagonal(mesh).is_infinite() {
        return Err(DenoiseError::ExtentOverflow {
            largest: largest_coordinate(&mesh.positions),
        });
    }
    Ok(normalnet_mesh::scale::working_exponent(
        mesh,
        MAX_SCALED_EXPONENT,
    ))
}
