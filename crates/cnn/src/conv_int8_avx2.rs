//! The int8 convolutions of [`Int8Conv`] on AVX2 (no AVX-512), in two
//! forms that give the same sums:
//!
//! - plain AVX2: the input bytes widened to i16, the signed-byte weights held
//!   as i16 pairs, and `vpmaddwd` summing two products per i32 lane. Every
//!   product of a byte (0 ..= 255) and a weight (−127 ..= 127) and every pair
//!   sum (≤ 64,770 in magnitude) is exact in i32, as are the sums over taps;
//! - AVX-VNNI (`Isa::AvxVnni`): the bytes and the VNNI weight layout as they
//!   are, `vpdpbusd` on 256-bit vectors summing four products per i32 lane
//!   (exact likewise): a quarter of the instructions per product.
//!
//! So the sums equal AVX-512 VNNI's `vpdpbusd` sums bit for bit, and the f32
//! steps after them (one fused multiply-add by input scale × weight scale
//! plus bias, the residual sum, the ReLU) are the same operations in the
//! same order: the outputs are those of the AVX-512 VNNI kernel.
//!
//! The narrower scheme `vpmaddubsw` (u8 × s8 pairs summed in i16) would
//! double the products per instruction but saturates: 255·127 + 255·127 =
//! 64,770 > 32,767, so its sums are not exact for these bytes. With
//! [`Int8Range::Narrow`] (bytes ≤ 127, weights within ±63) they are, and
//! even two pairs add in i16 (4 · 127 · 63 = 32,004): plain AVX2 then
//! reads the bytes and the VNNI weight layout as they are and does, per 64
//! products, two `vpmaddubsw`, one `vpaddw` and one `vpmaddwd` by ones
//! (`tile_sums_narrow`) where the widened form needs four `vpmaddwd`.
//!
//! 16 output channels (two vectors of 8) at a time, tiles of up to six
//! neighbouring output cubes of a W row: 12 i32 chains, two weight vectors
//! and one input broadcast in the 16 registers.

use crate::conv::{Region, output_side, taps};
use crate::conv_int8::{Int8Conv, Int8Range, for_each_tile};
use std::arch::x86_64::*;
use std::cell::RefCell;

/// Output channels per block (two vectors of 8).
const BLOCK: usize = 16;
/// Vectors per block.
const V: usize = BLOCK / 8;
/// Most output cubes per tile.
const MAX_TILE: usize = 6;

thread_local! {
    /// The widened input of the current call (grows, never shrinks).
    static WIDE: RefCell<Vec<i16>> = const { RefCell::new(Vec::new()) };
}

/// The i32 sums of `T` output cubes, one channel block, from the input as
/// `E` (i16 widened bytes, or the bytes).
type TileFn<E> = unsafe fn(&Int8Conv, &[E], usize, [usize; 4], &mut [[__m256i; V]; MAX_TILE]);

/// [`Int8Conv::run`] on AVX2, with `vpdpbusd` where `avx_vnni`.
///
/// # Safety
/// The CPU has AVX2 and FMA, and AVX-VNNI where `avx_vnni`.
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn run(
    c: &Int8Conv,
    input: &[u8],
    input_scale: f32,
    n: usize,
    out: &mut [f32],
    flags: [bool; 2],
    region: Option<Region>,
    avx_vnni: bool,
) {
    if avx_vnni {
        let tiles: [TileFn<u8>; MAX_TILE] = [
            tile_sums_vnni::<1>,
            tile_sums_vnni::<2>,
            tile_sums_vnni::<3>,
            tile_sums_vnni::<4>,
            tile_sums_vnni::<5>,
            tile_sums_vnni::<6>,
        ];
        // SAFETY: the caller checked the features.
        return unsafe { run_tiles(c, input, input_scale, n, out, flags, region, &tiles) };
    }
    // narrow bytes, input groups in pairs (8 channels): `vpmaddubsw`
    if c.range() == Int8Range::Narrow && c.shape()[3].is_multiple_of(8) {
        let tiles: [TileFn<u8>; MAX_TILE] = [
            tile_sums_narrow::<1>,
            tile_sums_narrow::<2>,
            tile_sums_narrow::<3>,
            tile_sums_narrow::<4>,
            tile_sums_narrow::<5>,
            tile_sums_narrow::<6>,
        ];
        // SAFETY: the caller checked the features.
        return unsafe { run_tiles(c, input, input_scale, n, out, flags, region, &tiles) };
    }
    let tiles: [TileFn<i16>; MAX_TILE] = [
        tile_sums::<1>,
        tile_sums::<2>,
        tile_sums::<3>,
        tile_sums::<4>,
        tile_sums::<5>,
        tile_sums::<6>,
    ];
    WIDE.with_borrow_mut(|wide| {
        widen(input, wide);
        // SAFETY: the caller checked the features.
        unsafe {
            run_tiles(
                c,
                &wide[..input.len()],
                input_scale,
                n,
                out,
                flags,
                region,
                &tiles,
            );
        }
    });
}

/// The convolution from the input as `E`, tile by tile with `tiles`.
///
/// # Safety
/// The CPU runs `tiles` (and has AVX2 and FMA).
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn run_tiles<E>(
    c: &Int8Conv,
    input: &[E],
    input_scale: f32,
    n: usize,
    out: &mut [f32],
    [accumulate, relu]: [bool; 2],
    region: Option<Region>,
    tiles: &[TileFn<E>; MAX_TILE],
) {
    let [k, s, p, _, co, _] = c.shape();
    assert!(co.is_multiple_of(BLOCK), "{co} output channels");
    let m = output_side(n, k, s, p);
    assert_eq!(out.len(), m * m * m * co);
    let (factor, bias) = c.finish_factors(input_scale);
    // i32 sums of one output cube's block → f32 scale, bias, [residual], [ReLU]
    let finish = |sums: &[__m256i; V], cb: usize, dst: &mut [f32]| {
        for (v, &sum) in sums.iter().enumerate() {
            let at = cb + 8 * v..cb + 8 * v + 8;
            let (f, b): (&[f32; 8], &[f32; 8]) = (
                factor[at.clone()].try_into().expect("factors"),
                bias[at.clone()].try_into().expect("bias"),
            );
            // SAFETY: 8 readable f32 each; unaligned loads.
            let (fv, bv) = unsafe { (_mm256_loadu_ps(f.as_ptr()), _mm256_loadu_ps(b.as_ptr())) };
            let mut y = _mm256_fmadd_ps(_mm256_cvtepi32_ps(sum), fv, bv);
            let d: &mut [f32; 8] = (&mut dst[at]).try_into().expect("out row");
            if accumulate {
                // SAFETY: 8 readable f32.
                y = _mm256_add_ps(y, unsafe { _mm256_loadu_ps(d.as_ptr()) });
            }
            if relu {
                y = _mm256_max_ps(y, _mm256_setzero_ps());
            }
            // SAFETY: 8 writable f32.
            unsafe { _mm256_storeu_ps(d.as_mut_ptr(), y) };
        }
    };
    let mut sums = [[_mm256_setzero_si256(); V]; MAX_TILE];
    for_each_tile(m, co, region, MAX_TILE, out, |[od, oh, ow], t, out| {
        let first = (od * m + oh) * m + ow;
        for cb in (0..co).step_by(BLOCK) {
            // SAFETY: the caller checked the features; the tile functions
            // check their slices.
            unsafe { tiles[t - 1](c, input, n, [od, oh, ow, cb], &mut sums) };
            for (i, sum) in sums[..t].iter().enumerate() {
                let o = first + i;
                finish(sum, cb, &mut out[o * co..o * co + co]);
            }
        }
    });
}

/// `bytes` as i16 into the front of `wide` (grown as needed).
#[target_feature(enable = "avx2")]
fn widen(bytes: &[u8], wide: &mut Vec<i16>) {
    if wide.len() < bytes.len() {
        wide.resize(bytes.len(), 0);
    }
    let chunks = bytes.chunks_exact(16);
    let tail = chunks.remainder();
    let mut outs = wide[..bytes.len()].chunks_exact_mut(16);
    for (b, w) in chunks.zip(&mut outs) {
        // SAFETY: 16 readable bytes, 16 writable i16.
        unsafe {
            let v = _mm256_cvtepu8_epi16(_mm_loadu_si128(b.as_ptr().cast()));
            _mm256_storeu_si256(w.as_mut_ptr().cast(), v);
        }
    }
    for (w, &b) in outs.into_remainder().iter_mut().zip(tail) {
        *w = i16::from(b);
    }
}

/// The inner step of a tile: how the input is held (`Input`: i16 widened
/// bytes, two channels per 32-bit group, or the bytes, four) and the
/// instruction that adds a group's products to the i32 lanes. Both weight
/// layouts hold one group of an output channel in four bytes, so one tile
/// body ([`tile_sums_of`]) serves both; it is inlined into a function per
/// instruction set (`tile_sums`, `tile_sums_vnni`), so no VNNI instruction
/// can reach the plain AVX2 path.
trait GroupMac {
    /// the input element
    type Input: Copy;
    /// The weights of taps `taps` as bytes (`[tap][group][co][4 bytes]`).
    fn weight_bytes(c: &Int8Conv, taps: std::ops::Range<usize>) -> *const u8;
    /// `acc` + the products of the input group `x` (broadcast) and the
    /// weight groups `w`, summed per i32 lane.
    ///
    /// # Safety
    /// The CPU has this step's instructions.
    unsafe fn mac(acc: __m256i, x: __m256i, w: __m256i) -> __m256i;
}

/// Plain AVX2: i16 pairs, `vpmaddwd` and `vpaddd`.
struct Madd;

impl GroupMac for Madd {
    type Input = i16;
    fn weight_bytes(c: &Int8Conv, taps: std::ops::Range<usize>) -> *const u8 {
        c.tap_weights16(taps).as_ptr().cast()
    }
    #[inline(always)]
    unsafe fn mac(acc: __m256i, x: __m256i, w: __m256i) -> __m256i {
        // SAFETY: the caller's CPU has AVX2.
        unsafe { _mm256_add_epi32(acc, _mm256_madd_epi16(x, w)) }
    }
}

/// AVX-VNNI: byte quadruples, `vpdpbusd`.
struct Dpbusd;

impl GroupMac for Dpbusd {
    type Input = u8;
    fn weight_bytes(c: &Int8Conv, taps: std::ops::Range<usize>) -> *const u8 {
        c.tap_weights8(taps).as_ptr().cast()
    }
    #[inline(always)]
    unsafe fn mac(acc: __m256i, x: __m256i, w: __m256i) -> __m256i {
        // SAFETY: the caller's CPU has AVX-VNNI.
        unsafe { _mm256_dpbusd_avx_epi32(acc, x, w) }
    }
}

/// The i32 sums of the `T` output cubes `ow .. ow + T` of output row (`od`,
/// `oh`), output channels `cb .. cb + 16`, into `sums[..T]` (`vpmaddwd` on
/// the i16 widened input).
///
/// # Safety
/// The CPU has AVX2.
#[target_feature(enable = "avx2")]
unsafe fn tile_sums<const T: usize>(
    c: &Int8Conv,
    wide: &[i16],
    n: usize,
    at: [usize; 4],
    sums: &mut [[__m256i; V]; MAX_TILE],
) {
    // SAFETY: the CPU has AVX2.
    unsafe { tile_sums_of::<Madd, T>(c, wide, n, at, sums) }
}

/// As [`tile_sums`] with `vpdpbusd` on the bytes themselves.
///
/// # Safety
/// The CPU has AVX2 and AVX-VNNI.
#[target_feature(enable = "avx2,avxvnni")]
unsafe fn tile_sums_vnni<const T: usize>(
    c: &Int8Conv,
    input: &[u8],
    n: usize,
    at: [usize; 4],
    sums: &mut [[__m256i; V]; MAX_TILE],
) {
    // SAFETY: the CPU has AVX2 and AVX-VNNI.
    unsafe { tile_sums_of::<Dpbusd, T>(c, input, n, at, sums) }
}

/// The body of [`tile_sums`] and [`tile_sums_vnni`]: for every tap and
/// input group (4 bytes: two i16 or four u8 channels), two weight loads
/// feed `2·T` multiply-adds (one input group broadcast per cube). The
/// input's W rows are padded, so every W tap is in range; D and H taps out
/// of range are skipped.
///
/// # Safety
/// The CPU runs `M::mac` (and has AVX2).
#[inline(always)]
unsafe fn tile_sums_of<M: GroupMac, const T: usize>(
    c: &Int8Conv,
    input: &[M::Input],
    n: usize,
    [od, oh, ow, cb]: [usize; 4],
    sums: &mut [[__m256i; V]; MAX_TILE],
) {
    let [k, s, p, cin, co, layout_pad] = c.shape();
    let per_group = 4 / std::mem::size_of::<M::Input>();
    let groups = cin / per_group;
    let padded = (n + 2 * layout_pad) * cin;
    assert!(cb + BLOCK <= co);
    // SAFETY: the CPU has AVX2.
    let mut acc = [[unsafe { _mm256_setzero_si256() }; V]; T];
    for kd in taps(od, s, p, k, n) {
        let id = od * s + kd - p;
        for kh in taps(oh, s, p, k, n) {
            let ih = oh * s + kh - p;
            // position in the padded W row of output cube ow's tap kw
            let start = (id * n + ih) * padded + (ow * s + layout_pad - p) * cin;
            let x = &input[start..start + ((T - 1) * s + k) * cin];
            let first = (kd * k + kh) * k;
            let wt = M::weight_bytes(c, first..first + k);
            // SAFETY (all reads): kw < k, g < groups, t < T, v < V: input
            // elements (t·s + kw)·cin + per_group·(g + 1) ≤ ((T − 1)·s +
            // k)·cin, weight bytes ((kw·groups + g)·co + cb + 8v)·4 + 32 ≤
            // k·cin·co·(4 / per_group) (the taps' weights); the caller's
            // CPU runs `M::mac`.
            unsafe {
                for kw in 0..k {
                    for g in 0..groups {
                        let wg = wt.add(((kw * groups + g) * co + cb) * 4);
                        let wv: [__m256i; V] =
                            std::array::from_fn(|v| _mm256_loadu_si256(wg.add(32 * v).cast()));
                        let xg = x.as_ptr().add(kw * cin + per_group * g);
                        for (t, a) in acc.iter_mut().enumerate() {
                            let xv = _mm256_set1_epi32(
                                xg.add(t * s * cin).cast::<i32>().read_unaligned(),
                            );
                            for (a, &w) in a.iter_mut().zip(&wv) {
                                *a = M::mac(*a, xv, w);
                            }
                        }
                    }
                }
            }
        }
    }
    sums[..T].copy_from_slice(&acc);
}

/// `acc` + the products of two narrow input groups `x` (bytes ≤ 127, each
/// group broadcast) and their weight groups `w` (within ±63), summed per
/// i32 lane: two `vpmaddubsw` (each lane two products, ≤ 2 · 127 · 63 =
/// 16,002 in magnitude) added in i16 (≤ 32,004: exact), then `vpmaddwd` by
/// `ones` (every i16 lane 1) adds the lane pairs into the i32 lanes. The
/// narrow step of the 3³ tiles and of the row stem.
///
/// # Safety
/// The CPU has AVX2.
#[inline(always)]
pub(crate) unsafe fn narrow_mac(
    acc: __m256i,
    x: [__m256i; 2],
    w: [__m256i; 2],
    ones: __m256i,
) -> __m256i {
    // SAFETY: the caller's CPU has AVX2.
    unsafe {
        let pairs = _mm256_add_epi16(
            _mm256_maddubs_epi16(x[0], w[0]),
            _mm256_maddubs_epi16(x[1], w[1]),
        );
        _mm256_add_epi32(acc, _mm256_madd_epi16(pairs, ones))
    }
}

/// As [`tile_sums`] for narrow bytes (≤ 127) and weights (within ±63), on
/// the bytes and the VNNI weight layout: per tap, pair of input groups (8
/// channels) and cube, two `vpmaddubsw` (each lane: two u8 × s8 products,
/// ≤ 2 · 127 · 63 = 16,002 in magnitude) added in i16 (≤ 32,004: exact),
/// then `vpmaddwd` by ones adds the lane pairs into the i32 sums. The
/// same products as the other kernels, summed exactly: the same sums.
///
/// # Safety
/// The CPU has AVX2; the weights are narrow and the input bytes ≤ 127
/// (else lanes saturate), input channels a multiple of 8.
#[target_feature(enable = "avx2")]
unsafe fn tile_sums_narrow<const T: usize>(
    c: &Int8Conv,
    input: &[u8],
    n: usize,
    [od, oh, ow, cb]: [usize; 4],
    sums: &mut [[__m256i; V]; MAX_TILE],
) {
    let [k, s, p, cin, co, layout_pad] = c.shape();
    let groups = cin / 4;
    let padded = (n + 2 * layout_pad) * cin;
    assert!(cb + BLOCK <= co && groups.is_multiple_of(2));
    debug_assert_eq!(c.range(), Int8Range::Narrow);
    let ones = _mm256_set1_epi16(1);
    let mut acc = [[_mm256_setzero_si256(); V]; T];
    for kd in taps(od, s, p, k, n) {
        let id = od * s + kd - p;
        for kh in taps(oh, s, p, k, n) {
            let ih = oh * s + kh - p;
            // position in the padded W row of output cube ow's tap kw
            let start = (id * n + ih) * padded + (ow * s + layout_pad - p) * cin;
            let x = &input[start..start + ((T - 1) * s + k) * cin];
            let first = (kd * k + kh) * k;
            let wt: *const u8 = c.tap_weights8(first..first + k).as_ptr().cast();
            // SAFETY (all reads): as in `tile_sums_of` with four bytes per
            // group, two groups g, g + 1 < groups at a time.
            unsafe {
                for kw in 0..k {
                    for g in (0..groups).step_by(2) {
                        let w0 = wt.add(((kw * groups + g) * co + cb) * 4);
                        let w1 = w0.add(co * 4);
                        let wv0: [__m256i; V] =
                            std::array::from_fn(|v| _mm256_loadu_si256(w0.add(32 * v).cast()));
                        let wv1: [__m256i; V] =
                            std::array::from_fn(|v| _mm256_loadu_si256(w1.add(32 * v).cast()));
                        let xg = x.as_ptr().add(kw * cin + 4 * g);
                        for (t, a) in acc.iter_mut().enumerate() {
                            let at = xg.add(t * s * cin);
                            let x0 = _mm256_set1_epi32(at.cast::<i32>().read_unaligned());
                            let x1 = _mm256_set1_epi32(at.add(4).cast::<i32>().read_unaligned());
                            for v in 0..V {
                                a[v] = narrow_mac(a[v], [x0, x1], [wv0[v], wv1[v]], ones);
                            }
                        }
                    }
                }
            }
        }
    }
    sums[..T].copy_from_slice(&acc);
}
