//! The row stems on AVX2 (no AVX-512): 16 output channels are two vectors
//! of 8.
//!
//! [`run`], f32: each block of [`CHUNK`] output cubes runs twice, once per
//! half of the output channels, with its 7 accumulators and the input
//! broadcast in registers and the weights read by the multiply-adds. Every
//! output lane gets the same fused multiply-adds in the same order as in
//! the AVX-512 [`super::run`] (bias first, then per reaching row the inputs
//! in W order, channels, taps), so the outputs are equal bit for bit.
//!
//! [`run_int8`], int8: the rows' bytes widened to i16 ([`Rows::widen`]),
//! the weights as i16 pairs, `vpmaddwd` summing two products per i32 lane.
//! A byte (0 ..= 255) times a weight (−127 ..= 127), and a pair of them
//! (≤ 64,770 in magnitude), are exact in i32, as are the sums over rows,
//! so the sums are those of VNNI's `vpdpbusd` and the steps after them (sum
//! − offset to f32, one fused multiply-add by scale and bias, the floor)
//! are the same operations: the outputs of [`super::run_int8`], bit for
//! bit. Per cube and row: 8 input pairs × 2 vectors = 16 `vpmaddwd` (VNNI:
//! 4 `vpdpbusd`), in tiles of up to 6 cubes (12 i32 chains). With AVX-VNNI
//! (`Isa::AvxVnni`) the same tiles read the bytes and the VNNI weights:
//! 4 groups × 2 vectors = 8 256-bit `vpdpbusd` per cube and row. With
//! [`Int8Range::Narrow`] (bytes 1 ..= 127, weights within ±63) plain AVX2
//! reads the bytes too: per pair of groups, two `vpmaddubsw` added in i16
//! (≤ 4 · 127 · 63 = 32,004: exact) and one `vpmaddwd` by ones, 12
//! multiply instructions per cube and row instead of 16.

use super::{
    CHUNK, CIN, CO, CubeMask, FoldedConv, Int8Stem, K, Rows, SLACK, WINDOW, background,
    for_each_span, serves,
};
use crate::conv_int8::Int8Range;
use crate::conv_int8_avx2::narrow_mac;
use std::arch::x86_64::*;

/// Input pairs of a W window (15 bytes and a zero).
const PAIRS: usize = WINDOW / 2;
/// Most output cubes per int8 tile: 12 i32 chains, two weight vectors and
/// the input broadcast in the 16 registers.
const MAX_TILE: usize = 6;

/// The ReLU's floor as a vector (0, or −∞ without it).
#[target_feature(enable = "avx2")]
fn floor_vector(relu: bool) -> __m256 {
    match relu {
        true => _mm256_setzero_ps(),
        false => _mm256_set1_ps(f32::NEG_INFINITY),
    }
}

/// [`super::run`] on AVX2: `out = [relu](conv(grid))`, `out` `[m, m, m,
/// 16]` channels-last, from the rows of an `n³` grid built by
/// [`Rows::build`] with f32 values and this conv's padding; with `near`,
/// also the output cubes whose window holds an occupied cube.
///
/// # Safety
/// The CPU must have AVX2 and FMA, and `serves(c, n)` must hold.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn run(
    c: &FoldedConv,
    rows: &Rows,
    n: usize,
    out: &mut [f32],
    relu: bool,
    near: Option<&mut CubeMask>,
) {
    let (p, m) = (c.pad, c.output_side(n));
    assert!(serves(c, n));
    assert!(rows.values.len() == rows.reaches.len() * rows.len * CIN);
    let floor = floor_vector(relu);
    let block = |c0: usize,
                 chunk: u64,
                 [lo, hi]: [usize; 2],
                 reach: &[(usize, usize, u64)],
                 dst: &mut [f32]| {
        for half in 0..CO / 8 {
            // SAFETY: 16 biases (`serves`: 16 output channels).
            let bias = unsafe { _mm256_loadu_ps(c.b.as_ptr().add(8 * half)) };
            let mut acc = [bias; CHUNK];
            // rows with no occupied cube near this block add only zeros
            for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & chunk != 0) {
                // SAFETY: `(tap_row + 1)·K·CIN·CO ≤ c.w.len()` (taps of one
                // (kd, kh)), weight reads end 8 floats after `8·half` within
                // a (kw, ci)'s 16; `(x0 + c0 + CHUNK + K − 1)·CIN ≤
                // rows.values.len()` (`c0 < m`, rows of `len` cubes).
                unsafe {
                    let w = c.w.as_ptr().add(tap_row * K * CIN * CO + 8 * half);
                    let x = rows.values.as_ptr().add((x0 + c0) * CIN);
                    // output cube c0 + o reads padded inputs c0 + o + kw;
                    // input j spelled out, as in the AVX-512 stem
                    macro_rules! input {
                        ($($j:literal)*) => {$(
                            for ci in 0..CIN {
                                let v = _mm256_set1_ps(*x.add($j * CIN + ci));
                                for kw in 0..K {
                                    if $j >= kw && $j - kw < CHUNK {
                                        let wk = _mm256_loadu_ps(w.add((kw * CIN + ci) * CO));
                                        acc[$j - kw] = _mm256_fmadd_ps(v, wk, acc[$j - kw]);
                                    }
                                }
                            }
                        )*};
                    }
                    const _: () = assert!(CHUNK + K - 1 == 11);
                    input!(0 1 2 3 4 5 6 7 8 9 10);
                }
            }
            for (o, a) in acc.iter().enumerate() {
                if (lo..hi).contains(&(c0 + o)) {
                    let at = (c0 + o) * CO + 8 * half;
                    let cube = &mut dst[at..at + 8];
                    // SAFETY: `cube` holds 8 floats.
                    unsafe { _mm256_storeu_ps(cube.as_mut_ptr(), _mm256_max_ps(*a, floor)) };
                }
            }
        }
    };
    // blocks of CHUNK cubes aligned to CHUNK (the rows hold whole blocks),
    // their cubes in lo..hi stored
    let span = |lo: usize, hi: usize, reach: &[(usize, usize, u64)], dst: &mut [f32]| {
        for c0 in (lo / CHUNK * CHUNK..hi).step_by(CHUNK) {
            block(c0, ((1u64 << CHUNK) - 1) << c0, [lo, hi], reach, dst);
        }
    };
    for_each_span(rows, [n, p, m], out, background(&c.b, relu), near, span);
}

/// [`super::run_int8`] on AVX2, on rows quantized by [`Rows::quantize`]
/// with scale `input_scale` and widened by [`Rows::widen`]; with
/// `avx_vnni`, on the bytes themselves with 256-bit `vpdpbusd`, and for a
/// narrow `q`, on the bytes with `vpmaddubsw` (neither widened: the same
/// sums). Returns the largest value of `out`.
///
/// # Safety
/// The CPU must have AVX2 and FMA (and AVX-VNNI with `avx_vnni`), and
/// `serves(c, n)` must hold for the stem `q` was made from.
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn run_int8(
    q: &Int8Stem,
    p: usize,
    rows: &Rows,
    input_scale: f32,
    n: usize,
    out: &mut [f32],
    relu: bool,
    near: Option<&mut CubeMask>,
    avx_vnni: bool,
) -> f32 {
    let m = crate::conv::output_side(n, K, 1, p);
    assert!(rows.len >= m + K - 1);
    let narrow = !avx_vnni && q.range() == Int8Range::Narrow;
    assert!(
        avx_vnni || narrow || rows.wide.len() == rows.row_bytes() + SLACK,
        "rows not quantized and widened"
    );
    let finish = Finish {
        // SAFETY: 16 output channels: 16 biases and scales.
        scale: std::array::from_fn(|h| unsafe {
            _mm256_mul_ps(
                _mm256_loadu_ps(q.scale.as_ptr().add(8 * h)),
                _mm256_set1_ps(input_scale),
            )
        }),
        // SAFETY: as above.
        bias: std::array::from_fn(|h| unsafe { _mm256_loadu_ps(q.bias.as_ptr().add(8 * h)) }),
        floor: floor_vector(relu),
    };
    // the largest output, for the next layer's quantization
    let mut largest = [_mm256_set1_ps(f32::NEG_INFINITY); 2];
    let span = |lo: usize, hi: usize, reach: &[(usize, usize, u64)], dst: &mut [f32]| {
        let mut c0 = lo;
        while c0 < hi {
            let t = crate::conv_int8::tile_len(hi - c0, MAX_TILE);
            let cubes = &mut dst[c0 * CO..(c0 + t) * CO];
            macro_rules! tile {
                ($($t:literal)*) => {
                    match t {
                        // SAFETY: the caller checked the features; the
                        // tile's reads stay inside `rows.wide` (checked
                        // above: rows of `len ≥ m + K − 1` cubes, SLACK
                        // values after the last).
                        $($t => unsafe {
                            if avx_vnni {
                                stem_tile_vnni::<$t>(q, rows, c0, reach, &finish, cubes, &mut largest)
                            } else if narrow {
                                stem_tile_narrow::<$t>(q, rows, c0, reach, &finish, cubes, &mut largest)
                            } else {
                                stem_tile::<$t>(q, rows, c0, reach, &finish, cubes, &mut largest)
                            }
                        },)*
                        _ => unreachable!("tiles of 1 to MAX_TILE cubes"),
                    }
                };
            }
            tile!(1 2 3 4 5 6);
            c0 += t;
        }
    };
    let background = background(&q.bias, relu);
    let any_background = for_each_span(rows, [n, p, m], out, background, near, span);
    let mut lanes = [0.0f32; 8];
    // SAFETY: 8 writable floats.
    unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), _mm256_max_ps(largest[0], largest[1])) };
    let computed = lanes.into_iter().fold(f32::NEG_INFINITY, f32::max);
    match any_background {
        true => background.into_iter().fold(computed, f32::max),
        false => computed,
    }
}

/// The int8 stem's last steps for a cube, per half of the output channels:
/// its i32 sum (offset removed) to f32 times the scale, plus the bias, then
/// the ReLU's floor.
struct Finish {
    scale: [__m256; 2],
    bias: [__m256; 2],
    floor: __m256,
}

/// The int8 stem's output cubes `c0 .. c0 + T` of one output row into
/// `out` (`T` cubes) from its reaching rows `reach` (those with an occupied
/// cube near the tile), and their maximum into `largest`: per row and input
/// pair, the two weight vectors of its (kd, kh) and for each cube the pair
/// broadcast as one i32 — `2·T` `vpmaddwd`, `2·T` chains in flight.
///
/// # Safety
/// The CPU has AVX2 and FMA; `rows` is quantized and widened, and `c0 + T +
/// K − 1 ≤ rows.len`.
#[target_feature(enable = "avx2,fma")]
unsafe fn stem_tile<const T: usize>(
    q: &Int8Stem,
    rows: &Rows,
    c0: usize,
    reach: &[(usize, usize, u64)],
    finish: &Finish,
    out: &mut [f32],
    largest: &mut [__m256; 2],
) {
    const { assert!(T <= MAX_TILE) };
    debug_assert!(c0 + T + K - 1 <= rows.len && out.len() == T * CO);
    let tile = ((1u64 << T) - 1) << c0;
    let mut acc = [[_mm256_setzero_si256(); 2]; T];
    let mut offset = [_mm256_setzero_si256(); 2];
    // rows with no occupied cube near this tile add only zeros
    for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & tile != 0) {
        // SAFETY: `(tap_row + 1)·PAIRS·CO·2 ≤ q.w16.len()` and `(tap_row +
        // 1)·CO ≤ q.offset.len()` (one (kd, kh)); cube c0 + o's window reads
        // values 3·(x0 + c0 + o) .. + 16 ≤ 3·(x0 + len) + 1, inside
        // `rows.wide` (`c0 + T + K − 1 ≤ len`, SLACK values after the last
        // row).
        unsafe {
            let w = q.w16.as_ptr().add(tap_row * PAIRS * CO * 2);
            add_row_offset(q, tap_row, &mut offset);
            let x = rows.wide.as_ptr().add(CIN * (x0 + c0));
            for g in 0..PAIRS {
                let wg = w.add(g * CO * 2);
                let wv = [
                    _mm256_loadu_si256(wg.cast()),
                    _mm256_loadu_si256(wg.add(16).cast()),
                ];
                for (t, a) in acc.iter_mut().enumerate() {
                    let pair = x.add(CIN * t + 2 * g).cast::<i32>().read_unaligned();
                    let xv = _mm256_set1_epi32(pair);
                    a[0] = _mm256_add_epi32(a[0], _mm256_madd_epi16(xv, wv[0]));
                    a[1] = _mm256_add_epi32(a[1], _mm256_madd_epi16(xv, wv[1]));
                }
            }
        }
    }
    finish_tile(acc, offset, finish, out, largest);
}

/// As [`stem_tile`], on the rows' bytes with AVX-VNNI: per row and group of
/// four window bytes, the two weight vectors of its (kd, kh) in the VNNI
/// layout and for each cube the group broadcast as one i32 — `2·T`
/// `vpdpbusd`, a quarter of [`stem_tile`]'s multiply-adds.
///
/// # Safety
/// The CPU has AVX2, FMA and AVX-VNNI; `rows` is quantized, and `c0 + T +
/// K − 1 ≤ rows.len`.
#[target_feature(enable = "avx2,fma,avxvnni")]
unsafe fn stem_tile_vnni<const T: usize>(
    q: &Int8Stem,
    rows: &Rows,
    c0: usize,
    reach: &[(usize, usize, u64)],
    finish: &Finish,
    out: &mut [f32],
    largest: &mut [__m256; 2],
) {
    const { assert!(T <= MAX_TILE) };
    debug_assert!(c0 + T + K - 1 <= rows.len && out.len() == T * CO);
    let tile = ((1u64 << T) - 1) << c0;
    let mut acc = [[_mm256_setzero_si256(); 2]; T];
    let mut offset = [_mm256_setzero_si256(); 2];
    // rows with no occupied cube near this tile add only zeros
    for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & tile != 0) {
        // SAFETY: `(tap_row + 1)·WINDOW·CO ≤ q.w.len()` and `(tap_row +
        // 1)·CO ≤ q.offset.len()` (one (kd, kh)); cube c0 + o's window
        // reads bytes 3·(x0 + c0 + o) .. + 16 ≤ 3·(x0 + len) + SLACK, inside
        // `rows.bytes` (`c0 + T + K − 1 ≤ len`).
        unsafe {
            let w = q.w.as_ptr().add(tap_row * WINDOW * CO);
            add_row_offset(q, tap_row, &mut offset);
            let x = rows.bytes.as_ptr().add(CIN * (x0 + c0));
            for g in 0..WINDOW / 4 {
                let wg = w.add(g * CO * 4);
                let wv = [
                    _mm256_loadu_si256(wg.cast()),
                    _mm256_loadu_si256(wg.add(32).cast()),
                ];
                for (t, a) in acc.iter_mut().enumerate() {
                    let group = x.add(CIN * t + 4 * g).cast::<i32>().read_unaligned();
                    let xv = _mm256_set1_epi32(group);
                    a[0] = _mm256_dpbusd_avx_epi32(a[0], xv, wv[0]);
                    a[1] = _mm256_dpbusd_avx_epi32(a[1], xv, wv[1]);
                }
            }
        }
    }
    finish_tile(acc, offset, finish, out, largest);
}

/// As [`stem_tile_vnni`] on plain AVX2 for a narrow stem (bytes ≤ 127,
/// weights within ±63): per row, pair of window groups and cube, one
/// [`narrow_mac`] per half of the output channels.
///
/// # Safety
/// The CPU has AVX2 and FMA; `rows` is quantized to `q`'s narrow range,
/// and `c0 + T + K − 1 ≤ rows.len`.
#[target_feature(enable = "avx2,fma")]
unsafe fn stem_tile_narrow<const T: usize>(
    q: &Int8Stem,
    rows: &Rows,
    c0: usize,
    reach: &[(usize, usize, u64)],
    finish: &Finish,
    out: &mut [f32],
    largest: &mut [__m256; 2],
) {
    const { assert!(T <= MAX_TILE && (WINDOW / 4).is_multiple_of(2)) };
    debug_assert!(c0 + T + K - 1 <= rows.len && out.len() == T * CO);
    debug_assert_eq!(q.range(), Int8Range::Narrow);
    let tile = ((1u64 << T) - 1) << c0;
    let ones = _mm256_set1_epi16(1);
    let mut acc = [[_mm256_setzero_si256(); 2]; T];
    let mut offset = [_mm256_setzero_si256(); 2];
    // rows with no occupied cube near this tile add only zeros
    for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & tile != 0) {
        // SAFETY: as in `stem_tile_vnni`, two groups g, g + 1 < WINDOW / 4
        // at a time.
        unsafe {
            let w = q.w.as_ptr().add(tap_row * WINDOW * CO);
            add_row_offset(q, tap_row, &mut offset);
            let x = rows.bytes.as_ptr().add(CIN * (x0 + c0));
            for g in (0..WINDOW / 4).step_by(2) {
                let (w0, w1) = (w.add(g * CO * 4), w.add((g + 1) * CO * 4));
                let wv0 = [
                    _mm256_loadu_si256(w0.cast()),
                    _mm256_loadu_si256(w0.add(32).cast()),
                ];
                let wv1 = [
                    _mm256_loadu_si256(w1.cast()),
                    _mm256_loadu_si256(w1.add(32).cast()),
                ];
                for (t, a) in acc.iter_mut().enumerate() {
                    let at = x.add(CIN * t + 4 * g);
                    let x0 = _mm256_set1_epi32(at.cast::<i32>().read_unaligned());
                    let x1 = _mm256_set1_epi32(at.add(4).cast::<i32>().read_unaligned());
                    for h in 0..2 {
                        a[h] = narrow_mac(a[h], [x0, x1], [wv0[h], wv1[h]], ones);
                    }
                }
            }
        }
    }
    finish_tile(acc, offset, finish, out, largest);
}

/// Adds the offset of (kd, kh) row `tap_row` (what the inputs' +128 adds to
/// its sum, per output channel) to both halves of `offset`.
///
/// # Safety
/// The CPU has AVX2; `(tap_row + 1)·CO ≤ q.offset.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn add_row_offset(q: &Int8Stem, tap_row: usize, offset: &mut [__m256i; 2]) {
    debug_assert!((tap_row + 1) * CO <= q.offset.len());
    for (h, o) in offset.iter_mut().enumerate() {
        // SAFETY: inside `q.offset` (the caller's bound).
        let row_offset = unsafe { q.offset.as_ptr().add(tap_row * CO + 8 * h) };
        // SAFETY: eight i32 from there, still inside.
        *o = _mm256_add_epi32(*o, unsafe { _mm256_loadu_si256(row_offset.cast()) });
    }
}

/// The i32 sums of a tile's cubes, less the rows' offsets, to the outputs
/// ([`Finish`]) and their maximum into `largest`.
#[target_feature(enable = "avx2,fma")]
fn finish_tile<const T: usize>(
    acc: [[__m256i; 2]; T],
    offset: [__m256i; 2],
    finish: &Finish,
    out: &mut [f32],
    largest: &mut [__m256; 2],
) {
    let mut top = *largest;
    for (a, cube) in acc.into_iter().zip(out.chunks_exact_mut(CO)) {
        for h in 0..2 {
            let sum = _mm256_cvtepi32_ps(_mm256_sub_epi32(a[h], offset[h]));
            let v = _mm256_max_ps(
                _mm256_fmadd_ps(sum, finish.scale[h], finish.bias[h]),
                finish.floor,
            );
            top[h] = _mm256_max_ps(top[h], v);
            // SAFETY: `cube` holds 16 floats.
            unsafe { _mm256_storeu_ps(cube.as_mut_ptr().add(8 * h), v) };
        }
    }
    *largest = top;
}
