//! `Frame`: the local coordinate frame of one voxelized face (paper §3.3
//! Eq. 8, SPEC §5 step 2): the minimal rotation `W_r` taking the 2-ring mean
//! normal `n̄` to `N_t = (0, 1, 0)` (Rodrigues' formula), followed by an
//! optional yaw (rotation about y, the training augmentation), and the
//! translation of the face centre `c_f` to the origin.

use normalnet_mesh::vec3::{self, Vec3};

/// A row-major 3×3 matrix.
pub type Mat3 = [[f64; 3]; 3];

/// The 3×3 identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Local frame of a voxelized face: `local = rotation · (world − centre)`.
///
/// `rotation = Y(yaw) · W_r`, with `W_r` the minimal rotation taking the
/// face's 2-ring mean normal to `(0, 1, 0)` and `Y(θ)` the rotation by `θ`
/// about the y axis (`[[cos θ, 0, sin θ], [0, 1, 0], [−sin θ, 0, cos θ]]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// `Y(yaw) · W_r`, row-major.
    pub rotation: Mat3,
    /// `c_f`, the face centre (world coordinates), mapped to the origin.
    pub centre: Vec3,
    /// The yaw angle θ in radians (0 without augmentation).
    pub yaw: f64,
}

impl Frame {
    /// The frame of a face with 2-ring mean normal `mean_normal`, centre
    /// `centre`, and yaw angle `yaw` (radians). A zero mean normal gives
    /// `W_r = I`.
    pub fn new(mean_normal: Vec3, centre: Vec3, yaw: f64) -> Frame {
        Frame {
            rotation: mat_mul(&yaw_rotation(yaw), &rotation_to_y(mean_normal)),
            centre,
            yaw,
        }
    }

    /// Rotates a direction (e.g. a normal) from world into local
    /// coordinates: `rotation · v`.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        mat_vec(&self.rotation, v)
    }

    /// Rotates a local direction back into world coordinates:
    /// `rotationᵀ · v` (how network outputs return to the mesh).
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        mat_t_vec(&self.rotation, v)
    }

    /// Maps a world point into local coordinates: `rotation · (p − centre)`.
    #[inline]
    pub fn point_to_local(&self, p: Vec3) -> Vec3 {
        mat_vec(&self.rotation, vec3::sub(p, self.centre))
    }

    /// Maps a local point back into world coordinates.
    #[inline]
    pub fn point_to_world(&self, p: Vec3) -> Vec3 {
        vec3::add(mat_t_vec(&self.rotation, p), self.centre)
    }
}

/// `W_r`: the minimal rotation taking the direction `n` to `(0, 1, 0)`
/// (Rodrigues: `R = I + [v]× + [v]×² / (1 + c)` with `v = n × y`,
/// `c = n · y`). When `n` is (numerically) antiparallel to y, the rotation by
/// π about the x axis; when `n` is zero, the identity.
pub fn rotation_to_y(n: Vec3) -> Mat3 {
    let n = vec3::normalize_or_zero(n);
    if n == [0.0; 3] {
        return IDENTITY;
    }
    // v = n × (0,1,0) = (−n_z, 0, n_x); c = n_y.
    let c = n[1];
    if 1.0 + c < 1e-12 {
        return [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];
    }
    let v = [-n[2], 0.0, n[0]];
    // k = 1 / (1 + c). Near antiparallel, 1 + c cancels (n_y = −0.94 and
    // n_z = 0.008 lost 12 digits of orthogonality); there |v|² = 1 − c² gives
    // k = (1 − c) / |v|², exact to rounding for any c < 0.
    let k = if c >= 0.0 {
        1.0 / (1.0 + c)
    } else {
        (1.0 - c) / vec3::dot(v, v)
    };
    let vx: Mat3 = [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]];
    let vx2 = mat_mul(&vx, &vx);
    let mut r = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] += vx[i][j] + vx2[i][j] * k;
        }
    }
    r
}

/// `Y(θ)`: rotation by `θ` radians about the y axis.
pub fn yaw_rotation(theta: f64) -> Mat3 {
    if theta == 0.0 {
        return IDENTITY;
    }
    let (s, c) = theta.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

/// `a · b`
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    r
}

/// `m · v`
#[inline]
pub fn mat_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [vec3::dot(m[0], v), vec3::dot(m[1], v), vec3::dot(m[2], v)]
}

/// `mᵀ · v`
#[inline]
pub fn mat_t_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// `mᵀ`
pub fn transpose(m: &Mat3) -> Mat3 {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn assert_rotation(r: &Mat3) {
        let p = mat_mul(r, &transpose(r));
        for (i, row) in p.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((x - e).abs() < 1e-12, "{r:?}");
            }
        }
        let det = vec3::dot(r[0], vec3::cross(r[1], r[2]));
        assert!((det - 1.0).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn w_r_maps_mean_normal_to_y(x in -1.0..1.0f64, y in -1.0..1.0f64, z in -1.0..1.0f64) {
            prop_assume!(vec3::norm([x, y, z]) > 1e-3);
            let r = rotation_to_y([x, y, z]);
            assert_rotation(&r);
            let m = mat_vec(&r, vec3::normalize_or_zero([x, y, z]));
            prop_assert!(vec3::dist2(m, [0.0, 1.0, 0.0]) < 1e-20);
        }
    }

    #[test]
    fn antiparallel_zero_and_parallel() {
        // The third: 1 + c = 3.4e-5, where 1 / (1 + c) gave a matrix 1e-12
        // off orthogonal (a proptest case of CI).
        for n in [
            [0.0, -1.0, 0.0],
            [1e-14, -1.0, 0.0],
            [0.0, -3.0, 1e-9],
            [0.0, -0.9422317975800072, 0.007803621918479193],
            [1e-5, -1.0, -2e-6],
        ] {
            let r = rotation_to_y(n);
            assert_rotation(&r);
            let m = mat_vec(&r, vec3::normalize_or_zero(n));
            assert!(vec3::dist2(m, [0.0, 1.0, 0.0]) < 1e-16, "{m:?}");
        }
        assert_eq!(rotation_to_y([0.0; 3]), IDENTITY);
        assert_eq!(rotation_to_y([0.0, 2.0, 0.0]), IDENTITY);
    }

    #[test]
    fn frame_round_trip_and_yaw_keeps_y() {
        let f = Frame::new([0.3, -0.2, 0.9], [1.0, 2.0, 3.0], 0.7);
        assert_rotation(&f.rotation);
        let n = f.to_local(vec3::normalize_or_zero([0.3, -0.2, 0.9]));
        assert!(vec3::dist2(n, [0.0, 1.0, 0.0]) < 1e-20);
        let p = [0.5, -4.0, 2.0];
        let q = f.point_to_world(f.point_to_local(p));
        assert!(vec3::dist2(p, q) < 1e-24);
        assert!(vec3::norm(f.point_to_local([1.0, 2.0, 3.0])) < 1e-15);
        let v = [0.1, 0.2, 0.3];
        assert!(vec3::dist2(f.to_world(f.to_local(v)), v) < 1e-28);
    }
}
