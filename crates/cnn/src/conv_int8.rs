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
//!
//! [`Int8Range::Narrow`] halves both ranges (bytes 0 ..= 127, weights ±63)
//! for networks trained for it: the VNNI kernels are the same, and plain
//! AVX2 can then sum two `vpmaddubsw` pairs in i16 exactly
//! ([`crate::conv_int8_avx2`]).

use crate::conv::{CubeMask, FoldedConv, Region, output_side, taps};

/// The integer ranges of the int8 arithmetic: a property of the networks
/// (what they were trained to tolerate), not of the CPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(rename_all = "lowercase")
)]
pub enum Int8Range {
    /// block inputs in 0 ..= 255 (max / 255 per sample), weights in ±127
    /// (per output channel), stem inputs in ±127: the shipped networks
    #[default]
    Full,
    /// block inputs in 0 ..= 127, weights in ±63, stem inputs in ±63
    /// (stored as 1 ..= 127, zero at 64): two `vpmaddubsw` pair sums of
    /// plain AVX2 add in i16 without overflow (4 · 127 · 63 = 32,004), so
    /// AVX2 does 64 products in 5 instructions (3 multiplies) instead of 8
    /// (4)
    Narrow,
}

impl Int8Range {
    /// The largest byte of a block input.
    pub(crate) fn activation_max(self) -> f32 {
        match self {
            Int8Range::Full => 255.0,
            Int8Range::Narrow => 127.0,
        }
    }

    /// The largest |weight|.
    pub(crate) fn weight_max(self) -> f32 {
        match self {
            Int8Range::Full => 127.0,
            Int8Range::Narrow => 63.0,
        }
    }

    /// The stem's largest |input| step and the byte that stores zero.
    pub(crate) fn stem_levels(self) -> (i32, i32) {
        match self {
            Int8Range::Full => (127, 128),
            Int8Range::Narrow => (63, 64),
        }
    }

    /// `full` or `narrow` (the bundle manifest's `int8_range`).
    pub fn name(self) -> &'static str {
        match self {
            Int8Range::Full => "full",
            Int8Range::Narrow => "narrow",
        }
    }

    /// The ranges a network trained for `self` runs with by default on
    /// kernel path `isa`: its own where the path has VNNI (`vpdpbusd`),
    /// narrow where plain AVX2 sums the bytes (AVX2, AVX-512 without
    /// VNNI: `vpmaddubsw` is exact only for narrow numbers).
    pub fn default_on(self, isa: normalnet_isa::Isa) -> Int8Range {
        match isa.has_vnni() || isa.uses_avx_vnni() {
            true => self,
            false => Int8Range::Narrow,
        }
    }
}

/// A [`FoldedConv`] with its weights in signed bytes, laid out
/// `[k³][cin/4][cout][4]` (four input channels per i32 lane).
#[derive(Clone, Debug)]
pub(crate) struct Int8Conv {
    w: Vec<i8>,
    /// the same weights as i16 pairs, `[k³][cin/2][cout][2]` (two input
    /// channels per i32 lane), for the AVX2 kernel (`vpmaddwd`)
    w16: Vec<i16>,
    /// per output channel: f32 weight = `w · scale`
    scale: Vec<f32>,
    bias: Vec<f32>,
    cin: usize,
    cout: usize,
    k: usize,
    stride: usize,
    pad: usize,
    /// zero cubes on each side of the input's W rows in the layout `run`
    /// reads (≥ `pad`; `pad` unless [`Int8Conv::reading_layout`] says
    /// otherwise)
    layout_pad: usize,
    /// the integer ranges of its weights and inputs
    range: Int8Range,
}

impl Int8Conv {
    /// Quantizes `c` to `range`; `None` where the layout does not fit the
    /// kernel (input channels not a multiple of 4, outputs not 16, 32, 64,
    /// 128 or 256).
    pub(crate) fn new(c: &FoldedConv, range: Int8Range) -> Option<Int8Conv> {
        // exactly the output channel counts `run` dispatches on
        if !c.cin.is_multiple_of(4) || !matches!(c.cout, 16 | 32 | 64 | 128 | 256) {
            return None;
        }
        let (cin, cout) = (c.cin, c.cout);
        let k3 = c.k.pow(3);
        let scale = weight_scales(&c.w, cout, range);
        let wmax = range.weight_max();
        let groups = cin / 4;
        let mut w = vec![0i8; k3 * cin * cout];
        for tap in 0..k3 {
            for ci in 0..cin {
                for co in 0..cout {
                    let v = c.w[(tap * cin + ci) * cout + co] / scale[co];
                    let (g, r) = (ci / 4, ci % 4);
                    w[((tap * groups + g) * cout + co) * 4 + r] =
                        v.round().clamp(-wmax, wmax) as i8;
                }
            }
        }
        let w16 = (0..k3 * cin * cout)
            .map(|i| {
                let (tap, pair, co, r) = (
                    i / (cin * cout),
                    i / (2 * cout) % (cin / 2),
                    i / 2 % cout,
                    i % 2,
                );
                let ci = 2 * pair + r;
                i16::from(w[((tap * groups + ci / 4) * cout + co) * 4 + ci % 4])
            })
            .collect();
        Some(Int8Conv {
            w,
            w16,
            scale,
            bias: c.b.clone(),
            cin,
            cout,
            k: c.k,
            stride: c.stride,
            pad: c.pad,
            layout_pad: c.pad,
            range,
        })
    }

    /// The integer ranges it was quantized to (its inputs must be
    /// [`quantize`]d to the same).
    pub(crate) fn range(&self) -> Int8Range {
        self.range
    }

    /// The same convolution reading inputs quantized with `layout_pad` zero
    /// cubes on each side of every W row (`layout_pad ≥` its padding): a
    /// 1³ shortcut reads the bytes quantized for its block's 3³ convolution.
    pub(crate) fn reading_layout(mut self, layout_pad: usize) -> Int8Conv {
        assert!(layout_pad >= self.pad, "the layout holds every padded tap");
        self.layout_pad = layout_pad;
        self
    }

    /// As [`FoldedConv::run`] on an input quantized by [`quantize`] with
    /// [`Self::input_pad`] (`input` bytes, f32 value = byte · `input_scale`),
    /// with the kernels of `isa`: AVX-512 VNNI (`vpdpbusd`), AVX-VNNI
    /// (`vpdpbusd` on 256 bits) or AVX2 (`vpmaddwd` on bytes widened to
    /// i16). All sum the same products exactly in i32 and finish them with
    /// the same f32 steps: the same bits.
    ///
    /// # Safety
    /// [`supported`]`(isa)`, and the CPU runs `isa`.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn run(
        &self,
        isa: normalnet_isa::Isa,
        input: &[u8],
        input_scale: f32,
        n: usize,
        out: &mut [f32],
        accumulate: bool,
        relu: bool,
        region: Option<Region>,
    ) {
        assert_eq!(input.len(), n * n * (n + 2 * self.layout_pad) * self.cin);
        if !isa.has_vnni() {
            debug_assert!(isa.has_avx2());
            let flags = [accumulate, relu];
            let avx_vnni = isa.uses_avx_vnni();
            // SAFETY: the caller checked the features.
            return unsafe {
                crate::conv_int8_avx2::run(
                    self,
                    input,
                    input_scale,
                    n,
                    out,
                    flags,
                    region,
                    avx_vnni,
                )
            };
        }
        // V vectors of 16 output channels; tiles of 1 ..= 16 / V cubes
        // (at most 12): as many i32 chains in flight, within the 32 registers
        macro_rules! go {
            ($v:literal; $($t:literal)*) => {
                dense_vnni::<$v>(
                    self,
                    input,
                    input_scale,
                    n,
                    out,
                    [accumulate, relu],
                    region,
                    &[$(tile_sums::<$v, $t> as TileFn<$v>),*],
                )
            };
        }
        // SAFETY: the caller checked the features.
        unsafe {
            match self.cout {
                16 => go!(1; 1 2 3 4 5 6 7 8 9 10 11 12),
                32 => go!(2; 1 2 3 4 5 6 7 8),
                64 => go!(4; 1 2 3 4),
                128 => go!(8; 1 2),
                256 => go!(16; 1),
                c => unreachable!("{c} output channels rejected by Int8Conv::new"),
            }
        }
    }

    /// Zero cubes on each side of the input's W rows that [`Self::run`]
    /// expects (its padding, or the layout it was told to read).
    pub(crate) fn input_pad(&self) -> usize {
        self.layout_pad
    }

    /// Flags in `rows` (len `n²`, one per W row `d·n + h` of an `n³`
    /// input; flags already set stay set) the input rows that [`Self::run`]
    /// reads when it computes the output cubes set in `mask`: the rows in
    /// the (d, h) window of every output row with a cube to compute.
    pub(crate) fn rows_read(&self, mask: &CubeMask, n: usize, rows: &mut [bool]) {
        let (k, s, p) = (self.k, self.stride, self.pad);
        let m = output_side(n, k, s, p);
        assert_eq!(mask.side(), m);
        assert_eq!(rows.len(), n * n);
        for o in 0..m * m {
            if mask.row(o) != 0 {
                let (od, oh) = (o / m, o % m);
                for kd in taps(od, s, p, k, n) {
                    for kh in taps(oh, s, p, k, n) {
                        rows[(od * s + kd - p) * n + oh * s + kh - p] = true;
                    }
                }
            }
        }
    }
}

/// Per output channel of weights `w` (`[k³][cin][cout]`), the scale of its
/// signed-byte weights: its
/// largest |w| / `range`'s largest weight (127, or 63 narrow; 1 for an
/// all-zero channel).
pub(crate) fn weight_scales(w: &[f32], cout: usize, range: Int8Range) -> Vec<f32> {
    (0..cout)
        .map(|co| {
            let max = w
                .iter()
                .skip(co)
                .step_by(cout)
                .fold(0.0f32, |m, w| m.max(w.abs()));
            if max > 0.0 {
                max / range.weight_max()
            } else {
                1.0
            }
        })
        .collect()
}

/// Whether the path `isa` runs [`Int8Conv`] (AVX-512 VNNI or AVX2).
pub(crate) fn supported(isa: normalnet_isa::Isa) -> bool {
    cfg!(target_arch = "x86_64") && isa.has_avx2()
}

impl Int8Conv {
    /// Kernel size, stride, padding, input and output channels, the zero
    /// cubes of the input layout: what the AVX2 kernel reads.
    pub(crate) fn shape(&self) -> [usize; 6] {
        [
            self.k,
            self.stride,
            self.pad,
            self.cin,
            self.cout,
            self.layout_pad,
        ]
    }

    /// The signed-byte weights of taps `taps` in the VNNI layout,
    /// `[cin/4][cout][4]` per tap.
    pub(crate) fn tap_weights8(&self, taps: std::ops::Range<usize>) -> &[i8] {
        let per_tap = self.cin * self.cout;
        &self.w[taps.start * per_tap..taps.end * per_tap]
    }

    /// The i16 pair weights of tap `tap`, `[cin/2][cout][2]`.
    pub(crate) fn tap_weights16(&self, taps: std::ops::Range<usize>) -> &[i16] {
        let per_tap = self.cin * self.cout;
        &self.w16[taps.start * per_tap..taps.end * per_tap]
    }

    /// Per output channel: `input_scale ·` weight scale, and the bias.
    pub(crate) fn finish_factors(&self, input_scale: f32) -> (Vec<f32>, &[f32]) {
        let f = self.scale.iter().map(|&s| input_scale * s).collect();
        (f, &self.bias)
    }
}

/// `x` (`[n, n, n, cin]`, all ≥ 0, as after a ReLU) as bytes in the layout
/// [`Int8Conv::run`] reads: every W row of `n` cubes between `pad` zero
/// cubes on each side (so that no tap along W is ever out of range).
/// byte = ⌊x / s + ½⌋ with s = max(x) / 255 (`range` narrow: max(x) / 127,
/// so every byte is ≤ 127: x / s ≤ 127 to within rounding, and + ½
/// truncates to 127). Returns the bytes (the first
/// `n²·(n + 2·pad)·cin` of `buffer`, which only grows: no zero fill per
/// call) and s (1 for an all-zero input). With `rows` (one flag per W row,
/// as [`Int8Conv::rows_read`] gives), only the flagged rows are written (the
/// others keep what the buffer held); s is the whole input's either way.
/// `max`, where the caller knows it, is max(x) (else it is computed).
/// AVX-512 where the path `isa` has it (the same bytes as the scalar loop).
pub(crate) fn quantize<'a>(
    isa: normalnet_isa::Isa,
    x: &[f32],
    n: usize,
    pad: usize,
    range: Int8Range,
    (rows, max): (Option<&[bool]>, Option<f32>),
    buffer: &'a mut Vec<u8>,
) -> (&'a [u8], f32) {
    let cin = x.len() / (n * n * n).max(1);
    assert_eq!(x.len(), n * n * n * cin, "input is not [n, n, n, cin]");
    let (row, padded) = (n * cin, (n + 2 * pad) * cin);
    let len = n * n * padded;
    if buffer.len() < len {
        buffer.resize(len, 0);
    }
    let out = &mut buffer[..len];
    let x86 = cfg!(target_arch = "x86_64");
    let (avx512, avx2) = (x86 && isa.has_avx512(), x86 && isa.has_avx2());
    let max = match (max, avx512) {
        (Some(max), _) => {
            debug_assert_eq!(max, x.iter().fold(f32::NEG_INFINITY, |m, &v| m.max(v)));
            max.max(0.0)
        }
        // SAFETY: the feature was detected.
        #[cfg(target_arch = "x86_64")]
        (None, true) => unsafe { max_avx512(x) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        (None, false) if avx2 => unsafe { max_avx2(x) },
        _ => x.iter().fold(0.0f32, |m, &v| m.max(v)),
    };
    let scale = if max > 0.0 {
        max / range.activation_max()
    } else {
        1.0
    };
    let inv = 1.0 / scale;
    let wanted = |r: usize| rows.is_none_or(|rows| rows[r]);
    for (_, (x, o)) in x
        .chunks_exact(row.max(1))
        .zip(out.chunks_exact_mut(padded.max(1)))
        .enumerate()
        .filter(|&(r, _)| wanted(r))
    {
        let (left, rest) = o.split_at_mut(pad * cin);
        let (middle, right) = rest.split_at_mut(row);
        left.fill(0);
        right.fill(0);
        match (avx512, avx2) {
            // SAFETY: the feature was detected.
            #[cfg(target_arch = "x86_64")]
            (true, _) => unsafe { bytes_avx512(x, inv, middle) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            (_, true) => unsafe { bytes_avx2(x, inv, middle) },
            _ => bytes_scalar(x, inv, middle),
        }
    }
    (out, scale)
}

fn bytes_scalar(x: &[f32], inv: f32, out: &mut [u8]) {
    for (o, &v) in out.iter_mut().zip(x) {
        *o = (v * inv + 0.5).min(255.0) as u8;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn max_avx512(x: &[f32]) -> f32 {
    use std::arch::x86_64::*;
    let chunks = x.chunks_exact(16);
    let tail = chunks.remainder();
    let mut m = _mm512_setzero_ps();
    for c in chunks {
        // SAFETY: 16 readable f32.
        m = _mm512_max_ps(m, unsafe { _mm512_loadu_ps(c.as_ptr()) });
    }
    tail.iter().fold(_mm512_reduce_max_ps(m), |m, &v| m.max(v))
}

/// As [`max_avx512`], 8 at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn max_avx2(x: &[f32]) -> f32 {
    use std::arch::x86_64::*;
    let chunks = x.chunks_exact(8);
    let tail = chunks.remainder();
    let mut m = _mm256_setzero_ps();
    for c in chunks {
        // SAFETY: 8 readable f32.
        m = _mm256_max_ps(m, unsafe { _mm256_loadu_ps(c.as_ptr()) });
    }
    let mut lanes = [0.0f32; 8];
    // SAFETY: 8 writable f32.
    unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), m) };
    lanes
        .into_iter()
        .chain(tail.iter().copied())
        .fold(0.0f32, f32::max)
}

/// As [`bytes_scalar`] (the same bytes: the same multiply, add and
/// truncation, saturated to 0 ..= 255 by the packs), 32 at a time, then 8
/// at a time (a row of 11 cubes of 16 channels is 5 · 32 + 2 · 8).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn bytes_avx2(x: &[f32], inv: f32, out: &mut [u8]) {
    use std::arch::x86_64::*;
    let (iv, half, top) = (
        _mm256_set1_ps(inv),
        _mm256_set1_ps(0.5),
        _mm256_set1_ps(255.0),
    );
    // 8 values to i32 (the scalar's multiply, add, clamp and truncation)
    let truncated = |v: __m256| {
        _mm256_cvttps_epi32(_mm256_min_ps(
            _mm256_add_ps(_mm256_mul_ps(v, iv), half),
            top,
        ))
    };
    // the packs interleave 128-bit lanes: dword order back to the input's
    let order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    let chunks = x.chunks_exact(32);
    let rest = chunks.remainder();
    let mut outs = out.chunks_exact_mut(32);
    for (c, o) in chunks.zip(&mut outs) {
        // SAFETY: 32 readable f32, 32 writable bytes.
        unsafe {
            let q: [__m256i; 4] =
                std::array::from_fn(|i| truncated(_mm256_loadu_ps(c.as_ptr().add(8 * i))));
            let words = (
                _mm256_packus_epi32(q[0], q[1]),
                _mm256_packus_epi32(q[2], q[3]),
            );
            let bytes = _mm256_packus_epi16(words.0, words.1);
            _mm256_storeu_si256(
                o.as_mut_ptr().cast(),
                _mm256_permutevar8x32_epi32(bytes, order),
            );
        }
    }
    let eights = rest.chunks_exact(8);
    let tail = eights.remainder();
    let mut rest_out = outs.into_remainder().chunks_exact_mut(8);
    for (c, o) in eights.zip(&mut rest_out) {
        // SAFETY: 8 readable f32, 8 writable bytes.
        unsafe {
            let q = truncated(_mm256_loadu_ps(c.as_ptr()));
            // bytes 0..4 of each 128-bit lane hold the lane's four values
            let words = _mm256_packus_epi32(q, q);
            let bytes = _mm256_permutevar8x32_epi32(_mm256_packus_epi16(words, words), order);
            _mm_storel_epi64(o.as_mut_ptr().cast(), _mm256_castsi256_si128(bytes));
        }
    }
    bytes_scalar(tail, inv, rest_out.into_remainder());
}

/// As [`bytes_scalar`] (the same bytes), 16 at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn bytes_avx512(x: &[f32], inv: f32, out: &mut [u8]) {
    use std::arch::x86_64::*;
    let chunks = x.chunks_exact(16);
    let tail = chunks.remainder();
    let (iv, half, top) = (
        _mm512_set1_ps(inv),
        _mm512_set1_ps(0.5),
        _mm512_set1_ps(255.0),
    );
    let mut outs = out.chunks_exact_mut(16);
    for (c, o) in chunks.zip(&mut outs) {
        // SAFETY: 16 readable f32, 16 writable bytes.
        unsafe {
            // (max with 0: a negative input saturates to 0 like the
            // scalar cast, not to 255 through the unsigned conversion)
            let v = _mm512_max_ps(
                _mm512_min_ps(
                    _mm512_add_ps(_mm512_mul_ps(_mm512_loadu_ps(c.as_ptr()), iv), half),
                    top,
                ),
                _mm512_setzero_ps(),
            );
            _mm_storeu_si128(
                o.as_mut_ptr().cast(),
                _mm512_cvtusepi32_epi8(_mm512_cvttps_epi32(v)),
            );
        }
    }
    bytes_scalar(tail, inv, outs.into_remainder());
}

/// The length of the next tile over `left` cubes, tiles of at most `max`:
/// as equal as they can be (13 cubes by at most 12: 7, then 6).
pub(crate) fn tile_len(left: usize, max: usize) -> usize {
    left.div_ceil(left.div_ceil(max))
}

/// Computes the i32 sums of `t` neighbouring output cubes of one W row into
/// `sums[..t]` (the function at index `t − 1` of the table).
#[cfg(target_arch = "x86_64")]
type TileFn<const V: usize> =
    unsafe fn(&Int8Conv, &[u8], usize, [usize; 3], &mut [[std::arch::x86_64::__m512i; V]]);

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[allow(clippy::too_many_arguments)]
fn dense_vnni<const V: usize>(
    c: &Int8Conv,
    input: &[u8],
    input_scale: f32,
    n: usize,
    out: &mut [f32],
    [accumulate, relu]: [bool; 2],
    region: Option<Region>,
    tiles: &[TileFn<V>],
) {
    use std::arch::x86_64::*;
    let (k, s, p, co) = (c.k, c.stride, c.pad, c.cout);
    debug_assert_eq!(co, 16 * V);
    let m = output_side(n, k, s, p);
    assert_eq!(out.len(), m * m * m * co);
    let mut factor = [[0.0f32; 16]; V];
    for (v, f) in factor.iter_mut().enumerate() {
        for (j, f) in f.iter_mut().enumerate() {
            *f = input_scale * c.scale[16 * v + j];
        }
    }
    // i32 sums of one output cube → f32 scale, bias, [residual], [ReLU]
    let finish = |sums: &[__m512i; V], dst: &mut [f32]| {
        for (v, &sum) in sums.iter().enumerate() {
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
    let mut sums = [[_mm512_setzero_si512(); V]; 12];
    assert!((1..=sums.len()).contains(&tiles.len()));
    for_each_tile(m, co, region, tiles.len(), out, |[od, oh, ow], t, out| {
        // SAFETY: the caller checked the features; `tile_sums` checks its
        // slices.
        unsafe { tiles[t - 1](c, input, n, [od, oh, ow], &mut sums) };
        let first = (od * m + oh) * m + ow;
        for (i, sum) in sums[..t].iter().enumerate() {
            let o = first + i;
            finish(sum, &mut out[o * co..o * co + co]);
        }
    });
}

/// Walks the output cubes of an `m³ × co` convolution output `out` as the
/// int8 kernels compute them: per W row, the cubes from the first to the
/// last one `region` asks for in tiles of at most `max_tile` neighbouring
/// cubes (`tile([od, oh, ow], t, out)` writes cubes `ow .. ow + t` of row
/// (`od`, `oh`)); every cube outside the region, in a tile or not, then
/// takes the background's value, if any (runs of cubes in one copy: a
/// library call per 64-byte cube cost more than the copy).
#[inline(always)]
pub(crate) fn for_each_tile(
    m: usize,
    co: usize,
    region: Option<Region>,
    max_tile: usize,
    out: &mut [f32],
    mut tile: impl FnMut([usize; 3], usize, &mut [f32]),
) {
    let background_run = |cubes: std::ops::Range<usize>, out: &mut [f32]| {
        if let Some(bg) = region.and_then(|r| r.background) {
            let at = cubes.start * co..cubes.end * co;
            out[at.clone()].copy_from_slice(&bg[at]);
        }
    };
    for od in 0..m {
        for oh in 0..m {
            let first = (od * m + oh) * m;
            // the cubes to compute (bit ow), the first and the last
            let bits = region.map_or(u64::MAX, |r| r.mask.row(od * m + oh));
            if bits == 0 {
                background_run(first..first + m, out);
                continue;
            }
            let (lo, hi) = match region {
                None => (0, m),
                Some(_) => (
                    bits.trailing_zeros() as usize,
                    64 - bits.leading_zeros() as usize,
                ),
            };
            background_run(first..first + lo, out);
            background_run(first + hi..first + m, out);
            let mut ow = lo;
            while ow < hi {
                let t = tile_len(hi - ow, max_tile);
                tile([od, oh, ow], t, out);
                // the tile's cubes outside the region (none without one)
                for w in (ow..ow + t).filter(|w| bits >> w & 1 == 0) {
                    background_run(first + w..first + w + 1, out);
                }
                ow += t;
            }
        }
    }
}

/// The i32 sums of the `T` output cubes `ow .. ow + T` of output row (`od`,
/// `oh`) into `sums[..T]`, `V` vectors of 16 channels each: for every tap
/// and input group, `V` weight loads feed `T · V` `vpdpbusd` (one input
/// broadcast per cube), `T · V` chains in flight. The input's W rows are
/// padded ([`quantize`]), so every W tap is in range; D and H taps out of
/// range are skipped.
///
/// # Safety
/// The CPU has AVX-512 F, BW and VNNI.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
unsafe fn tile_sums<const V: usize, const T: usize>(
    c: &Int8Conv,
    input: &[u8],
    n: usize,
    [od, oh, ow]: [usize; 3],
    sums: &mut [[std::arch::x86_64::__m512i; V]],
) {
    use std::arch::x86_64::*;
    let (k, s, p, cin, co) = (c.k, c.stride, c.pad, c.cin, c.cout);
    let groups = cin / 4;
    let padded = (n + 2 * c.layout_pad) * cin;
    let mut acc = [[_mm512_setzero_si512(); V]; T];
    for kd in taps(od, s, p, k, n) {
        let id = od * s + kd - p;
        for kh in taps(oh, s, p, k, n) {
            let ih = oh * s + kh - p;
            // position in the padded W row of output cube ow's tap kw:
            // ow·s + kw − p + layout_pad
            let start = (id * n + ih) * padded + (ow * s + c.layout_pad - p) * cin;
            let x = &input[start..start + ((T - 1) * s + k) * cin];
            let first = (kd * k + kh) * k;
            let wt = &c.w[first * cin * co..(first + k) * cin * co];
            // SAFETY (all reads): kw < k, g < groups, t < T, v < V: input
            // bytes (t·s + kw)·cin + 4g + 4 ≤ ((T − 1)·s + k)·cin, weight
            // bytes ((kw·groups + g)·co + 16v)·4 + 64 ≤ k·cin·co.
            unsafe {
                for kw in 0..k {
                    for g in 0..groups {
                        let wg = wt.as_ptr().add((kw * groups + g) * co * 4);
                        let wv: [__m512i; V] =
                            std::array::from_fn(|v| _mm512_loadu_si512(wg.add(64 * v).cast()));
                        let xg = x.as_ptr().add(kw * cin + 4 * g);
                        for (t, a) in acc.iter_mut().enumerate() {
                            let xv = _mm512_set1_epi32(
                                xg.add(t * s * cin).cast::<i32>().read_unaligned(),
                            );
                            for (a, &w) in a.iter_mut().zip(&wv) {
                                *a = _mm512_dpbusd_epi32(*a, xv, w);
                            }
                        }
                    }
                }
            }
        }
    }
    sums[..T].copy_from_slice(&acc);
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
        if !supported(normalnet_isa::Isa::detected()) {
            eprintln!("no AVX2 on this CPU: skipped");
            return;
        }
        for (cin, cout, stride, n) in [
            (16, 32, 2, 9),
            (32, 32, 1, 6),
            (32, 64, 2, 7),
            (64, 64, 1, 4),
        ] {
            for range in [Int8Range::Full, Int8Range::Narrow] {
                integer_convolution_near_f32(cin, cout, stride, n, range);
            }
        }
    }

    /// [`Int8Conv`] against its f32 convolution on ReLU-like inputs: within
    /// the quantization error (about 1 % of the output range with full
    /// ranges; half the steps each way narrow: 4 %).
    fn integer_convolution_near_f32(
        cin: usize,
        cout: usize,
        stride: usize,
        n: usize,
        range: Int8Range,
    ) {
        let f = conv(cin, cout, stride, (cin * cout + stride) as u32);
        let q = Int8Conv::new(&f, range).expect("layout fits");
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
            let mut buffer = Vec::new();
            let (xq, sx) = quantize(
                normalnet_isa::Isa::detected(),
                &x,
                n,
                q.input_pad(),
                q.range(),
                (None, None),
                &mut buffer,
            );
            let got = on_every_path(&q, xq, sx, n, &start, [accumulate, relu], None);
            let span = want.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let worst = want
                .iter()
                .zip(&got)
                .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
            // 8-bit inputs and weights: about 1 % of the output range
            let tolerance = match range {
                Int8Range::Full => 0.02,
                Int8Range::Narrow => 0.08,
            };
            assert!(
                worst < tolerance * span,
                "{range:?}: cin {cin} cout {cout}: worst {worst} of range {span}"
            );
            assert!(worst > 0.0, "quantization must show somewhere");
        }
    }

    /// The sums in plain integer arithmetic over the unpadded bytes, then the
    /// kernel's f32 steps (one fused multiply-add, residual, ReLU).
    #[allow(clippy::too_many_arguments)]
    fn reference(
        q: &Int8Conv,
        x: &[u8],
        scale: f32,
        n: usize,
        out: &mut [f32],
        accumulate: bool,
        region: Region,
    ) {
        let (k, s, p, cin, co) = (q.k, q.stride, q.pad, q.cin, q.cout);
        let m = output_side(n, k, s, p);
        for o in 0..m * m * m {
            let at = o * co..o * co + co;
            if !region.mask.contains(o) {
                out[at.clone()].copy_from_slice(&region.background.expect("bg")[at]);
                continue;
            }
            let (od, oh, ow) = (o / (m * m), o / m % m, o % m);
            for c in 0..co {
                let mut sum = 0i32;
                for kd in taps(od, s, p, k, n) {
                    for kh in taps(oh, s, p, k, n) {
                        for kw in taps(ow, s, p, k, n) {
                            let (id, ih, iw) = (od * s + kd - p, oh * s + kh - p, ow * s + kw - p);
                            let tap = (kd * k + kh) * k + kw;
                            for ci in 0..cin {
                                let w = q.w[((tap * (cin / 4) + ci / 4) * co + c) * 4 + ci % 4];
                                let v = x[((id * n + ih) * n + iw) * cin + ci];
                                sum += i32::from(w) * i32::from(v);
                            }
                        }
                    }
                }
                let mut y = (sum as f32).mul_add(scale * q.scale[c], q.bias[c]);
                if accumulate {
                    y += out[o * co + c];
                }
                out[o * co + c] = y.max(0.0);
            }
        }
    }

    /// `q` run on `input` over a copy of `start` on every int8 path this
    /// CPU runs (AVX2, AVX-512 VNNI), which must agree bit for bit; their
    /// output.
    fn on_every_path(
        q: &Int8Conv,
        input: &[u8],
        scale: f32,
        n: usize,
        start: &[f32],
        [accumulate, relu]: [bool; 2],
        region: Option<Region>,
    ) -> Vec<f32> {
        let mut outputs = normalnet_isa::Isa::all_here()
            .filter(|&isa| supported(isa))
            .map(|isa| {
                let mut out = start.to_vec();
                // SAFETY: the CPU runs the path, and it has int8 kernels.
                unsafe { q.run(isa, input, scale, n, &mut out, accumulate, relu, region) };
                (isa, out)
            });
        let (first, want) = outputs.next().expect("an int8 path");
        for (isa, got) in outputs {
            assert!(same_bits(&want, &got), "{isa} differs from {first}");
        }
        want
    }

    /// A deterministic stream of 24-bit numbers.
    fn numbers(seed: u32) -> impl FnMut() -> u32 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        }
    }

    /// Random bytes of an `[n, n, n, cin]` input (every byte `range`
    /// allows), and the same bytes with a zero cube before and after every
    /// W row (the layout `quantize` writes for padding 1).
    fn input_and_padded(
        n: usize,
        cin: usize,
        range: Int8Range,
        next: &mut impl FnMut() -> u32,
    ) -> (Vec<u8>, Vec<u8>) {
        let top = range.activation_max() as u32 + 1;
        let x: Vec<u8> = (0..n * n * n * cin).map(|_| (next() % top) as u8).collect();
        let padded = padded(&x, n, cin);
        (x, padded)
    }

    /// The bytes `x` of an `[n, n, n, cin]` input with a zero cube before
    /// and after every W row (the layout `quantize` writes for padding 1).
    fn padded(x: &[u8], n: usize, cin: usize) -> Vec<u8> {
        x.chunks_exact(n * cin)
            .flat_map(|row| [&[0; 256][..cin], row, &[0; 256][..cin]].concat())
            .collect()
    }

    /// Every output `want` and `got` agree bit for bit.
    fn same_bits(want: &[f32], got: &[f32]) -> bool {
        want.iter()
            .zip(got)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    }

    /// A 1³ shortcut reading the bytes quantized for a 3³ convolution (W
    /// rows between one zero cube each side) gives the exact integer sums.
    #[test]
    fn a_shortcut_reads_the_padded_layout_exactly() {
        if !supported(normalnet_isa::Isa::detected()) {
            eprintln!("no AVX2 on this CPU: skipped");
            return;
        }
        let mut next = numbers(9);
        for (cin, cout, stride, n) in [(16, 16, 1, 21), (16, 32, 2, 21), (32, 64, 2, 11)] {
            let weight = (0..cout * cin)
                .map(|i| ((i * 37 % 101) as f32 - 50.0) / 200.0)
                .collect();
            let c = ConvWeights {
                in_channels: cin,
                out_channels: cout,
                kernel: 1,
                stride,
                padding: 0,
                weight,
                bias: Some((0..cout).map(|i| i as f32 * 0.01).collect()),
            };
            let f = FoldedConv::new(&c, &BatchNormWeights::identity(cout));
            let q = Int8Conv::new(&f, Int8Range::Full)
                .expect("layout fits")
                .reading_layout(1);
            assert_eq!(q.input_pad(), 1);
            let m = output_side(n, 1, stride, 0);
            let (x, padded) = input_and_padded(n, cin, Int8Range::Full, &mut next);
            let mask: Vec<bool> = (0..m * m * m)
                .map(|o| o % 3 != 1 && !next().is_multiple_of(5))
                .collect();
            let background: Vec<f32> = (0..m * m * m * cout).map(|i| i as f32).collect();
            let cube_mask = CubeMask::from_flags(&mask, m);
            let region = Region {
                mask: &cube_mask,
                background: Some(&background),
            };
            let mut want = vec![0.0; m * m * m * cout];
            reference(&q, &x, 0.02, n, &mut want, false, region);
            let zeros = vec![0.0; m * m * m * cout];
            let got = on_every_path(&q, &padded, 0.02, n, &zeros, [false, true], Some(region));
            assert!(
                same_bits(&want, &got),
                "cin {cin} cout {cout} stride {stride}"
            );
        }
    }

    #[test]
    fn the_tiles_give_the_exact_integer_sums() {
        tiles_give_the_exact_integer_sums(Int8Range::Full);
    }

    /// Narrow bytes and weights: the same exact sums on every path (plain
    /// AVX2 summing two `vpmaddubsw` pairs in i16), with the extreme bytes
    /// and weights in the input.
    #[test]
    fn narrow_tiles_give_the_exact_integer_sums() {
        tiles_give_the_exact_integer_sums(Int8Range::Narrow);
    }

    fn tiles_give_the_exact_integer_sums(range: Int8Range) {
        if !supported(normalnet_isa::Isa::detected()) {
            eprintln!("no AVX2 on this CPU: skipped");
            return;
        }
        let mut next = numbers(3);
        // rows longer than the largest tile (16 → 30 cubes), odd lengths,
        // every output width the kernel has
        for (cin, cout, stride, n) in [
            (16, 16, 1, 30),
            (16, 16, 2, 21),
            (32, 32, 1, 11),
            (16, 32, 2, 11),
            (32, 64, 2, 6),
            (64, 64, 1, 7),
            (64, 128, 1, 4),
            (128, 256, 2, 5),
        ] {
            let f = conv(cin, cout, stride, cin as u32 + 5);
            let q = Int8Conv::new(&f, range).expect("layout fits");
            let wmax = range.weight_max() as i8;
            assert!(q.w.iter().all(|w| (-wmax..=wmax).contains(w)));
            assert!(q.w.contains(&wmax) || q.w.contains(&-wmax));
            let m = output_side(n, 3, stride, 1);
            let (mut x, _) = input_and_padded(n, cin, range, &mut next);
            // the largest byte in runs, where the sums are largest
            let top = range.activation_max() as u8;
            for (i, b) in x.iter_mut().enumerate() {
                if i % 97 < 24 {
                    *b = top;
                }
            }
            let padded = padded(&x, n, cin);
            // a mask with runs and gaps, rows with nothing to compute, and
            // a back half in D the kernel need not read
            let mask: Vec<bool> = (0..m * m * m)
                .map(|o| o / (m * m) < m / 2 && o / m % 3 != 1 && !next().is_multiple_of(4))
                .collect();
            let background: Vec<f32> = (0..m * m * m * cout).map(|i| i as f32).collect();
            let cube_mask = CubeMask::from_flags(&mask, m);
            let region = Region {
                mask: &cube_mask,
                background: Some(&background),
            };
            let start: Vec<f32> = (0..m * m * m * cout)
                .map(|i| (i % 5) as f32 - 2.0)
                .collect();
            for accumulate in [false, true] {
                let mut want = start.clone();
                reference(&q, &x, 0.01, n, &mut want, accumulate, region);
                let flags = [accumulate, true];
                let got = on_every_path(&q, &padded, 0.01, n, &start, flags, Some(region));
                assert!(
                    same_bits(&want, &got),
                    "{range:?}: cin {cin} cout {cout} stride {stride} n {n}"
                );
                // rows it does not read may hold anything
                let mut rows = vec![false; n * n];
                q.rows_read(&cube_mask, n, &mut rows);
                assert!(rows.contains(&false), "some rows unread");
                let mut garbled = padded.clone();
                for (bytes, _) in garbled
                    .chunks_exact_mut((n + 2) * cin)
                    .zip(&rows)
                    .filter(|(_, read)| !**read)
                {
                    bytes.fill(0xab);
                }
                let again = on_every_path(&q, &garbled, 0.01, n, &start, flags, Some(region));
                assert!(same_bits(&got, &again));
            }
        }
    }

    #[test]
    fn quantize_maps_zero_to_zero_the_maximum_to_255_rounds_and_pads_rows() {
        // n = 1, one channel: a row of one cube between two zero cubes
        let x = [0.013];
        let mut buffer = Vec::new();
        let (q, s) = quantize(
            normalnet_isa::Isa::detected(),
            &x,
            1,
            1,
            Int8Range::Full,
            (None, Some(0.013)),
            &mut buffer,
        );
        assert_eq!((q, s), (&[0, 255, 0][..], 0.013 / 255.0));
        // n = 2, three channels, rows padded by one cube
        let x: Vec<f32> = [0.0, 1.0, 0.5, 2.0, 0.013, 1.999]
            .into_iter()
            .cycle()
            .take(24)
            .collect();
        let (q, s) = quantize(
            normalnet_isa::Isa::detected(),
            &x,
            2,
            1,
            Int8Range::Full,
            (None, None),
            &mut buffer,
        );
        assert!((s - 2.0 / 255.0).abs() < 1e-9);
        assert_eq!(q.len(), 4 * 4 * 3);
        for (row, bytes) in x.chunks_exact(6).zip(q.chunks_exact(12)) {
            assert_eq!((&bytes[..3], &bytes[9..]), (&[0; 3][..], &[0; 3][..]));
            for (&v, &b) in row.iter().zip(&bytes[3..9]) {
                assert!((b as f32 * s - v).abs() <= 0.5001 * s, "{v} -> {b}");
            }
        }
        assert_eq!((q[3], q[6]), (0, 255));
        // a smaller input reuses the buffer: only its own bytes count
        assert_eq!(
            quantize(
                normalnet_isa::Isa::detected(),
                &[0.0; 8],
                2,
                0,
                Int8Range::Full,
                (None, None),
                &mut buffer
            ),
            (&[0u8; 8][..], 1.0)
        );
        // the vector path (where the CPU has it) gives the scalar loop's bytes
        let long: Vec<f32> = (0..1000)
            .map(|i| ((i * 7919) % 1013) as f32 * 0.037)
            .collect();
        let max = long.iter().fold(0.0f32, |m, &v| m.max(v));
        let mut scalar = vec![0; long.len()];
        bytes_scalar(&long, 1.0 / (max / 255.0), &mut scalar);
        // (every path: 1,000 values are 31 runs of 32 and a tail)
        for isa in normalnet_isa::Isa::all_here() {
            let (q, s) = quantize(
                isa,
                &long,
                10,
                0,
                Int8Range::Full,
                (None, None),
                &mut buffer,
            );
            assert_eq!((q, s), (&scalar[..], max / 255.0), "{isa}");
        }
        // narrow: the maximum to 127, every byte ≤ 127, on every path
        bytes_scalar(&long, 1.0 / (max / 127.0), &mut scalar);
        assert!(scalar.iter().all(|&b| b <= 127) && scalar.contains(&127));
        for isa in normalnet_isa::Isa::all_here() {
            let (q, s) = quantize(
                isa,
                &long,
                10,
                0,
                Int8Range::Narrow,
                (None, None),
                &mut buffer,
            );
            assert_eq!((q, s), (&scalar[..], max / 127.0), "{isa}");
        }
        // negative and not-a-number inputs saturate to 0 as the scalar cast does
        // 32-value chunks, 8-value chunks and a scalar tail
        let odd: Vec<f32> = (0..83)
            .map(|i| {
                if i % 3 == 0 {
                    -1.0
                } else if i % 7 == 0 {
                    f32::NAN
                } else {
                    i as f32
                }
            })
            .collect();
        let mut scalar = vec![0; odd.len()];
        bytes_scalar(&odd, 2.0, &mut scalar);
        for isa in normalnet_isa::Isa::all_here() {
            let mut got = vec![0; odd.len()];
            match isa {
                #[cfg(target_arch = "x86_64")]
                normalnet_isa::Isa::Avx2 => unsafe { bytes_avx2(&odd, 2.0, &mut got) },
                #[cfg(target_arch = "x86_64")]
                normalnet_isa::Isa::Avx512 => unsafe { bytes_avx512(&odd, 2.0, &mut got) },
                _ => bytes_scalar(&odd, 2.0, &mut got),
            }
            assert_eq!(got, scalar, "{isa}");
        }
    }
}
