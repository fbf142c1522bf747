//! Small 3-vector helpers on `[f64; 3]`: the only linear algebra the geometry
//! crates need in their hot loops.

/// A 3-vector of f64 (positions, normals, centres).
pub type Vec3 = [f64; 3];

/// `a + b`
#[inline]
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`
#[inline]
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s · a`
#[inline]
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a · b`
#[inline]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`
#[inline]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|²`
#[inline]
pub fn norm2(a: Vec3) -> f64 {
    dot(a, a)
}

/// `|a|`
#[inline]
pub fn norm(a: Vec3) -> f64 {
    norm2(a).sqrt()
}

/// `|a − b|²`
#[inline]
pub fn dist2(a: Vec3, b: Vec3) -> f64 {
    norm2(sub(a, b))
}

/// `a / |a|`, or the zero vector when `|a|` is zero, subnormal or not finite.
/// Never returns NaN.
#[inline]
pub fn normalize_or_zero(a: Vec3) -> Vec3 {
    let n = norm(a);
    if n > f64::MIN_POSITIVE && n.is_finite() {
        scale(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}

/// Angle between two vectors in radians, in `[0, π]`; `π/2` when either is zero
/// (a degenerate face counts as 90°, SPEC §3).
#[inline]
pub fn angle(a: Vec3, b: Vec3) -> f64 {
    let a = normalize_or_zero(a);
    let b = normalize_or_zero(b);
    dot(a, b).clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_zero_and_nan_give_zero() {
        assert_eq!(normalize_or_zero([0.0; 3]), [0.0; 3]);
        assert_eq!(normalize_or_zero([f64::NAN, 0.0, 0.0]), [0.0; 3]);
        assert_eq!(normalize_or_zero([f64::INFINITY, 0.0, 0.0]), [0.0; 3]);
        let n = normalize_or_zero([3.0, 0.0, 4.0]);
        assert!((norm(n) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn angle_with_zero_is_right_angle() {
        assert!((angle([0.0; 3], [1.0, 0.0, 0.0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!(angle([1.0, 0.0, 0.0], [2.0, 0.0, 0.0]).abs() < 1e-7);
    }
}
