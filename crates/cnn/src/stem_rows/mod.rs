//! The stem (5³, 3 → 16 channels, stride 1) as dense 1D convolutions along
//! grid rows, for AVX-512. The voxelizer turns every neighbourhood so that
//! its mean normal is the grid's H axis (`normalnet_voxel::voxelizer`), so
//! the surface sheet lies across a few H layers and only those W rows (fixed
//! D, H) hold occupied cubes. Instead of scattering each occupied cube into
//! its 125 outputs (a load, an add and a store per tap: `sparse_conv`), each
//! output row sums, over the ≤ 25 non-empty input rows that reach it, a 1D
//! convolution of that row with the 5 W taps — in blocks of [`CHUNK`] output
//! cubes whose 16 channels stay in registers, with the 15 weight vectors of
//! the (kd, kh) in registers too; a row whose occupied cubes are all far from
//! a block is skipped for it. Zeros inside a row are multiplied like any
//! value: on real grids (a noisy validation box, first iteration) a row holds
//! 5.9 occupied cubes of 21 and the blocks do 2.4× the scatter's
//! multiply-adds, at register speed: 1.26× faster than scatter + mask there,
//! 2.4× on the flat synthetic sheets of the layer benchmark. In an output
//! row, only the span of cubes its input rows' occupied cubes reach is
//! computed; the cubes outside it sum to zero and take the background.
//!
//! The result equals the scatter's up to f32 rounding (another summation
//! order); a test checks it. The int8 version ([`run_int8`]) reads each
//! output cube's W window as 15 packed bytes (four `vpdpbusd` per cube and
//! input row) in tiles of up to 12 cubes over that span.
//!
//! [`avx2`] has both stems for AVX2 (no AVX-512): the f32 stem in two
//! halves of 8 output channels (the same multiply-adds per lane in the same
//! order, so the same outputs as [`run`]), the int8 stem with `vpmaddwd` on
//! the bytes widened to i16 (exact i32 sums: the same outputs as
//! [`run_int8`], bit for bit).

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;

use crate::conv::{CubeMask, FoldedConv};
use crate::conv_int8::Int8Range;
use crate::sparse_conv::Occupied;

/// Output cubes per register block: 7 accumulators, 15 weights and the
/// broadcast input stay within the 32 vector registers.
pub(crate) const CHUNK: usize = 7;

const K: usize = 5;
const CIN: usize = 3;
const CO: usize = 16;
const EMPTY: u32 = u32::MAX;

/// The occupied cubes as zero-padded W rows, channels-last.
#[derive(Default)]
pub(crate) struct Rows {
    /// per input row `d·n + h`: its slot in `values`, or [`EMPTY`]
    slot: Vec<u32>,
    /// per input depth `d`: bit `h` set where row `d·n + h` is not empty
    heights: Vec<u64>,
    /// per non-empty row: `len` cubes × 3 channels, cube `w` at `w + pad`
    values: Vec<f32>,
    /// per non-empty row: bit `ow` set where output cube `ow` of an output
    /// row it feeds has an occupied cube of this row in its W window
    reaches: Vec<u64>,
    /// per non-empty row, for [`run_int8`] (after [`Rows::quantize`]):
    /// `len` cubes of three bytes, channel value / scale + 128 (empty and
    /// padding cubes 128), then [`SLACK`] bytes after the last row
    bytes: Vec<u8>,
    /// `bytes` widened to i16 for the AVX2 int8 stem (after
    /// [`Rows::widen`])
    wide: Vec<i16>,
    /// per occupied cube: its cube in the row buffers
    cubes: Vec<u32>,
    len: usize,
}

impl Rows {
    /// Lays out `occupied` (cubes of an `n³` grid) for a stem with padding
    /// `pad` and output side `m`; the f32 values (for [`run`]) only with
    /// `values` ([`run_int8`] needs only [`Rows::quantize`]'s bytes).
    pub(crate) fn build(&mut self, occupied: &Occupied, [n, pad, m]: [usize; 3], values: bool) {
        self.len = m.div_ceil(CHUNK) * CHUNK + K - 1;
        debug_assert!(n + pad <= self.len);
        self.slot.clear();
        self.slot.resize(n * n, EMPTY);
        self.heights.clear();
        self.heights.resize(n, 0);
        // (the cubes ascend, so their rows do: no division per cube)
        let mut used = 0u32;
        for (row, _) in rows_and_columns(&occupied.index, n) {
            if self.slot[row] == EMPTY {
                self.slot[row] = used;
                self.heights[row / n] |= 1 << (row % n);
                used += 1;
            }
        }
        self.values.clear();
        if values {
            self.values.resize(used as usize * self.len * CIN, 0.0);
        }
        self.reaches.clear();
        self.reaches.resize(used as usize, 0);
        self.cubes.clear();
        for (cube, (row, w)) in rows_and_columns(&occupied.index, n).enumerate() {
            // output ow sees inputs ow − pad .. ow − pad + K − 1
            let outputs = ((1u64 << K) - 1) << (w + pad) >> (K - 1);
            self.reaches[self.slot[row] as usize] |= outputs & output_bits(m);
            let at = self.slot[row] as usize * self.len + w + pad;
            self.cubes.push(at as u32);
            if values {
                let at = at * CIN;
                self.values[at..at + CIN]
                    .copy_from_slice(&occupied.values[cube * CIN..cube * CIN + CIN]);
            }
        }
    }

    /// Bytes of the rows in [`run_int8`]'s layout, without the slack.
    fn row_bytes(&self) -> usize {
        self.reaches.len() * self.len * CIN
    }

    /// The rows in bytes for [`run_int8`], from the `occupied` cubes
    /// [`Rows::build`] laid out; returns the scale s (value ≈ (byte − 128) ·
    /// s, s = largest |value| / 127, 1 for an all-zero grid; `range` narrow:
    /// (byte − 64) · s, s = largest |value| / 63).
    pub(crate) fn quantize(&mut self, occupied: &Occupied, range: Int8Range) -> f32 {
        assert_eq!(
            occupied.index.len(),
            self.cubes.len(),
            "rows built from these cubes"
        );
        let max = occupied.values.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let (top, zero) = range.stem_levels();
        let scale = if max > 0.0 { max / top as f32 } else { 1.0 };
        let inv = 1.0 / scale;
        let byte = |v: f32| round_half_even(v * inv).clamp(-top, top) + zero;
        // every cube zero (the byte 128, narrow 64) but the occupied ones
        self.bytes.clear();
        self.bytes.resize(self.row_bytes() + SLACK, zero as u8);
        for (&at, values) in self.cubes.iter().zip(occupied.values.chunks_exact(CIN)) {
            let at = at as usize * CIN;
            for (b, &v) in self.bytes[at..at + CIN].iter_mut().zip(values) {
                *b = byte(v) as u8;
            }
        }
        scale
    }

    /// [`Rows::quantize`]'s bytes (slack included) as i16, for
    /// [`avx2::run_int8`].
    pub(crate) fn widen(&mut self) {
        self.wide.clear();
        self.wide.extend(self.bytes.iter().map(|&b| i16::from(b)));
    }
}

/// The (W row, column) of each cube of an `n³` grid in `index` (ascending,
/// as [`Occupied`] holds them), the row counted up instead of divided out.
fn rows_and_columns(index: &[u32], n: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
    let mut row = 0;
    let mut row_start = 0;
    index.iter().map(move |&i| {
        let i = i as usize;
        debug_assert!(i >= row_start, "cubes in ascending order");
        while i >= row_start + n {
            row += 1;
            row_start += n;
        }
        (row, i - row_start)
    })
}

/// `x` rounded to the nearest integer, halves to even: one `cvtss2si` on
/// x86-64 (a library call through `f32::round`).
#[inline(always)]
fn round_half_even(x: f32) -> i32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvtss_si32, _mm_set_ss};
        // SAFETY: SSE is part of every x86-64 CPU. The default MXCSR
        // rounding: to nearest, ties to even.
        unsafe { _mm_cvtss_si32(_mm_set_ss(x)) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x.round_ties_even() as i32
    }
}

/// Bytes of input read past a row's last cube by [`run_int8`]'s last
/// window (its 16th byte, whose weight is zero).
const SLACK: usize = 4;

/// Bytes of one (kd, kh) row of weights in [`Int8Stem`]: the 15 (kw, ci)
/// pairs of a W window and a zero, as four i32 lanes of four bytes.
const WINDOW: usize = 16;

/// The stem's weights in signed bytes for [`run_int8`], one scale per output
/// channel. Per (kd, kh), the 15 weights of a W window (kw, ci) in the order
/// of the packed input bytes (`3·kw + ci`) and a zero, as four groups of four
/// bytes: `[kd·K + kh][group][co][4]`.
#[derive(Clone, Debug)]
pub(crate) struct Int8Stem {
    /// `[kd·K + kh][WINDOW / 4][co][4]`
    w: Vec<i8>,
    /// per output channel: f32 weight = byte · scale
    scale: Vec<f32>,
    /// per (kd, kh) and output channel: 128 (narrow: 64) · Σ over kw and
    /// channels of the bytes — what the offset of the inputs' zero byte
    /// adds to a sum over one row
    offset: Vec<i32>,
    bias: Vec<f32>,
    /// the same weights as i16 pairs for [`avx2::run_int8`]: per (kd, kh),
    /// the window's bytes `2g` and `2g + 1` for each output channel,
    /// `[kd·K + kh][WINDOW / 2][co][2]`
    w16: Vec<i16>,
    /// the integer ranges of its weights and input bytes
    range: Int8Range,
}

impl Int8Stem {
    /// Quantizes the stem `c` to `range`; `None` where [`run`] does not
    /// serve it.
    pub(crate) fn new(c: &FoldedConv, range: Int8Range) -> Option<Int8Stem> {
        if c.k != K || c.cin != CIN || c.cout != CO || c.stride != 1 {
            return None;
        }
        const { assert!(K * CIN < WINDOW) };
        let scale = crate::conv_int8::weight_scales(&c.w, c.cout, range);
        let (wmax, zero) = (range.weight_max(), range.stem_levels().1);
        let mut w = vec![0i8; K * K * WINDOW * CO];
        let mut offset = vec![0i32; K * K * CO];
        for tap in 0..K * K * K {
            let row = tap / K;
            for ci in 0..CIN {
                for co in 0..CO {
                    let q = (c.w[(tap * CIN + ci) * CO + co] / scale[co])
                        .round()
                        .clamp(-wmax, wmax) as i8;
                    w[weight_index(tap, ci, co)] = q;
                    offset[row * CO + co] += zero * i32::from(q);
                }
            }
        }
        let w16 = (0..K * K * WINDOW * CO)
            .map(|i| {
                let (row, g, co, half) = (
                    i / (WINDOW * CO),
                    i / (2 * CO) % (WINDOW / 2),
                    i / 2 % CO,
                    i % 2,
                );
                let byte = 2 * g + half;
                i16::from(w[((row * WINDOW / 4 + byte / 4) * CO + co) * 4 + byte % 4])
            })
            .collect();
        Some(Int8Stem {
            w,
            scale,
            offset,
            bias: c.b.clone(),
            w16,
            range,
        })
    }

    /// The integer ranges it was quantized to (its rows must be
    /// [`Rows::quantize`]d to the same).
    pub(crate) fn range(&self) -> Int8Range {
        self.range
    }

    /// The byte of the weight of tap `(kd·K + kh)·K + kw`, input channel
    /// `ci`, output channel `co`.
    #[cfg(test)]
    fn weight(&self, tap: usize, ci: usize, co: usize) -> i8 {
        self.w[weight_index(tap, ci, co)]
    }
}

/// Where [`Int8Stem`]'s `w` keeps the weight of tap `(kd·K + kh)·K + kw`,
/// input channel `ci`, output channel `co`: byte `3·kw + ci` of its (kd, kh)
/// row's window.
fn weight_index(tap: usize, ci: usize, co: usize) -> usize {
    let (row, byte) = (tap / K, CIN * (tap % K) + ci);
    ((row * WINDOW / 4 + byte / 4) * CO + co) * 4 + byte % 4
}

/// Bits `0..m` set.
fn output_bits(m: usize) -> u64 {
    if m == 64 { u64::MAX } else { (1u64 << m) - 1 }
}

/// Whether [`run`] serves this convolution on grids of side `n`.
pub(crate) fn serves(c: &FoldedConv, n: usize) -> bool {
    // bit sets of u64: every input cube's W window bits below 64
    c.k == K && c.cin == CIN && c.cout == CO && c.stride == 1 && c.pad < K && n + c.pad + K <= 64
}

/// The non-empty input rows that reach output row (`od`, `oh`) as (first
/// cube of the row in the row buffers, (kd, kh) tap row `kd·K + kh`, the
/// output cubes it reaches); returns all those cubes' bits.
#[inline(always)]
fn reaching_rows(
    rows: &Rows,
    n: usize,
    p: usize,
    (od, oh): (usize, usize),
    reach: &mut Vec<(usize, usize, u64)>,
) -> u64 {
    reach.clear();
    let mut reached = 0u64;
    // input depth id = od + kd − p, height ih = oh + kh − p: bit kh of
    // `heights[id] << p >> oh` (p < K and n + p < 64: no bit lost)
    for kd in 0..K {
        let Some(id) = (od + kd).checked_sub(p).filter(|&i| i < n) else {
            continue;
        };
        let mut taps = (rows.heights[id] << p >> oh) & ((1 << K) - 1);
        while taps != 0 {
            let kh = taps.trailing_zeros() as usize;
            taps &= taps - 1;
            let slot = rows.slot[id * n + oh + kh - p];
            debug_assert_ne!(slot, EMPTY);
            let outputs = rows.reaches[slot as usize];
            reached |= outputs;
            reach.push((slot as usize * rows.len, kd * K + kh, outputs));
        }
    }
    reached
}

/// The row loops both stems share: for every output row (od, oh) the input
/// rows that reach it and the span `lo..hi` of the output cubes they reach;
/// every cube outside the span (a row no input row reaches: all its cubes)
/// gets `background` (its sums are zero), and `span(lo, hi, reach, dst)`
/// computes cubes `lo..hi` of the row `dst`. With `near`, also the output
/// cubes whose window holds an occupied cube. Returns whether any cube got
/// the background.
#[inline(always)]
fn for_each_span(
    rows: &Rows,
    [n, p, m]: [usize; 3],
    out: &mut [f32],
    background: [f32; CO],
    mut near: Option<&mut CubeMask>,
    mut span: impl FnMut(usize, usize, &[(usize, usize, u64)], &mut [f32]),
) -> bool {
    assert!(out.len() == m * m * m * CO && rows.slot.len() == n * n);
    assert!(rows.len == m.div_ceil(CHUNK) * CHUNK + K - 1);
    if let Some(near) = near.as_deref_mut() {
        near.reset(m);
    }
    let mut any_background = false;
    // (first cube of the input row, its (kd, kh) tap row, the output cubes
    // it reaches)
    let mut reach: Vec<(usize, usize, u64)> = Vec::with_capacity(K * K);
    for od in 0..m {
        for oh in 0..m {
            let reached = reaching_rows(rows, n, p, (od, oh), &mut reach);
            let first = (od * m + oh) * m;
            let dst = &mut out[first * CO..(first + m) * CO];
            let (lo, hi) = match reached {
                0 => (0, 0),
                r => (r.trailing_zeros() as usize, 64 - r.leading_zeros() as usize),
            };
            if hi - lo < m {
                any_background = true;
                for cube in dst[..lo * CO].chunks_exact_mut(CO) {
                    cube.copy_from_slice(&background);
                }
                for cube in dst[hi * CO..].chunks_exact_mut(CO) {
                    cube.copy_from_slice(&background);
                }
            }
            if reached == 0 {
                continue;
            }
            if let Some(near) = near.as_deref_mut() {
                near.rows_mut()[od * m + oh] = reached;
            }
            span(lo, hi, &reach, dst);
        }
    }
    any_background
}

/// `max(bias, floor)` per output channel, with the ReLU's floor (0, or −∞
/// without it): the output of a cube no occupied cube reaches. The max as
/// `maxps` takes it: the floor unless the bias is greater.
fn background(bias: &[f32], relu: bool) -> [f32; CO] {
    let floor = if relu { 0.0 } else { f32::NEG_INFINITY };
    std::array::from_fn(|co| if bias[co] > floor { bias[co] } else { floor })
}

/// The ReLU's floor (0, or −∞ without it) and `max(bias, floor)` as an
/// array: the output of a cube no occupied cube reaches.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn floor_and_background(
    bias: std::arch::x86_64::__m512,
    relu: bool,
) -> (std::arch::x86_64::__m512, [f32; CO]) {
    use std::arch::x86_64::*;
    let floor = if relu {
        _mm512_setzero_ps()
    } else {
        _mm512_set1_ps(f32::NEG_INFINITY)
    };
    let mut out = [0.0f32; CO];
    // SAFETY: `out` holds 16 floats.
    unsafe { _mm512_storeu_ps(out.as_mut_ptr(), _mm512_max_ps(bias, floor)) };
    (floor, out)
}

/// `out = [relu](conv(grid))`, `out` `[m, m, m, 16]` channels-last, from the
/// rows of an `n³` grid built by [`Rows::build`] with this conv's padding;
/// with `near`, also the output cubes whose window holds an occupied cube
/// (len `m³`; what `FoldedConv::reach_mask` gives).
///
/// # Safety
/// The CPU must have AVX-512F, and `serves(c, n)` must hold.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn run(
    c: &FoldedConv,
    rows: &Rows,
    n: usize,
    out: &mut [f32],
    relu: bool,
    near: Option<&mut CubeMask>,
) {
    use std::arch::x86_64::*;
    let (p, m) = (c.pad, c.output_side(n));
    assert!(serves(c, n));
    // SAFETY: `serves` means 16 output channels, so 16 biases.
    let bias = unsafe { _mm512_loadu_ps(c.b.as_ptr()) };
    let (floor, background) = floor_and_background(bias, relu);
    let block = |c0: usize,
                 chunk: u64,
                 [lo, hi]: [usize; 2],
                 reach: &[(usize, usize, u64)],
                 dst: &mut [f32]| {
        let mut acc = [bias; CHUNK];
        // rows with no occupied cube near this block add only zeros
        for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & chunk != 0) {
            // SAFETY: `(tap_row + 1)·K·CIN·CO ≤ c.w.len()` (taps of one
            // (kd, kh)), and `(x0 + c0 + CHUNK + K − 1)·CIN ≤
            // rows.values.len()` (`c0 < m`, rows of `len` cubes).
            unsafe {
                let w = c.w.as_ptr().add(tap_row * K * CIN * CO);
                let wr: [[__m512; CIN]; K] = std::array::from_fn(|kw| {
                    std::array::from_fn(|ci| _mm512_loadu_ps(w.add((kw * CIN + ci) * CO)))
                });
                let x = rows.values.as_ptr().add((x0 + c0) * CIN);
                // output cube c0 + o reads padded inputs c0 + o + kw; input
                // j spelled out (a loop over it is not unrolled, and `acc`
                // would live on the stack)
                macro_rules! input {
                    ($($j:literal)*) => {$(
                        for ci in 0..CIN {
                            let v = _mm512_set1_ps(*x.add($j * CIN + ci));
                            for (kw, wk) in wr.iter().enumerate() {
                                if $j >= kw && $j - kw < CHUNK {
                                    acc[$j - kw] = _mm512_fmadd_ps(v, wk[ci], acc[$j - kw]);
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
                let cube = &mut dst[(c0 + o) * CO..(c0 + o + 1) * CO];
                // SAFETY: `cube` holds 16 floats.
                unsafe { _mm512_storeu_ps(cube.as_mut_ptr(), _mm512_max_ps(*a, floor)) };
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
    for_each_span(rows, [n, p, m], out, background, near, span);
}

/// As [`run`] with the stem's multiply-adds in 8-bit integers (AVX-512
/// VNNI: four input channels per `vpdpbusd` lane, so one instruction per
/// input cube and tap where f32 takes three FMAs), on rows quantized by
/// [`Rows::quantize`] with scale `input_scale`. The inputs are signed, so
/// they are offset by 128 into unsigned bytes and the offset's share of each
/// sum ([`Int8Stem`]'s `offset`, per tap row taken) is subtracted again: the
/// i32 sums are exact, the error is the rounding of inputs and weights.
/// Returns the largest value of `out`.
///
/// # Safety
/// The CPU must have AVX-512 F, BW and VNNI, and `serves(c, n)` must hold
/// for the stem `q` was made from.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
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
) -> f32 {
    use std::arch::x86_64::*;
    let m = crate::conv::output_side(n, K, 1, p);
    assert!(rows.len >= m + K - 1);
    assert!(
        rows.bytes.len() == rows.row_bytes() + SLACK,
        "rows not quantized"
    );
    // SAFETY: 16 output channels: 16 biases and scales.
    let (bias, scale) = unsafe {
        let s = _mm512_loadu_ps(q.scale.as_ptr());
        (
            _mm512_loadu_ps(q.bias.as_ptr()),
            _mm512_mul_ps(s, _mm512_set1_ps(input_scale)),
        )
    };
    let (floor, background) = floor_and_background(bias, relu);
    // the largest output, for the next layer's quantization
    let mut largest = _mm512_set1_ps(f32::NEG_INFINITY);
    let finish = Finish { scale, bias, floor };
    let span = |lo: usize, hi: usize, reach: &[(usize, usize, u64)], dst: &mut [f32]| {
        let mut c0 = lo;
        while c0 < hi {
            let t = crate::conv_int8::tile_len(hi - c0, 12);
            let cubes = &mut dst[c0 * CO..(c0 + t) * CO];
            macro_rules! tile {
                ($($t:literal)*) => {
                    match t {
                        // SAFETY: the caller checked the features;
                        // `stem_tile`'s reads stay inside `rows.bytes`
                        // (checked above: rows of `len ≥ m + K − 1` cubes,
                        // SLACK bytes after the last).
                        $($t => unsafe {
                            stem_tile::<$t>(q, rows, c0, reach, &finish, cubes, &mut largest)
                        },)*
                        _ => unreachable!("tiles of 1 to 12 cubes"),
                    }
                };
            }
            tile!(1 2 3 4 5 6 7 8 9 10 11 12);
            c0 += t;
        }
    };
    let any_background = for_each_span(rows, [n, p, m], out, background, near, span);
    let computed = _mm512_reduce_max_ps(largest);
    match any_background {
        true => background.into_iter().fold(computed, f32::max),
        false => computed,
    }
}

/// The int8 stem's last steps for a cube: its i32 sum (offset removed) to
/// f32 times the scale, plus the bias, then the ReLU's floor.
#[cfg(target_arch = "x86_64")]
struct Finish {
    scale: std::arch::x86_64::__m512,
    bias: std::arch::x86_64::__m512,
    floor: std::arch::x86_64::__m512,
}

/// The int8 stem's output cubes `c0 .. c0 + T` of one output row into
/// `out` (`T` cubes) from its reaching rows `reach` (those with an occupied
/// cube near the tile), and their maximum into `largest`: per row, the four
/// weight vectors of its (kd, kh) in registers, and for each cube its W
/// window of 15 packed bytes (and one more, whose weight is zero) as four
/// broadcast i32 — four `vpdpbusd` per cube and row, `T` chains in flight.
///
/// # Safety
/// The CPU has AVX-512 F, BW and VNNI; `rows` is quantized, and `c0 + T +
/// K − 1 ≤ rows.len`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
unsafe fn stem_tile<const T: usize>(
    q: &Int8Stem,
    rows: &Rows,
    c0: usize,
    reach: &[(usize, usize, u64)],
    finish: &Finish,
    out: &mut [f32],
    largest: &mut std::arch::x86_64::__m512,
) {
    use std::arch::x86_64::*;
    const { assert!(T <= 12) };
    debug_assert!(c0 + T + K - 1 <= rows.len && out.len() == T * CO);
    let tile = ((1u64 << T) - 1) << c0;
    let mut acc = [_mm512_setzero_si512(); T];
    let mut offset = _mm512_setzero_si512();
    // rows with no occupied cube near this tile add only zeros
    for &(x0, tap_row, _) in reach.iter().filter(|r| r.2 & tile != 0) {
        // SAFETY: `(tap_row + 1)·WINDOW·CO ≤ q.w.len()` and `(tap_row +
        // 1)·CO ≤ q.offset.len()` (one (kd, kh)); cube c0 + o's window
        // reads bytes 3·(x0 + c0 + o) .. + 16 ≤ 3·(x0 + len) + SLACK, inside
        // `rows.bytes` (`c0 + T + K − 1 ≤ len`).
        unsafe {
            let w = q.w.as_ptr().add(tap_row * WINDOW * CO);
            let wv: [__m512i; WINDOW / 4] =
                std::array::from_fn(|g| _mm512_loadu_si512(w.add(g * CO * 4).cast()));
            offset = _mm512_add_epi32(
                offset,
                _mm512_loadu_si512(q.offset.as_ptr().add(tap_row * CO).cast()),
            );
            let x = rows.bytes.as_ptr().add(CIN * (x0 + c0));
            for (o, a) in acc.iter_mut().enumerate() {
                for (g, &w) in wv.iter().enumerate() {
                    let v = x.add(CIN * o + 4 * g).cast::<i32>().read_unaligned();
                    *a = _mm512_dpbusd_epi32(*a, _mm512_set1_epi32(v), w);
                }
            }
        }
    }
    let mut top = *largest;
    for (a, cube) in acc.into_iter().zip(out.chunks_exact_mut(CO)) {
        let sum = _mm512_cvtepi32_ps(_mm512_sub_epi32(a, offset));
        let v = _mm512_max_ps(
            _mm512_fmadd_ps(sum, finish.scale, finish.bias),
            finish.floor,
        );
        top = _mm512_max_ps(top, v);
        // SAFETY: `cube` holds 16 floats.
        unsafe { _mm512_storeu_ps(cube.as_mut_ptr(), v) };
    }
    *largest = top;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conv::Level;
    use crate::weights::{BatchNormWeights, ConvWeights};

    /// A random stem and a grid of side `n` with a sheet, scattered cubes
    /// and cubes at the borders, as occupied cubes and as rows (with the
    /// stem's output side).
    fn stem_and_grid(n: usize) -> (FoldedConv, Occupied, Rows, usize) {
        let mut state = 5u32 + n as u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let conv = ConvWeights {
            in_channels: 3,
            out_channels: 16,
            kernel: 5,
            stride: 1,
            padding: 2,
            weight: (0..16 * 3 * 125).map(|_| next()).collect(),
            bias: Some((0..16).map(|_| next()).collect()),
        };
        let c = FoldedConv::new(&conv, &BatchNormWeights::identity(16));
        let cubes = n * n * n;
        let mut grid = vec![0.0f32; 3 * cubes];
        for i in 0..cubes {
            let (h, w) = ((i / n) % n, i % n);
            if h == n / 2 || i % 11 == 0 || i == cubes - 1 || (h == 0 && w == n - 1) {
                for ch in 0..3 {
                    grid[ch * cubes + i] = next();
                }
            }
        }
        let mut occ = Occupied::default();
        occ.gather(&grid, 3);
        let m = c.output_side(n);
        let mut rows = Rows::default();
        rows.build(&occ, [n, c.pad, m], true);
        (c, occ, rows, m)
    }

    /// Sides around multiples of CHUNK.
    const SIDES: [usize; 4] = [6, 7, 9, 15];

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn rows_equal_the_scatter() {
        if !normalnet_isa::Isa::detected().has_avx512() {
            eprintln!("skipped: no AVX-512F on this CPU");
            return;
        }
        for n in SIDES {
            let (c, occ, rows, m) = stem_and_grid(n);
            let mut want_near = CubeMask::default();
            c.reach_mask(&occ, n, &mut want_near);
            for relu in [false, true] {
                // the scatter of the occupied cubes (its own test: against
                // the scatter over all cubes; the network against f64)
                let mut want = vec![f32::NAN; m * m * m * 16];
                c.run_sparse(Level::Scalar, &occ, n, &mut want, relu);
                let mut got = vec![f32::NAN; m * m * m * 16];
                // a mask of another grid, all set: reset by the stem
                let mut near = CubeMask::from_flags(&[true; 8], 2);
                // SAFETY: AVX-512F detected above; `serves` holds.
                unsafe { run(&c, &rows, n, &mut got, relu, Some(&mut near)) };
                assert_eq!(near, want_near, "n {n}: near cubes");
                for (g, w) in got.iter().zip(&want) {
                    assert!((g - w).abs() < 1e-5, "n {n}: {g} vs {w}");
                }
            }
        }
    }

    /// The int8 stem computes exactly the f32 stem of its rounded inputs and
    /// weights (up to f32 rounding), and is near the f32 stem itself.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn int8_rows_equal_the_rows_of_the_rounded_values() {
        if !normalnet_isa::Isa::detected().has_vnni() {
            eprintln!("skipped: no AVX-512 VNNI on this CPU");
            return;
        }
        for (n, range) in SIDES
            .into_iter()
            .flat_map(|n| [(n, Int8Range::Full), (n, Int8Range::Narrow)])
        {
            let (c, occ, mut rows, m) = stem_and_grid(n);
            let s = rows.quantize(&occ, range);
            let q = Int8Stem::new(&c, range).expect("a 3 → 16 stem");
            // the values the bytes stand for
            let mut rounded = c.clone();
            for (r, w) in rounded.w.iter_mut().enumerate() {
                let (tap, ci, co) = (r / (CIN * CO), r / CO % CIN, r % CO);
                *w = f32::from(q.weight(tap, ci, co)) * q.scale[co];
            }
            let mut rounded_occ = Occupied {
                index: occ.index.clone(),
                values: occ.values.clone(),
            };
            for v in &mut rounded_occ.values {
                *v = (*v / s).round() * s;
            }
            let mut rounded_rows = Rows::default();
            rounded_rows.build(&rounded_occ, [n, c.pad, m], true);
            for relu in [false, true] {
                let mut want = vec![f32::NAN; m * m * m * 16];
                let mut exact = vec![f32::NAN; m * m * m * 16];
                let mut got = vec![f32::NAN; m * m * m * 16];
                let mut want_near = CubeMask::default();
                let mut near = CubeMask::from_flags(&[true; 8], 2);
                // SAFETY: VNNI (with F and BW) detected above; `serves` holds.
                unsafe {
                    run(
                        &rounded,
                        &rounded_rows,
                        n,
                        &mut want,
                        relu,
                        Some(&mut want_near),
                    );
                    run(&c, &rows, n, &mut exact, relu, None);
                    run_int8(&q, c.pad, &rows, s, n, &mut got, relu, Some(&mut near));
                }
                assert_eq!(near, want_near, "n {n}: near cubes");
                let mut worst = 0.0f32;
                for ((g, w), e) in got.iter().zip(&want).zip(&exact) {
                    assert!((g - w).abs() < 1e-5, "n {n}: {g} vs {w}");
                    worst = worst.max((g - e).abs());
                }
                // inputs in ±0.5, weights in ±0.5, up to 375 products
                // (narrow: steps twice as coarse each way)
                let bound = match range {
                    Int8Range::Full => 0.05,
                    Int8Range::Narrow => 0.2,
                };
                assert!(
                    worst > 0.0 && worst < bound,
                    "{range:?}, n {n}: int8 vs f32 {worst}"
                );
            }
        }
    }

    /// The AVX2 f32 stem does per lane what the AVX-512 one does: equal to
    /// it bit for bit, and to the scatter up to f32 rounding.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn avx2_rows_equal_the_avx512_rows_and_the_scatter() {
        let isa = normalnet_isa::Isa::detected();
        if !isa.has_avx2() {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        }
        for n in SIDES {
            let (c, occ, rows, m) = stem_and_grid(n);
            let mut want_near = CubeMask::default();
            c.reach_mask(&occ, n, &mut want_near);
            for relu in [false, true] {
                let mut want = vec![f32::NAN; m * m * m * 16];
                c.run_sparse(Level::Scalar, &occ, n, &mut want, relu);
                let mut got = vec![f32::NAN; m * m * m * 16];
                let mut near = CubeMask::from_flags(&[true; 8], 2);
                // SAFETY: AVX2 and FMA detected above; `serves` holds.
                unsafe { avx2::run(&c, &rows, n, &mut got, relu, Some(&mut near)) };
                assert_eq!(near, want_near, "n {n}: near cubes");
                for (g, w) in got.iter().zip(&want) {
                    assert!((g - w).abs() < 1e-5, "n {n}: {g} vs {w}");
                }
                if isa.has_avx512() {
                    let mut wide = vec![f32::NAN; m * m * m * 16];
                    // SAFETY: AVX-512F detected.
                    unsafe { run(&c, &rows, n, &mut wide, relu, None) };
                    assert!(
                        got.iter()
                            .zip(&wide)
                            .all(|(g, w)| g.to_bits() == w.to_bits()),
                        "n {n}: AVX2 and AVX-512 rows differ"
                    );
                }
            }
        }
    }

    /// The int8 stem on AVX2 gives the exact integer sums: every output
    /// equals the scalar computation from the bytes (i32 sums, one fused
    /// multiply-add, the floor) bit for bit, and so VNNI's where the CPU
    /// has it; its largest output is the largest of `out`.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn int8_rows_on_avx2_give_the_exact_integer_sums() {
        int8_rows_on_avx2_exact(Int8Range::Full);
    }

    /// As above for a narrow stem (plain AVX2 on the bytes with
    /// `vpmaddubsw`): the same exact sums on every path.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn narrow_int8_rows_on_avx2_give_the_exact_integer_sums() {
        int8_rows_on_avx2_exact(Int8Range::Narrow);
    }

    #[cfg(target_arch = "x86_64")]
    fn int8_rows_on_avx2_exact(range: Int8Range) {
        let isa = normalnet_isa::Isa::detected();
        if !isa.has_avx2() {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        }
        let zero = range.stem_levels().1;
        for n in SIDES {
            let (c, occ, mut rows, m) = stem_and_grid(n);
            let s = rows.quantize(&occ, range);
            if range == Int8Range::Full {
                rows.widen();
            }
            let q = Int8Stem::new(&c, range).expect("a 3 → 16 stem");
            let wmax = range.weight_max() as i8;
            assert!(q.w.iter().all(|w| (-wmax..=wmax).contains(w)));
            let top = 2 * zero - 1;
            assert!(
                rows.bytes
                    .iter()
                    .all(|&b| (1..=top).contains(&i32::from(b)))
            );
            for relu in [false, true] {
                let floor = if relu { 0.0 } else { f32::NEG_INFINITY };
                let mut want = vec![f32::NAN; m * m * m * 16];
                for (cube, out) in want.chunks_exact_mut(CO).enumerate() {
                    let (od, oh, ow) = (cube / (m * m), cube / m % m, cube % m);
                    let mut sums = [0i32; CO];
                    for kd in 0..K {
                        for kh in 0..K {
                            let (Some(id), Some(ih)) =
                                ((od + kd).checked_sub(c.pad), (oh + kh).checked_sub(c.pad))
                            else {
                                continue;
                            };
                            if id >= n || ih >= n || rows.slot[id * n + ih] == EMPTY {
                                continue;
                            }
                            let x0 = rows.slot[id * n + ih] as usize * rows.len;
                            for kw in 0..K {
                                for ci in 0..CIN {
                                    let b = i32::from(rows.bytes[(x0 + ow + kw) * CIN + ci]);
                                    for (co, sum) in sums.iter_mut().enumerate() {
                                        let tap = (kd * K + kh) * K + kw;
                                        *sum += (b - zero) * i32::from(q.weight(tap, ci, co));
                                    }
                                }
                            }
                        }
                    }
                    for (co, o) in out.iter_mut().enumerate() {
                        let v = (sums[co] as f32).mul_add(q.scale[co] * s, q.bias[co]);
                        *o = if v > floor { v } else { floor };
                    }
                }
                let mut got = vec![f32::NAN; m * m * m * 16];
                let mut want_near = CubeMask::default();
                c.reach_mask(&occ, n, &mut want_near);
                let mut near = CubeMask::from_flags(&[true; 8], 2);
                // SAFETY: AVX2 and FMA detected above; `serves` holds.
                let largest = unsafe {
                    avx2::run_int8(
                        &q,
                        c.pad,
                        &rows,
                        s,
                        n,
                        &mut got,
                        relu,
                        Some(&mut near),
                        false,
                    )
                };
                assert_eq!(near, want_near, "n {n}: near cubes");
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(g.to_bits(), w.to_bits(), "n {n}: {g} vs {w}");
                }
                assert_eq!(
                    largest,
                    got.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b))
                );
                if normalnet_isa::Isa::AvxVnni.runs_here() {
                    let mut ymm = vec![f32::NAN; m * m * m * 16];
                    // SAFETY: AVX-VNNI (with AVX2 and FMA) detected.
                    let top = unsafe {
                        avx2::run_int8(&q, c.pad, &rows, s, n, &mut ymm, relu, None, true)
                    };
                    assert!(
                        got.iter()
                            .zip(&ymm)
                            .all(|(g, v)| g.to_bits() == v.to_bits())
                    );
                    assert_eq!(top, largest);
                }
                if isa.has_vnni() {
                    let mut vnni = vec![f32::NAN; m * m * m * 16];
                    // SAFETY: VNNI (with F and BW) detected.
                    let top = unsafe { run_int8(&q, c.pad, &rows, s, n, &mut vnni, relu, None) };
                    assert!(
                        got.iter()
                            .zip(&vnni)
                            .all(|(g, v)| g.to_bits() == v.to_bits())
                    );
                    assert_eq!(top, largest);
                }
            }
        }
    }
}
