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
