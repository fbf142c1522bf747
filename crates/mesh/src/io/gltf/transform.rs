//! Node transforms of glTF 2.0 (§3.5.3 "Transformations"): a node's local
//! transform is its `matrix` (16 numbers, column-major) or `T · R · S` from
//! `translation`, `rotation` (unit quaternion `[x, y, z, w]`) and `scale`;
//! a node's world transform is its parent's world transform times its local
//! one, down the node tree from the scene's roots.

use crate::vec3::{self, Vec3};

/// An affine map `p ↦ m · p + t` (`m` row-major: `m[row][column]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Affine {
    /// the linear part
    pub m: [[f64; 3]; 3],
    /// the translation
    pub t: Vec3,
}

impl Affine {
    /// The identity map.
    pub(crate) const IDENTITY: Affine = Affine {
        m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    /// The map of a column-major 4 × 4 `matrix`; `Err` for a last row other
    /// than `0 0 0 1` (a projection, which no node may have).
    pub(crate) fn from_column_major(a: &[f64; 16]) -> Result<Affine, String> {
        if a[3] != 0.0 || a[7] != 0.0 || a[11] != 0.0 || a[15] != 1.0 {
            return Err(format!(
                "matrix has last row {} {} {} {}, not 0 0 0 1",
                a[3], a[7], a[11], a[15]
            ));
        }
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = a[4 * c + r];
            }
        }
        Ok(Affine {
            m,
            t: [a[12], a[13], a[14]],
        })
    }

    /// `T · R · S`: `rotation` is the quaternion `[x, y, z, w]`, normalised
    /// here (exporters write it rounded).
    pub(crate) fn from_trs(translation: Vec3, rotation: [f64; 4], scale: Vec3) -> Affine {
        let [x, y, z, w] = rotation;
        let n = (x * x + y * y + z * z + w * w).sqrt();
        let (x, y, z, w) = if n > 0.0 {
            (x / n, y / n, z / n, w / n)
        } else {
            (0.0, 0.0, 0.0, 1.0)
        };
        let r = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - z * w),
                2.0 * (x * z + y * w),
            ],
            [
                2.0 * (x * y + z * w),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - x * w),
            ],
            [
                2.0 * (x * z - y * w),
                2.0 * (y * z + x * w),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        let mut m = r;
        for row in &mut m {
            for (c, v) in row.iter_mut().enumerate() {
                *v *= scale[c];
            }
        }
        Affine { m, t: translation }
    }

    /// `self ∘ inner`: first `inner`, then `self` (parent · child).
    pub(crate) fn then_inner(&self, inner: &Affine) -> Affine {
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = (0..3).map(|k| self.m[r][k] * inner.m[k][c]).sum();
            }
        }
        Affine {
            m,
            t: vec3::add(self.apply_linear(inner.t), self.t),
        }
    }

    /// `m · v` (a direction: no translation).
    pub(crate) fn apply_linear(&self, v: Vec3) -> Vec3 {
        [
            vec3::dot(self.m[0], v),
            vec3::dot(self.m[1], v),
            vec3::dot(self.m[2], v),
        ]
    }

    /// `m · p + t`.
    pub(crate) fn apply(&self, p: Vec3) -> Vec3 {
        vec3::add(self.apply_linear(p), self.t)
    }

    /// The determinant of the linear part: negative for a mirroring
    /// transform (which turns the triangles' winding over).
    pub(crate) fn determinant(&self) -> f64 {
        let m = &self.m;
        vec3::dot(m[0], vec3::cross(m[1], m[2]))
    }

    /// The inverse map; `None` when the linear part is singular (a zero
    /// scale) or not finite.
    pub(crate) fn inverse(&self) -> Option<Affine> {
        let det = self.determinant();
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let m = &self.m;
        // the inverse is the transposed cofactor matrix over the determinant
        let cols = [
            vec3::cross(m[1], m[2]),
            vec3::cross(m[2], m[0]),
            vec3::cross(m[0], m[1]),
        ];
        let mut inv = [[0.0; 3]; 3];
        for (r, row) in inv.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = cols[c][r] / det;
            }
        }
        let linear = Affine {
            m: inv,
            t: [0.0; 3],
        };
        let t = vec3::scale(linear.apply_linear(self.t), -1.0);
        let out = Affine { m: inv, t };
        out.m
            .iter()
            .flatten()
            .chain(&out.t)
            .all(|x| x.is_finite())
            .then_some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    #[test]
    fn trs_rotates_scales_and_translates_in_that_order() {
        // a quarter turn about z: x ↦ y
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let a = Affine::from_trs([1.0, 2.0, 3.0], [0.0, 0.0, h, h], [2.0, 3.0, 4.0]);
        // S: (1, 0, 0) ↦ (2, 0, 0); R: ↦ (0, 2, 0); T: ↦ (1, 4, 3)
        assert!(close(a.apply([1.0, 0.0, 0.0]), [1.0, 4.0, 3.0]));
        assert!(close(a.apply([0.0, 1.0, 0.0]), [-2.0, 2.0, 3.0]));
        assert!((a.determinant() - 24.0).abs() < 1e-12);
    }

    #[test]
    fn matrix_is_column_major_and_inverse_undoes_it() {
        let a = Affine::from_column_major(&[
            2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 5.0, 6.0, 7.0, 1.0,
        ])
        .unwrap();
        assert!(close(a.apply([1.0, 1.0, 1.0]), [7.0, 5.0, 8.0]));
        let inv = a.inverse().unwrap();
        for p in [[1.0, 2.0, 3.0], [-4.0, 0.5, 9.0]] {
            assert!(close(inv.apply(a.apply(p)), p));
        }
        let composed = a.then_inner(&inv);
        assert!(close(composed.apply([3.0, -2.0, 1.0]), [3.0, -2.0, 1.0]));
        let mut projective = [0.0; 16];
        projective[15] = 2.0;
        assert!(Affine::from_column_major(&projective).is_err());
        let flat = Affine::from_trs([0.0; 3], [0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 1.0]);
        assert!(flat.inverse().is_none());
    }
}
