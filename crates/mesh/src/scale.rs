//! Extreme coordinate scales: exact power-of-two changes of unit.
//!
//! Normal filtering squares lengths more than once: a face normal is the
//! cross product of two edges (~L²) normalised through its squared norm
//! (~L⁴), an area is ~L², the L0 system holds products of those. A valid
//! mesh whose coordinates are all ~1e-80 (or ~1e80) therefore underflows
//! (overflows): every face reads as degenerate, areas turn NaN, Cholesky
//! factorisations fail. The repair is a change of unit by a power of two:
//! multiplying a coordinate by `2^k` only changes its exponent, so it is
//! exact (unless the product is subnormal or overflows) and multiplying by
//! `2^-k` gives the same bits back.
//!
//! The safe range [`SAFE_DIAGONAL_MIN`] ..= [`SAFE_DIAGONAL_MAX`]
//! (`2^-40 ≈ 9.1e-13` to `2^40 ≈ 1.1e12`) of the bounding-box diagonal `D`:
//! edges resolvable in f64 are at least `D·2^-52`, so inside it every edge
//! length `L` lies in `[2^-92, 2^40]` and even `L⁸` stays a normal f64
//! (`2^-736 .. 2^320`; f64 spans `2^-1022 .. 2^1024`), while every mesh in
//! physical units from micrometres to millions of kilometres is inside and
//! is never rescaled (its results keep their bits).
//!
//! Whether a mesh is rescaled is decided by its *robust radius*
//! ([`robust_radius`]: 99 % of the vertices lie within it of the
//! per-coordinate median), not by its bounding box (issue 39): one stray
//! vertex near 1 beside a body of extent 1e-80 keeps the box in range while
//! every face of the body underflows, and one stray vertex at 1e300 beside
//! a unit-sized body pushes the box out of range although the body needs no
//! change ([`working_exponent`]).

use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};

/// The smallest bounding-box diagonal computed without rescaling: `2^-40`.
pub const SAFE_DIAGONAL_MIN: f64 = 9.094_947_017_729_282e-13;

/// The largest bounding-box diagonal computed without rescaling: `2^40`.
pub const SAFE_DIAGONAL_MAX: f64 = 1_099_511_627_776.0;

/// `⌊log2 |x|⌋` of a finite non-zero `x`, subnormals included (read from
/// the bits, exact).
///
/// # Panics
/// If `x` is zero, infinite or NaN.
pub fn exponent(x: f64) -> i32 {
    assert!(x != 0.0 && x.is_finite(), "exponent of {x}");
    let bits = x.abs().to_bits();
    let biased = (bits >> 52) as i32;
    if biased > 0 {
        biased - 1023
    } else {
        // subnormal: the highest set bit of the mantissa
        -1074 + (63 - bits.leading_zeros() as i32)
    }
}

/// `x · 2^k`, exact unless the result is subnormal or overflows (in steps
/// of at most `2^±1022`, each between `x` and the result, so no step
/// underflows or overflows where the result does not).
pub fn mul_pow2(mut x: f64, mut k: i32) -> f64 {
    while k != 0 {
        let step = k.clamp(-1022, 1023);
        x *= f64::from_bits(((step + 1023) as u64) << 52);
        k -= step;
    }
    x
}

/// Every position times `2^k` ([`mul_pow2`]), one `[f64; 3]` per vertex.
pub fn pow2_scaled(positions: &[Vec3], k: i32) -> Vec<Vec3> {
    positions
        .iter()
        .map(|p| p.map(|c| mul_pow2(c, k)))
        .collect()
}

/// Length of the diagonal of the box `lo ..= hi`, without intermediate
/// overflow or underflow (the plain `|hi − lo|` where its squares are safe,
/// else computed at the exponent of the largest extent, as `hypot`).
/// Infinite only when an extent `hi − lo` itself overflows; 0 for a point.
pub fn diagonal_length(lo: Vec3, hi: Vec3) -> f64 {
    let d = vec3::sub(hi, lo);
    let plain = vec3::norm(d);
    if plain.is_finite() && plain >= SAFE_DIAGONAL_MIN * SAFE_DIAGONAL_MIN {
        return plain;
    }
    let m = d.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    let k = exponent(m);
    mul_pow2(vec3::norm(d.map(|c| mul_pow2(c, -k))), k)
}

/// The bounding-box diagonal of `mesh` ([`diagonal_length`] of
/// [`Mesh::bounding_box`]).
pub fn bounding_box_diagonal(mesh: &Mesh) -> f64 {
    let (lo, hi) = mesh.bounding_box();
    diagonal_length(lo, hi)
}

/// The share of vertices whose extent sets the unit ([`robust_radius`]):
/// the same 99th percentile as [`crate::outliers`] (up to 1 % of the
/// vertices may be anywhere; at least one vertex of any mesh of two or more).
pub const ROBUST_QUANTILE: f64 = 0.99;

/// The [`ROBUST_QUANTILE`] over the vertices of `max_k |x_k − m_k|`, `m` the
/// per-coordinate median (nearest rank): the radius that all but 1 % of the
/// vertices lie within. No squares, so it neither underflows nor overflows;
/// 0 for no vertex, or when 99 % of them coincide.
pub fn robust_radius(positions: &[Vec3]) -> f64 {
    let n = positions.len();
    if n == 0 {
        return 0.0;
    }
    let rank = |q: f64| ((q * (n - 1) as f64).floor() as usize).min(n - 1);
    let mut values: Vec<f64> = Vec::with_capacity(n);
    let mut centre = [0.0; 3];
    for (k, c) in centre.iter_mut().enumerate() {
        values.clear();
        values.extend(positions.iter().map(|p| p[k]));
        *c = *values.select_nth_unstable_by(rank(0.5), f64::total_cmp).1;
    }
    values.clear();
    values.extend(
        positions
            .iter()
            .map(|p| (0..3).fold(0.0f64, |m, k| m.max((p[k] - centre[k]).abs()))),
    );
    *values
        .select_nth_unstable_by(rank(ROBUST_QUANTILE), f64::total_cmp)
        .1
}

/// The largest absolute coordinate of `positions` (0 for none).
pub fn largest_coordinate(positions: &[Vec3]) -> f64 {
    positions
        .iter()
        .flatten()
        .fold(0.0f64, |m, c| m.max(c.abs()))
}

/// The `k` that a computation on `mesh` runs at (its positions times
/// `2^k`), `None` to run it on `mesh` as it is.
///
/// - The [`robust_radius`] `r` decides: `None` when it lies in the safe
///   range, else the `k` with `r · 2^k` in `[1, 2)`, whatever the bounding
///   box says (a stray vertex neither keeps a tiny body at its scale nor
///   pushes a unit-sized one away from it).
/// - Where `r` is 0 (99 % of the vertices at one point) the bounding-box
///   diagonal decides, as [`normalising_exponent`].
/// - `k` is capped so that no coordinate exceeds `2^max_exponent` (room for
///   the caller's products: the metrics need `L⁴` of every face, a
///   denoising pass only sums).
///
/// A mesh whose robust radius lies in the safe range always gets `None`:
/// every mesh in physical units keeps its bits.
pub fn working_exponent(mesh: &Mesh, max_exponent: i32) -> Option<i32> {
    let radius = robust_radius(&mesh.positions);
    let k = if radius > 0.0 && radius.is_finite() {
        if (SAFE_DIAGONAL_MIN..=SAFE_DIAGONAL_MAX).contains(&radius) {
            return None;
        }
        -exponent(radius)
    } else {
        normalising_exponent(bounding_box_diagonal(mesh))?
    };
    let k = cap_exponent(k, largest_coordinate(&mesh.positions), max_exponent);
    (k != 0).then_some(k)
}

/// `k` lowered, where it scales up, so that `largest · 2^k` stays below
/// `2^(max_exponent + 1)`, but never below 0: a cap never scales down.
pub fn cap_exponent(k: i32, largest: f64, max_exponent: i32) -> i32 {
    if k <= 0 || !(largest > 0.0 && largest.is_finite()) {
        return k;
    }
    k.min((max_exponent - exponent(largest)).max(0))
}

/// The `k` with `diagonal · 2^k` in `[1, 2)` when `diagonal` lies outside
/// the safe range; `None` inside it, for 0 (a single point: nothing to
/// scale) and for a non-finite diagonal (no power of two helps).
pub fn normalising_exponent(diagonal: f64) -> Option<i32> {
    let outside = !(SAFE_DIAGONAL_MIN..=SAFE_DIAGONAL_MAX).contains(&diagonal);
    (outside && diagonal > 0.0 && diagonal.is_finite()).then(|| -exponent(diagonal))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_safe_range_is_two_to_the_plus_minus_40() {
        assert_eq!(SAFE_DIAGONAL_MIN, 2f64.powi(-40));
        assert_eq!(SAFE_DIAGONAL_MAX, 2f64.powi(40));
        assert_eq!(normalising_exponent(SAFE_DIAGONAL_MIN), None);
        assert_eq!(normalising_exponent(SAFE_DIAGONAL_MAX), None);
        assert_eq!(normalising_exponent(1.0), None);
        assert_eq!(normalising_exponent(0.0), None);
        assert_eq!(normalising_exponent(f64::INFINITY), None);
        assert_eq!(normalising_exponent(3e-80), Some(265));
        assert_eq!(normalising_exponent(3e80), Some(-267));
        for d in [1e-300, 5e-324, 1e-13, 1e13, 1.7e308] {
            let k = normalising_exponent(d).unwrap();
            let s = mul_pow2(d, k);
            assert!((1.0..2.0).contains(&s), "{d:e} -> {s}");
        }
    }

    #[test]
    fn exponents_and_powers_of_two_are_exact() {
        assert_eq!(exponent(1.0), 0);
        assert_eq!(exponent(-3.0), 1);
        assert_eq!(exponent(0.75), -1);
        assert_eq!(exponent(f64::MIN_POSITIVE), -1022);
        assert_eq!(exponent(5e-324), -1074);
        assert_eq!(exponent(f64::MAX), 1023);
        let x = 0.1234567890123;
        for k in [-1500, -1000, -300, -1, 0, 1, 300, 1000] {
            let y = mul_pow2(mul_pow2(x, k), -k);
            if k >= -1000 {
                assert_eq!(y.to_bits(), x.to_bits(), "{k}");
            }
        }
        assert_eq!(mul_pow2(1.0, -1074), 5e-324);
        assert_eq!(mul_pow2(5e-324, 2097), 2f64.powi(1023));
        assert_eq!(mul_pow2(1.5, 1024), f64::INFINITY);
    }

    /// A cube's corners times `2·s` (robust radius `2·s`), 200 vertices, plus
    /// `strays` vertices at `[far, 0, 0]`.
    fn body_with_strays(s: f64, far: f64, strays: usize) -> Mesh {
        let mut positions: Vec<Vec3> = (0..200)
            .map(|i| [(i % 2) as f64, (i / 2 % 2) as f64, (i / 4 % 2) as f64].map(|c| c * 2.0 * s))
            .collect();
        positions.extend(std::iter::repeat_n([far, 0.0, 0.0], strays));
        Mesh::new(positions, vec![[0, 1, 2]]).unwrap()
    }

    /// Issue 39: one stray vertex near 1 kept the box of a body at 1e-80 in
    /// range, and the body was not rescaled.
    #[test]
    fn issue_39_the_robust_radius_sets_the_unit_not_the_box() {
        for (s, far) in [(1e-80, 1.0), (1e-80, 1e-80), (1e80, 1.0), (1e-300, 1e-10)] {
            let mesh = body_with_strays(s, far, 1);
            let k = working_exponent(&mesh, 1000).unwrap();
            let r = mul_pow2(robust_radius(&mesh.positions), k);
            assert!((1.0..2.0).contains(&r), "{s:e}, {far:e}: {r}");
        }
        // a unit-sized body keeps its unit, a stray vertex at 1e300 or not
        for far in [1.0, 1e300, -1e-300] {
            assert_eq!(working_exponent(&body_with_strays(1.0, far, 1), 1000), None);
        }
        // more than 1 % of the vertices far out: they are part of the body
        let spread = body_with_strays(1e-80, 1.0, 10);
        assert_eq!(working_exponent(&spread, 1000), None);
        // the cap: no coordinate beyond 2^max_exponent
        let capped = body_with_strays(1e-80, 1.0, 1);
        let k = working_exponent(&capped, 240).unwrap();
        assert_eq!(k, 240);
        // ... which never scales a tiny body further down
        assert_eq!(
            working_exponent(&body_with_strays(1e-80, 1e300, 1), 240),
            None
        );
        assert_eq!(cap_exponent(-50, 1e300, 240), -50);
        // all vertices at one point: the box decides (a point: nothing)
        assert_eq!(working_exponent(&body_with_strays(0.0, 0.0, 1), 1000), None);
        let mut two = body_with_strays(0.0, 0.0, 0);
        two.positions[0] = [1e-200, 0.0, 0.0];
        let k = working_exponent(&two, 1000).unwrap();
        assert_eq!(mul_pow2(1e-200, k).floor(), 1.0);
        assert_eq!(robust_radius(&[]), 0.0);
    }

    #[test]
    fn the_diagonal_neither_overflows_nor_underflows() {
        let lo = [0.0; 3];
        assert_eq!(diagonal_length(lo, [3.0, 4.0, 0.0]), 5.0);
        for s in [1e200, 1e-200] {
            let d = diagonal_length(lo, [3.0 * s, 4.0 * s, 0.0]);
            assert!((d / (5.0 * s) - 1.0).abs() < 1e-15, "{d:e}");
        }
        assert_eq!(diagonal_length(lo, lo), 0.0);
        assert_eq!(
            diagonal_length([-f64::MAX, 0.0, 0.0], [f64::MAX, 0.0, 0.0]),
            f64::INFINITY
        );
    }
}
