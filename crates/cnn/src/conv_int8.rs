//! The 3³ convolutions in 8-bit integers (AVX-512 VNNI, `vpdpbusd`): 64
//! multiply-adds per instruction where f32 FMA does 16, at the same issue
//! rate on this CPU (measured: 5.6 G `vpdpbusd` and 5.3 G `vfmadd231ps` zmm
//! instructions/s per core; AVX-512 BF16 `vdpbf16ps` only 1.3 G, no faster
//! than f32, so it is not used).
//!
//! Every input of a residual-block convolution follows a ReLU, so it is ≥ 0
//! and fits unsigned bytes: one scale per input tensor (its maximum / 255,
//! taken per sample). Weights are signed bytes with one scale per output
//! channel (its largest |w| / 127). Products are summed exactly in i32 and
//! scaled back to f32 once per output, where the bias, the residual sum and
//! the ReLU are applied as in [`crate::conv`].

use crate::conv::{FoldedConv, Region, output_side, taps};

/// A [`FoldedConv`] with its weights in signed bytes, laid out
/// `[k³][cin/4][cout][4]` (four input channels per i32 lane).
#[derive(Clone, Debug)]
pub(crate) struct Int8Conv {
    w: Vec<i8>,
    /// per output channel: f32 weight = `w · scale`
    scale: Vec<f32>,
    bias: Vec<f32>,
    cin: usize,
    cout: usize,
    k: usize,
    stride: usize,
    pad: usize,
}

impl Int8Conv {
    /// Quantizes `c`; `None` where the layout does not fit the kernel
    /// (input channels not a multiple of 4, outputs not 16, 32, 64, 128 or 256).
    pub(crate) fn new(c: &FoldedConv) -> Option<Int8Conv> {
        // exactly the output channel counts `run` dispatches on
        if !c.cin.is_multiple_of(4) || !matches!(c.cout, 16 | 32 | 64 | 128 | 256) {
            return None;
        }
        let (cin, cout) = (c.cin, c.cout);
        let k3 = c.k.pow(3);
        let scale = weight_scales(c);
        let groups = cin / 4;
        let mut w = vec![0i8; k3 * cin * cout];
        for tap in 0..k3 {
            for ci in 0..cin {
                for co in 0..cout {
                    let v = c.w[(tap * cin + ci) * cout + co] / scale[co];
                    let (g, r) = (ci / 4, ci % 4);
                    w[((tap * groups + g) * cout + co) * 4 + r] =
                        v.round().clamp(-127.0, 127.0) as i8;
                }
            }
        }
        Some(Int8Conv {
            w,
            scale,
            bias: c.b.clone(),
            cin,
            cout,
            k: c.k,
            stride: c.stride,
            pad: c.pad,
        })
    }

    /// As [`FoldedConv::run`] on an input quantized by [`quantize`]
    /// (`input` bytes, f32 value = byte · `input_scale`).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F, BW and VNNI.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn run(
        &self,
        input: &[u8],
        input_scale: f32,
        n: usize,
        out: &mut [f32],
        accumulate: bool,
        relu: bool,
        region: Option<Region>,
    ) {
        debug_assert_eq!(input.len(), n * n * n * self.cin);
        // V vectors of 16 output channels, S accumulator sets: eight i32
        // chains in flight whatever the channel count
        macro_rules! go {
            ($v:literal, $s:literal, $paired:literal) => {
                dense_vnni::<$v, $s, $paired>(
                    self,
                    input,
                    input_scale,
                    n,
                    out,
                    accumulate,
                    relu,
                    region,
                )
            };
        }
        // SAFETY: the caller checked the features.
        unsafe {
            match self.cout {
                // pairs of output cubes where a weight load feeds few instructions
                16 => go!(1, 8, true),
                32 => go!(2, 4, true),
                64 => go!(4, 2, true),
                128 => go!(8, 1, false),
                256 => go!(16, 1, false),
                c => unreachable!("{c} output channels rejected by Int8Conv::new"),
            }
        }
    }
}

/// Per output channel of `c`, the scale of its signed-byte weights: its
/// largest |w| / 127 (1 for an all-zero channel).
pub(crate) fn weight_scales(c: &FoldedConv) -> Vec<f32> {
    (0..c.cout)
        .map(|co| {
            let max =
                c.w.iter()
                    .skip(co)
                    .step_by(c.cout)
                    .fold(0.0f32, |m, w| m.max(w.abs()));
            if max > 0.0 { max / 127.0 } else { 1.0 }
        })
        .collect()
}

/// Whether this CPU runs [`Int8Conv`].
pub(crate) fn supported() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512vnni")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `x` (all ≥ 0, as after a ReLU) as bytes: byte = ⌊x / s + ½⌋ with
/// s = max(x) / 255. Returns the bytes (the first `x.len()` of `buffer`,
/// which only grows: no zero fill per call) and s (1 for an all-zero input).
/// AVX-512 where the CPU has it (the same bytes as the scalar loop).
pub(crate) fn quantize<'a>(x: &[f32], buffer: &'a mut Vec<u8>) -> (&'a [u8], f32) {
    if buffer.len() < x.len() {
        buffer.resize(x.len(), 0);
    }
    let out = &mut buffer[..x.len()];
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the feature was detected.
        let scale = unsafe { quantize_avx512(x, out) };
        return (out, scale);
    }
    let scale = quantize_scalar(x, out);
    (out, scale)
}

fn quantize_scalar(x: &[f32], out: &mut [u8]) -> f32 {
    let max = x.iter().fold(0.0f32, |m, &v| m.max(v));
    let scale = if max > 0.0 { max / 255.0 } else { 1.0 };
    let inv = 1.0 / scale;
    for (o, &v) in out.iter_mut().zip(x) {
        *o = (v * inv + 0.5).min(255.0) as u8;
    }
    scale
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn quantize_avx512(x: &[f32], out: &mut [u8]) -> f32 {
    use std::arch::x86_64::*;
    let chunks = x.chunks_exact(16);
    let tail = chunks.remainder();
    let mut m = _mm512_setzero_ps();
    for c in chunks.clone() {
        // SAFETY: 16 readable f32.
        m = _mm512_max_ps(m, unsafe { _mm512_loadu_ps(c.as_ptr()) });
    }
    let max = tail.iter().fold(_mm512_reduce_max_ps(m), |m, &v| m.max(v));
    let scale = if max > 0.0 { max / 255.0 } else { 1.0 };
    let inv = 1.0 / scale;
    let (iv, half, top) = (
        _mm512_set1_ps(inv),
        _mm512_set1_ps(0.5),
        _mm512_set1_ps(255.0),
    );
    let mut outs = out.chunks_exact_mut(16);
    for (c, o) in chunks.zip(&mut outs) {
        // SAFETY: 16 readable f32, 16 writable bytes.
        unsafe {
            let v = _mm512_min_ps(
                _mm512_add_ps(_mm512_mul_ps(_mm512_loadu_ps(c.as_ptr()), iv), half),
                top,
            );
            _mm_storeu_si128(
                o.as_mut_ptr().cast(),
                _mm512_cvtusepi32_epi8(_mm512_cvttps_epi32(v)),
            );
        }
    }
    for (o, &v) in outs.into_remainder().iter_mut().zip(tail) {
        *o = (v * inv + 0.5).min(255.0) as u8;
    }
    scale
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[allow(clippy::too_many_arguments)]
fn dense_vnni<const V: usize, const S: usize, const PAIRED: bool>(
    c: &Int8Conv,
    input: &[u8],
    input_scale: f32,
    n: usize,
    out: &mut [f32],
    accumulate: bool,
    relu: bool,
    region: Option<Region>,
) {
    use std::arch::x86_64::*;
    let (cin, k, s, p) = (c.cin, c.k, c.stride, c.pad);
    let co = c.cout;
    debug_assert_eq!(co, 16 * V);
    let m = output_side(n, k, s, p);
    debug_assert_eq!(out.len(), m * m * m * co);
    let groups = cin / 4;
    let mut factor = [[0.0f32; 16]; V];
    for (v, f) in factor.iter_mut().enumerate() {
        for (j, f) in f.iter_mut().enumerate() {
            *f = input_scale * c.scale[16 * v + j];
        }
    }
    // i32 sums of one output cube → f32 scale, bias, [residual], [ReLU]
    let finish = |sums: [__m512i; V], dst: &mut [f32]| {
        for (v, sum) in sums.into_iter().enumerate() {
            let f: &[f32; 16] = &factor[v];
            let b: &[f32; 16] = c.bias[16 * v..16 * v + 16].try_into().expect("bias");
            // SAFETY: 16 readable f32 each; unaligned loads.
            let (fv, bv) = unsafe { (_mm512_loadu_ps(f.as_ptr()), _mm512_loadu_ps(b.as_ptr())) };
            let mut y = _mm512_fmadd_ps(_mm512_cvtepi32_ps(sum), fv, bv);
            let d: &mut [f32; 16] = (&mut dst[16 * v..16 * v + 16]).try_into().expect("out row");
            if accumulate {
                // SAFETY: 16 readable f32.
                y = _mm512_add_ps(y, unsafe { _mm512_loadu_ps(d.as_ptr()) });
            }
            if relu {
                y = _mm512_max_ps(y, _mm512_setzero_ps());
            }
            // SAFETY: 16 writable f32.
            unsafe { _mm512_storeu_ps(d.as_mut_ptr(), y) };
        }
    };
    let computed = |o: usize| region.is_none_or(|r| r.mask[o]);
    // a cube outside the region takes the background's value, if any
    let background = |o: usize, out: &mut [f32]| {
        if let Some(bg) = region.and_then(|r| r.background) {
            out[o * co..o * co + co].copy_from_slice(&bg[o * co..o * co + co]);
        }
    };
    for od in 0..m {
        let rd = taps(od, s, p, k, n);
        for oh in 0..m {
            let rh = taps(oh, s, p, k, n);
            let mut ow = 0;
            while ow < m {
                let rw = taps(ow, s, p, k, n);
                let o = (od * m + oh) * m + ow;
                if !computed(o) {
                    background(o, out);
                    ow += 1;
                    continue;
                }
                // 16 output channels: eight neighbours along W with every
                // tap in range share each weight load (exact sums: the same
                // bits as one by one); cubes outside the region are computed
                // and then replaced by the background
                if V == 1
                    && ow + TILE <= m
                    && rw == (0..k)
                    && taps(ow + TILE - 1, s, p, k, n) == rw
                    && (o..o + TILE).any(computed)
                {
                    let mut sums = [_mm512_setzero_si512(); TILE];
                    for kd in rd.clone() {
                        let id = od * s + kd - p;
                        for kh in rh.clone() {
                            let ih = oh * s + kh - p;
                            let i = (id * n + ih) * n + ow * s - p;
                            let first = (kd * k + kh) * k;
                            let x = &input[i * cin..(i + (TILE - 1) * s + k) * cin];
                            let wt = &c.w[first * cin * co..(first + k) * cin * co];
                            // SAFETY: `x` holds the k taps of the TILE cubes
                            // (`s · cin` apart) and `wt` the k taps' weights
                            // (sliced above); the CPU has VNNI (caller).
                            unsafe {
                                tile_row_products(&mut sums, x.as_ptr(), wt.as_ptr(), groups, k, s)
                            };
                        }
                    }
                    for (t, sum) in sums.into_iter().enumerate() {
                        let at = (o + t) * co;
                        if computed(o + t) {
                            finish(std::array::from_fn(|_| sum), &mut out[at..at + co]);
                        } else {
                            background(o + t, out);
                        }
                    }
                    ow += TILE;
                    continue;
                }
                // two neighbours along W with the same taps share each
                // weight load (the sums are exact: the same bits either way)
                let pair =
                    PAIRED && ow + 1 < m && computed(o + 1) && taps(ow + 1, s, p, k, n) == rw;
                let mut accs = [[[_mm512_setzero_si512(); V]; S]; 2];
                for kd in rd.clone() {
                    let id = od * s + kd - p;
                    for kh in rh.clone() {
                        let ih = oh * s + kh - p;
                        for kw in rw.clone() {
                            let iw = ow * s + kw - p;
                            let i = (id * n + ih) * n + iw;
                            let tap = (kd * k + kh) * k + kw;
                            let wt = &c.w[tap * cin * co..(tap + 1) * cin * co];
                            if pair {
                                let x = &input[i * cin..(i + s) * cin + cin];
                                let [a0, a1] = &mut accs;
                                // SAFETY: `x` holds the `4 · groups` bytes of
                                // both cubes (`s · cin` apart) and `wt`
                                // `groups · co · 4`; offsets stay inside.
                                unsafe {
                                    tap_products_pair::<V, S>(
                                        a0,
                                        a1,
                                        x.as_ptr(),
                                        x.as_ptr().add(s * cin),
                                        wt.as_ptr(),
                                        groups,
                                        co,
                                    )
                                };
                            } else {
                                let x = &input[i * cin..i * cin + cin];
                                // SAFETY: `x` holds `4 · groups` bytes and `wt`
                                // `groups · co · 4` (checked by the slicing
                                // above); every offset below stays inside them.
                                unsafe {
                                    tap_products::<V, S>(
                                        &mut accs[0],
                                        x.as_ptr(),
                                        wt.as_ptr(),
                                        groups,
                                        co,
                                    )
                                };
                            }
                        }
                    }
                }
                for (cube, sets) in accs.iter().enumerate().take(1 + usize::from(pair)) {
                    let sums = std::array::from_fn(|v| {
                        sets[1..]
                            .iter()
                            .fold(sets[0][v], |sum, acc| _mm512_add_epi32(sum, acc[v]))
                    });
                    let at = (o + cube) * co;
                    finish(sums, &mut out[at..at + co]);
                }
                ow += 1 + usize::from(pair);
            }
        }
    }
}

/// Output cubes per W tile of [`tile_row_products`].
const TILE: usize = 8;

/// One (kd, kh) row of taps for [`TILE`] neighbouring output cubes with 16
/// output channels: for each of the `k` W taps and input group, one weight
/// load feeds [`TILE`] `vpdpbusd` (one per cube), [`TILE`] chains in flight.
///
/// # Safety
/// `x` points to the input bytes of cubes `0 .. (TILE − 1)·s + k` (`4 ·
/// groups` each, consecutive), `w` to `k · groups · 16 · 4` weight bytes;
/// the CPU has AVX-512 F and VNNI.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[inline]
unsafe fn tile_row_products(
    sums: &mut [std::arch::x86_64::__m512i; TILE],
    x: *const u8,
    w: *const i8,
    groups: usize,
    k: usize,
    s: usize,
) {
    use std::arch::x86_64::*;
    let cin = 4 * groups;
    // SAFETY (all reads): kw < k and g < groups; cube t·s + kw ≤ (TILE −
    // 1)·s + k − 1, inside `x`; weights (kw·groups + g)·64 + 64 ≤ k·groups·64.
    unsafe {
        for kw in 0..k {
            for g in 0..groups {
                let wv = _mm512_loadu_si512(w.add((kw * groups + g) * 64).cast());
                for (t, sum) in sums.iter_mut().enumerate() {
                    let at = (t * s + kw) * cin + 4 * g;
                    let xv = _mm512_set1_epi32(x.add(at).cast::<i32>().read_unaligned());
                    *sum = _mm512_dpbusd_epi32(*sum, xv, wv);
                }
            }
        }
    }
}

/// As [`tap_products`] for two output cubes at once: each weight vector is
/// loaded once for both.
///
/// # Safety
/// As [`tap_products`], for `x0` and `x1`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[inline]
unsafe fn tap_products_pair<const V: usize, const S: usize>(
    a0: &mut [[std::arch::x86_64::__m512i; V]; S],
    a1: &mut [[std::arch::x86_64::__m512i; V]; S],
    x0: *const u8,
    x1: *const u8,
    w: *const i8,
    groups: usize,
    co: usize,
) {
    use std::arch::x86_64::*;
    // half the accumulator sets per cube: as many chains in flight as alone
    let sets = (S / 2).max(1);
    let mut g = 0;
    // SAFETY (all reads): g < groups, as in `tap_products`.
    unsafe {
        let mut group = |g: usize, u: usize| {
            let xv0 = _mm512_set1_epi32(x0.add(4 * g).cast::<i32>().read_unaligned());
            let xv1 = _mm512_set1_epi32(x1.add(4 * g).cast::<i32>().read_unaligned());
            let wg = w.add(g * co * 4);
            for v in 0..V {
                let wv = _mm512_loadu_si512(wg.add(64 * v).cast());
                a0[u][v] = _mm512_dpbusd_epi32(a0[u][v], xv0, wv);
                a1[u][v] = _mm512_dpbusd_epi32(a1[u][v], xv1, wv);
            }
        };
        while g + sets <= groups {
            for u in 0..sets {
                group(g + u, u);
            }
            g += sets;
        }
        // fewer groups than sets left: still one set each
        let mut u = 0;
        while g < groups {
            group(g, u);
            g += 1;
            u += 1;
        }
    }
}

/// Adds one tap's products to the accumulators: input group `g` (four
/// channels, one i32 broadcast) times its `V` weight vectors, groups spread
/// over the `S` accumulator sets.
///
/// # Safety
/// `x` points to `4 · groups` readable bytes, `w` to `groups · co · 4`; the
/// CPU has AVX-512 F and VNNI.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[inline]
unsafe fn tap_products<const V: usize, const S: usize>(
    accs: &mut [[std::arch::x86_64::__m512i; V]; S],
    x: *const u8,
    w: *const i8,
    groups: usize,
    co: usize,
) {
    use std::arch::x86_64::*;
    let mut g = 0;
    // SAFETY (all reads): g < groups, so the broadcast reads bytes
    // 4g..4g+4 of x and the loads bytes (g·co + 16v)·4 .. +64 of w.
    unsafe {
        while g + S <= groups {
            for (u, acc) in accs.iter_mut().enumerate() {
                let xv = _mm512_set1_epi32(x.add(4 * (g + u)).cast::<i32>().read_unaligned());
                let wg = w.add((g + u) * co * 4);
                for (v, a) in acc.iter_mut().enumerate() {
                    *a = _mm512_dpbusd_epi32(*a, xv, _mm512_loadu_si512(wg.add(64 * v).cast()));
                }
            }
            g += S;
        }
        // the remaining groups on separate sets too (fewer groups than
        // sets, as 16 input channels with 8 sets, would otherwise chain
        // every product of the cube on one accumulator)
        let mut u = 0;
        while g < groups {
            let xv = _mm512_set1_epi32(x.add(4 * g).cast::<i32>().read_unaligned());
            let wg = w.add(g * co * 4);
            for (v, a) in accs[u].iter_mut().enumerate() {
                *a = _mm512_dpbusd_epi32(*a, xv, _mm512_loadu_si512(wg.add(64 * v).cast()));
            }
            g += 1;
            u += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conv::Level;
    use crate::weights::{BatchNormWeights, ConvWeights};

    fn conv(cin: usize, cout: usize, stride: usize, seed: u32) -> FoldedConv {
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let weight = (0..cout * cin * 27).map(|_| next() * 0.2).collect();
        let bias = Some((0..cout).map(|_| next() * 0.1).collect());
        let c = ConvWeights {
            in_channels: cin,
            out_channels: cout,
            kernel: 3,
            stride,
            padding: 1,
            weight,
            bias,
        };
        FoldedConv::new(&c, &BatchNormWeights::identity(cout))
    }

    #[test]
    fn the_integer_convolution_matches_f32_to_quantization_error() {
        if !supported() {
            eprintln!("no AVX-512 VNNI on this CPU: skipped");
            return;
        }
        for (cin, cout, stride, n) in [
            (16, 32, 2, 9),
            (32, 32, 1, 6),
            (32, 64, 2, 7),
            (64, 64, 1, 4),
        ] {
            let f = conv(cin, cout, stride, (cin * cout + stride) as u32);
            let q = Int8Conv::new(&f).expect("layout fits");
            let mut state = 7u32;
            let x: Vec<f32> = (0..n * n * n * cin)
                .map(|_| {
                    state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    let u = (state >> 8) as f32 / (1u32 << 24) as f32;
                    // ReLU-like: a third zeros, the rest in [0, 2)
                    if u < 0.33 {
                        0.0
                    } else {
                        2.0 * (u - 0.33) / 0.67
                    }
                })
                .collect();
            let m = f.output_side(n);
            for (accumulate, relu) in [(false, true), (true, true), (false, false)] {
                let start: Vec<f32> = (0..m * m * m * cout)
                    .map(|i| (i % 7) as f32 * 0.1)
                    .collect();
                let mut want = start.clone();
                f.run(Level::detect(), &x, n, &mut want, accumulate, relu, None);
                let mut got = start.clone();
                let mut buffer = Vec::new();
                let (xq, sx) = quantize(&x, &mut buffer);
                // SAFETY: supported() checked the features.
                unsafe { q.run(xq, sx, n, &mut got, accumulate, relu, None) };
                let range = want.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                let worst = want
                    .iter()
                    .zip(&got)
                    .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
                // 8-bit inputs and weights: about 1 % of the output range
                assert!(
                    worst < 0.02 * range,
                    "cin {cin} cout {cout}: worst {worst} of range {range}"
                );
                assert!(worst > 0.0, "quantization must show somewhere");
            }
        }
    }

    #[test]
    fn pairing_output_cubes_changes_no_bit() {
        if !supported() {
            eprintln!("no AVX-512 VNNI on this CPU: skipped");
            return;
        }
        let mut state = 3u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        for (cin, cout, stride, n) in [
            (16, 16, 1, 7),
            (16, 32, 2, 9),
            (32, 32, 1, 6),
            (32, 64, 1, 5),
        ] {
            let q = Int8Conv::new(&conv(cin, cout, stride, cin as u32 + 5)).expect("layout fits");
            let m = output_side(n, 3, stride, 1);
            let x: Vec<u8> = (0..n * n * n * cin).map(|_| (next() % 256) as u8).collect();
            // a mask with runs and gaps, so pairs, singles and skipped cubes mix
            let mask: Vec<bool> = (0..m * m * m).map(|_| next() % 4 != 0).collect();
            let background: Vec<f32> = (0..m * m * m * cout).map(|i| i as f32).collect();
            let region = Region {
                mask: &mask,
                background: Some(&background),
            };
            let start: Vec<f32> = (0..m * m * m * cout).map(|i| (i % 5) as f32).collect();
            for (accumulate, relu) in [(false, true), (true, false)] {
                let run = |paired: bool| {
                    let mut out = start.clone();
                    macro_rules! go {
                        ($v:literal, $s:literal, $p:literal) => {
                            // SAFETY: supported() checked the features.
                            unsafe {
                                dense_vnni::<$v, $s, $p>(
                                    &q,
                                    &x,
                                    0.01,
                                    n,
                                    &mut out,
                                    accumulate,
                                    relu,
                                    Some(region),
                                )
                            }
                        };
                    }
                    match (cout, paired) {
                        (16, true) => go!(1, 8, true),
                        (16, false) => go!(1, 8, false),
                        (32, true) => go!(2, 4, true),
                        (32, false) => go!(2, 4, false),
                        (64, true) => go!(4, 2, true),
                        _ => go!(4, 2, false),
                    }
                    out
                };
                let (paired, single) = (run(true), run(false));
                assert!(
                    paired
                        .iter()
                        .zip(&single)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "cin {cin} cout {cout} stride {stride}"
                );
            }
        }
    }

    #[test]
    fn quantize_maps_zero_to_zero_the_maximum_to_255_and_rounds() {
        let x = [0.0, 1.0, 0.5, 2.0, 0.013, 1.999];
        let mut buffer = Vec::new();
        let (q, s) = quantize(&x, &mut buffer);
        assert!((s - 2.0 / 255.0).abs() < 1e-9);
        assert_eq!((q[0], q[3]), (0, 255));
        for (&v, &b) in x.iter().zip(q) {
            assert!((b as f32 * s - v).abs() <= 0.5001 * s, "{v} -> {b}");
        }
        // a shorter input reuses the buffer: only its own bytes count
        assert_eq!(quantize(&[0.0; 4], &mut buffer), (&[0u8; 4][..], 1.0));
        // the vector path (where the CPU has it) gives the scalar loop's bytes
        let long: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919) % 1013) as f32 * 0.037)
            .collect();
        let mut scalar = vec![0; long.len()];
        let s_scalar = quantize_scalar(&long, &mut scalar);
        assert_eq!(quantize(&long, &mut buffer), (&scalar[..], s_scalar));
    }
}
