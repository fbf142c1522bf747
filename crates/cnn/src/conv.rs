//! Dense 3D convolution, channels-last, batch norm folded in: the kernel of
//! the residual blocks. The output channels of one output cube are held in
//! registers (`[f32; CO]`, CO a compile-time constant), so each multiply-add
//! costs one weight load; the same code is compiled for AVX-512, AVX2+FMA and
//! plain x86-64 and picked at run time.

use crate::weights::{BatchNormWeights, ConvWeights};

/// Instruction set the f32 kernels were compiled for: the process's path
/// ([`normalnet_isa::active`], `NORMALNET_ISA` or the best the CPU runs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Level {
    Avx512,
    Avx2,
    Scalar,
}

impl Level {
    pub(crate) fn detect() -> Level {
        Level::of(normalnet_isa::active())
    }

    /// The f32 kernels of a path (AVX-512 with and without VNNI share them).
    pub(crate) fn of(isa: normalnet_isa::Isa) -> Level {
        if isa.has_avx512() {
            Level::Avx512
        } else if isa.has_avx2() {
            Level::Avx2
        } else {
            Level::Scalar
        }
    }
}

/// Multiply-add: fused where the target has FMA, plain otherwise (a fused
/// `mul_add` without hardware FMA is a slow library call).
pub(crate) trait MulAdd {
    fn mul_add(a: f32, b: f32, c: f32) -> f32;
}

/// Hardware FMA.
pub(crate) struct Fused;
/// Separate multiply and add.
pub(crate) struct Plain;

impl MulAdd for Fused {
    #[inline(always)]
    fn mul_add(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

impl MulAdd for Plain {
    #[inline(always)]
    fn mul_add(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

/// A set of cubes of a `side³` grid (`side ≤ 64`): one bit set per W row
/// (row `d·side + h`, bit `w`), so that a row's cubes are tested, spanned
/// and dilated with a few word operations.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CubeMask {
    side: usize,
    rows: Vec<u64>,
}

impl CubeMask {
    /// Largest grid side a mask holds.
    pub(crate) const MAX_SIDE: usize = 64;

    /// Empties the mask for a `side³` grid.
    pub(crate) fn reset(&mut self, side: usize) {
        assert!(
            side <= Self::MAX_SIDE,
            "grid side {side} over {}",
            Self::MAX_SIDE
        );
        self.side = side;
        self.rows.clear();
        self.rows.resize(side * side, 0);
    }

    /// The cubes flagged in `flags` (len `side³`).
    #[cfg(test)]
    pub(crate) fn from_flags(flags: &[bool], side: usize) -> CubeMask {
        assert_eq!(flags.len(), side.pow(3));
        let mut mask = CubeMask::default();
        mask.reset(side);
        for (row, f) in mask.rows.iter_mut().zip(flags.chunks_exact(side)) {
            *row = bits_of(f);
        }
        mask
    }

    /// One flag per cube.
    #[cfg(test)]
    pub(crate) fn to_flags(&self) -> Vec<bool> {
        let side = self.side;
        (0..side.pow(3)).map(|o| self.contains(o)).collect()
    }

    /// The grid side.
    pub(crate) fn side(&self) -> usize {
        self.side
    }

    /// Whether cube `o` (`(d·side + h)·side + w`) is in the set.
    #[inline(always)]
    pub(crate) fn contains(&self, o: usize) -> bool {
        self.rows[o / self.side] >> (o % self.side) & 1 == 1
    }

    /// The bits of W row `d·side + h`.
    #[inline(always)]
    pub(crate) fn row(&self, row: usize) -> u64 {
        self.rows[row]
    }

    /// The W rows' bits, to set.
    pub(crate) fn rows_mut(&mut self) -> &mut [u64] {
        &mut self.rows
    }

    /// Adds the cubes of `other` (same side).
    pub(crate) fn union_with(&mut self, other: &CubeMask) {
        assert_eq!(self.side, other.side);
        for (a, b) in self.rows.iter_mut().zip(&other.rows) {
            *a |= b;
        }
    }
}

/// Which output cubes to compute: the others are copied from `background`
/// (when given) or left as they are.
#[derive(Clone, Copy)]
pub(crate) struct Region<'a> {
    /// the output cubes to compute
    pub mask: &'a CubeMask,
    /// `[m, m, m, cout]`: the value of every cube not computed
    pub background: Option<&'a [f32]>,
}

/// Channel counts the kernels are compiled for.
pub(crate) const SUPPORTED_CHANNELS: [usize; 6] = [8, 16, 32, 64, 128, 256];

/// A convolution with batch norm folded in, weights reordered to
/// `[k³][in][out]` (tap-major, output channels innermost).
#[derive(Clone, Debug)]
pub(crate) struct FoldedConv {
    pub w: Vec<f32>,
    pub b: Vec<f32>,
    pub cin: usize,
    pub cout: usize,
    pub k: usize,
    pub stride: usize,
    pub pad: usize,
}

impl FoldedConv {
    /// Folds `bn(conv(x))` into one convolution `conv'(x)`.
    pub(crate) fn new(c: &ConvWeights, bn: &BatchNormWeights) -> FoldedConv {
        let (scale, shift) = bn.affine();
        let k3 = c.kernel * c.kernel * c.kernel;
        let (cin, cout) = (c.in_channels, c.out_channels);
        let mut w = vec![0.0f32; k3 * cin * cout];
        for co in 0..cout {
            for ci in 0..cin {
                for tap in 0..k3 {
                    w[(tap * cin + ci) * cout + co] =
                        c.weight[(co * cin + ci) * k3 + tap] * scale[co];
                }
            }
        }
        let b = (0..cout)
            .map(|co| c.bias.as_ref().map_or(0.0, |b| b[co]) * scale[co] + shift[co])
            .collect();
        FoldedConv {
            w,
            b,
            cin,
            cout,
            k: c.kernel,
            stride: c.stride,
            pad: c.padding,
        }
    }

    /// Output side for an input of side `n`.
    pub(crate) fn output_side(&self, n: usize) -> usize {
        output_side(n, self.k, self.stride, self.pad)
    }

    /// `out = [relu](conv(input) [+ out])`.
    ///
    /// `input`: `[n, n, n, cin]` channels-last; `out`: `[m, m, m, cout]` with
    /// `m = output_side(n)`. With `accumulate`, the convolution is added to
    /// what `out` holds (the residual sum).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run(
        &self,
        level: Level,
        input: &[f32],
        n: usize,
        out: &mut [f32],
        accumulate: bool,
        relu: bool,
        region: Option<Region>,
    ) {
        let m = self.output_side(n);
        debug_assert_eq!(input.len(), n * n * n * self.cin);
        debug_assert_eq!(out.len(), m * m * m * self.cout);
        #[cfg(target_arch = "x86_64")]
        if self.k == 1 && self.pad == 0 && level == Level::Avx512 {
            // SAFETY: `Level::detect` found AVX-512F; 1³, no padding, and
            // `B · 16` output channels.
            let (a, r) = (accumulate, relu);
            match self.cout {
                16 => {
                    return unsafe { pointwise_avx512::<1>(self, input, n, out, m, a, r, region) };
                }
                32 => {
                    return unsafe { pointwise_avx512::<2>(self, input, n, out, m, a, r, region) };
                }
                64 => {
                    return unsafe { pointwise_avx512::<4>(self, input, n, out, m, a, r, region) };
                }
                _ => {}
            }
        }
        // S independent accumulators per output cube hide the FMA latency:
        // about eight vector chains in flight whatever the channel count.
        macro_rules! go {
            ($co:literal, $s:literal) => {
                match level {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `Level::detect` found the features at run time.
                    Level::Avx512 => unsafe {
                        dense_avx512::<$co, $s>(self, input, n, out, m, accumulate, relu, region)
                    },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: as above.
                    Level::Avx2 => unsafe {
                        dense_avx2::<$co, $s>(self, input, n, out, m, accumulate, relu, region)
                    },
                    _ => dense::<$co, $s, Plain>(self, input, n, out, m, accumulate, relu, region),
                }
            };
        }
        match self.cout {
            8 => go!(8, 8),
            16 => go!(16, 8),
            32 => go!(32, 4),
            64 => go!(64, 2),
            128 => go!(128, 1),
            256 => go!(256, 1),
            c => unreachable!("channel count {c} rejected by Cnn::new"),
        }
    }
}

impl FoldedConv {
    /// Output cubes whose input window holds a cube of `mask_in` (an `n³`
    /// input), as a mask of the `m³` output: an output row ORs the ≤ k²
    /// input rows of its (d, h) window, then each output cube tests its W
    /// window.
    pub(crate) fn window_mask(&self, mask_in: &CubeMask, out: &mut CubeMask) {
        let (k, s, p) = (self.k, self.stride, self.pad);
        let n = mask_in.side();
        let m = self.output_side(n);
        out.reset(m);
        if s == 1 {
            return self.window_mask_stride_1(mask_in, out);
        }
        // per output cube ow, the bits of its W window (stride 2 packs
        // them with bit operations instead)
        let mut windows = [0u64; CubeMask::MAX_SIDE];
        if s != 2 {
            for (ow, w) in windows[..m].iter_mut().enumerate() {
                *w = taps(ow, s, p, k, n).fold(0, |bits, kw| bits | 1 << (ow * s + kw - p));
            }
        }
        let windows_of_m = if m == 64 { u64::MAX } else { (1u64 << m) - 1 };
        for od in 0..m {
            for oh in 0..m {
                let mut any = 0u64;
                for kd in taps(od, s, p, k, n) {
                    for kh in taps(oh, s, p, k, n) {
                        any |= mask_in.row((od * s + kd - p) * n + oh * s + kh - p);
                    }
                }
                out.rows[od * m + oh] = match s {
                    2 => stride_2_row(any, k, p) & windows_of_m,
                    _ => windows[..m]
                        .iter()
                        .enumerate()
                        .fold(0, |bits, (ow, &w)| bits | u64::from(any & w != 0) << ow),
                };
            }
        }
    }

    /// [`Self::window_mask`] at stride 1 (output `o` sees inputs `o − p ..=
    /// o − p + k − 1` on every axis), one axis at a time: rows ORed along
    /// H, then along D, then each row's bits shifted along W.
    fn window_mask_stride_1(&self, mask_in: &CubeMask, out: &mut CubeMask) {
        let (k, p) = (self.k, self.pad);
        let (n, m) = (mask_in.side(), out.side());
        // output rows oh of every input depth: ORs of input rows oh − p + kh
        let mut along_h = vec![0u64; n * m];
        for (id, dst) in along_h.chunks_exact_mut(m).enumerate() {
            let src = &mask_in.rows[id * n..(id + 1) * n];
            for kh in 0..k {
                // input row ih = oh + kh − p in 0..n
                let first = p.saturating_sub(kh);
                let last = (n + p).saturating_sub(kh).min(m);
                for oh in first..last {
                    dst[oh] |= src[oh + kh - p];
                }
            }
        }
        for od in 0..m {
            let dst = &mut out.rows[od * m..(od + 1) * m];
            for kd in 0..k {
                let Some(id) = (od + kd).checked_sub(p).filter(|&id| id < n) else {
                    continue;
                };
                for (d, &h) in dst.iter_mut().zip(&along_h[id * m..(id + 1) * m]) {
                    *d |= h;
                }
            }
            // output ow sees input bits ow − p + kw: shift by p − kw
            for row in dst.iter_mut() {
                let any = *row;
                let mut bits = 0u64;
                for kw in 0..k {
                    bits |= if kw > p {
                        any >> (kw - p)
                    } else {
                        any << (p - kw)
                    };
                }
                *row = bits & (u64::MAX >> (64 - m));
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[allow(clippy::too_many_arguments)]
fn dense_avx512<const CO: usize, const S: usize>(
    c: &FoldedConv,
    input: &[f32],
    n: usize,
    out: &mut [f32],
    m: usize,
    acc: bool,
    relu: bool,
    region: Option<Region>,
) {
    dense::<CO, S, Fused>(c, input, n, out, m, acc, relu, region)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
fn dense_avx2<const CO: usize, const S: usize>(
    c: &FoldedConv,
    input: &[f32],
    n: usize,
    out: &mut [f32],
    m: usize,
    acc: bool,
    relu: bool,
    region: Option<Region>,
) {
    dense::<CO, S, Fused>(c, input, n, out, m, acc, relu, region)
}

/// A 1³ convolution (the residual blocks' projection shortcuts): per output
/// cube one input cube, `cin` broadcasts times `cout / 16` FMAs into
/// registers. Results equal [`dense`]'s up to f32 rounding (another
/// summation order).
///
/// # Safety
/// The CPU must have AVX-512F; `c.k == 1`, `c.pad == 0`, `c.cout` a multiple
/// of 16 (at most 256).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
unsafe fn pointwise_avx512<const B: usize>(
    c: &FoldedConv,
    input: &[f32],
    n: usize,
    out: &mut [f32],
    m: usize,
    accumulate: bool,
    relu: bool,
    region: Option<Region>,
) {
    use std::arch::x86_64::*;
    let (cin, co, s) = (c.cin, c.cout, c.stride);
    assert!(c.k == 1 && c.pad == 0 && co == 16 * B);
    assert!(c.w.len() == cin * co && c.b.len() == co);
    assert!(input.len() >= n * n * n * cin && out.len() >= m * m * m * co);
    assert!((m - 1) * s < n);
    let floor = if relu {
        _mm512_setzero_ps()
    } else {
        _mm512_set1_ps(f32::NEG_INFINITY)
    };
    assert!(m <= 64);
    // a few cubes at a time, so that each has its own accumulators: with 16
    // or 32 outputs one cube's sum alone is a chain of `cin` dependent FMAs
    // (the same sums in the same order either way)
    let group = if B <= 4 { 4 } else { 1 };
    let mut cubes = [0usize; 64];
    for od in 0..m {
        for oh in 0..m {
            let first = (od * m + oh) * m;
            let mut count = 0;
            for ow in 0..m {
                let o = first + ow;
                if let Some(r) = region
                    && !r.mask.contains(o)
                {
                    if let Some(bg) = r.background {
                        out[o * co..(o + 1) * co].copy_from_slice(&bg[o * co..(o + 1) * co]);
                    }
                    continue;
                }
                cubes[count] = ow;
                count += 1;
            }
            for ows in cubes[..count].chunks(group) {
                // (input cube, output cube) of each
                let at = |j: usize| (((od * s) * n + oh * s) * n + ows[j] * s, first + ows[j]);
                macro_rules! go {
                    ($g:literal) => {
                        // SAFETY: input cubes `< n³` (asserted `(m − 1)·s <
                        // n`), output cubes `< m³`, within the asserted
                        // lengths; the caller checked AVX-512F.
                        unsafe {
                            pointwise_cubes::<B, $g>(
                                c,
                                input,
                                out,
                                std::array::from_fn(at),
                                accumulate,
                                floor,
                            )
                        }
                    };
                }
                match ows.len() {
                    4 => go!(4),
                    3 => go!(3),
                    2 => go!(2),
                    _ => go!(1),
                }
            }
        }
    }
}

/// [`pointwise_avx512`]'s sums for `G` cubes `(input cube, output cube)`,
/// each with its own `B` accumulators: `out = [relu](bias [+ out] + Σ_ci
/// x_ci · w_ci)`, summed over ci in order.
///
/// # Safety
/// The CPU must have AVX-512F; every input cube `< input.len() / cin`, every
/// output cube `< out.len() / co`; `co == 16·B`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn pointwise_cubes<const B: usize, const G: usize>(
    c: &FoldedConv,
    input: &[f32],
    out: &mut [f32],
    at: [(usize, usize); G],
    accumulate: bool,
    floor: std::arch::x86_64::__m512,
) {
    use std::arch::x86_64::*;
    let (cin, co) = (c.cin, c.cout);
    debug_assert!(
        at.iter()
            .all(|&(i, o)| (i + 1) * cin <= input.len() && (o + 1) * co <= out.len())
    );
    // SAFETY (all loads and stores): as the caller promised, `cin` inputs
    // from `i·cin` and `co` outputs from `o·co`; `co` weights per input
    // channel, `co` biases.
    unsafe {
        let x: [*const f32; G] = at.map(|(i, _)| input.as_ptr().add(i * cin));
        let dst: [*mut f32; G] = at.map(|(_, o)| out.as_mut_ptr().add(o * co));
        let mut acc = [[_mm512_setzero_ps(); B]; G];
        for (a, d) in acc.iter_mut().zip(dst) {
            for (b, a) in a.iter_mut().enumerate() {
                *a = _mm512_loadu_ps(c.b.as_ptr().add(16 * b));
                if accumulate {
                    *a = _mm512_add_ps(*a, _mm512_loadu_ps(d.add(16 * b)));
                }
            }
        }
        for ci in 0..cin {
            let w = c.w.as_ptr().add(ci * co);
            let wv: [__m512; B] = std::array::from_fn(|b| _mm512_loadu_ps(w.add(16 * b)));
            for (a, x) in acc.iter_mut().zip(x) {
                let v = _mm512_set1_ps(*x.add(ci));
                for (a, &w) in a.iter_mut().zip(&wv) {
                    *a = _mm512_fmadd_ps(v, w, *a);
                }
            }
        }
        for (a, d) in acc.iter().zip(dst) {
            for (b, a) in a.iter().enumerate() {
                _mm512_storeu_ps(d.add(16 * b), _mm512_max_ps(*a, floor));
            }
        }
    }
}

/// Output side of a convolution (kernel `k`, stride `s`, padding `p`) over
/// an input of side `n`.
#[inline(always)]
pub(crate) fn output_side(n: usize, k: usize, s: usize, p: usize) -> usize {
    (n + 2 * p).saturating_sub(k) / s + 1
}

/// The flags of `row` (at most 64) as bits: bit i set where `row[i]`;
/// eight flags at a time (their bytes, 0 or 1, gathered by one multiply).
#[cfg(test)]
pub(crate) fn bits_of(row: &[bool]) -> u64 {
    debug_assert!(row.len() <= 64);
    let chunks = row.chunks_exact(8);
    let tail = chunks.remainder();
    let mut bits = 0u64;
    for (i, c) in chunks.enumerate() {
        let bytes = u64::from_le_bytes(std::array::from_fn(|j| u8::from(c[j])));
        // byte j (0 or 1) lands on bit 56 + j
        bits |= (bytes.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * i);
    }
    let at = row.len() - tail.len();
    tail.iter()
        .enumerate()
        .fold(bits, |bits, (j, &f)| bits | u64::from(f) << (at + j))
}

/// The output bits of a W row at stride 2: bit `ow` set where the input
/// row `any` has a bit in `2·ow − p .. 2·ow − p + k` (the window, clipped at
/// the row's ends, where `any` has no bits). The bits the window reaches
/// ORed onto bit `2·ow`, then the even bits packed.
fn stride_2_row(any: u64, k: usize, p: usize) -> u64 {
    let reach = (0..k).fold(0u64, |t, kw| match kw >= p {
        true => t | any >> (kw - p),
        false => t | any << (p - kw),
    });
    let mut x = reach & 0x5555_5555_5555_5555;
    x = (x | x >> 1) & 0x3333_3333_3333_3333;
    x = (x | x >> 2) & 0x0f0f_0f0f_0f0f_0f0f;
    x = (x | x >> 4) & 0x00ff_00ff_00ff_00ff;
    x = (x | x >> 8) & 0x0000_ffff_0000_ffff;
    (x | x >> 16) & 0x0000_0000_ffff_ffff
}

/// Valid kernel offsets along one axis for output coordinate `o`:
/// `kk` with `0 <= o·s + kk − p < n`.
#[inline(always)]
pub(crate) fn taps(o: usize, s: usize, p: usize, k: usize, n: usize) -> std::ops::Range<usize> {
    let start = o * s;
    let lo = p.saturating_sub(start);
    let hi = (n + p).saturating_sub(start).min(k);
    lo..hi.max(lo)
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn dense<const CO: usize, const S: usize, F: MulAdd>(
    c: &FoldedConv,
    input: &[f32],
    n: usize,
    out: &mut [f32],
    m: usize,
    accumulate: bool,
    relu: bool,
    region: Option<Region>,
) {
    let (cin, k, s, p) = (c.cin, c.k, c.stride, c.pad);
    let bias: [f32; CO] = c.b[..CO].try_into().expect("bias length");
    for od in 0..m {
        let rd = taps(od, s, p, k, n);
        for oh in 0..m {
            let rh = taps(oh, s, p, k, n);
            for ow in 0..m {
                let rw = taps(ow, s, p, k, n);
                let o = (od * m + oh) * m + ow;
                let dst: &mut [f32; CO] =
                    (&mut out[o * CO..o * CO + CO]).try_into().expect("out row");
                if let Some(r) = region
                    && !r.mask.contains(o)
                {
                    if let Some(bg) = r.background {
                        dst.copy_from_slice(&bg[o * CO..o * CO + CO]);
                    }
                    continue;
                }
                let mut accs = [[0.0f32; CO]; S];
                for kd in rd.clone() {
                    let id = od * s + kd - p;
                    for kh in rh.clone() {
                        let ih = oh * s + kh - p;
                        for kw in rw.clone() {
                            let iw = ow * s + kw - p;
                            let i = (id * n + ih) * n + iw;
                            let x = &input[i * cin..i * cin + cin];
                            let tap = (kd * k + kh) * k + kw;
                            let wt = &c.w[tap * cin * CO..(tap + 1) * cin * CO];
                            let mut xs = x.chunks_exact(S);
                            let mut ws = wt.chunks_exact(S * CO);
                            for (xc, wc) in (&mut xs).zip(&mut ws) {
                                for u in 0..S {
                                    let xv = xc[u];
                                    let wr: &[f32; CO] =
                                        wc[u * CO..u * CO + CO].try_into().expect("weight row");
                                    for j in 0..CO {
                                        accs[u][j] = F::mul_add(xv, wr[j], accs[u][j]);
                                    }
                                }
                            }
                            for (u, (&xv, wr)) in xs
                                .remainder()
                                .iter()
                                .zip(ws.remainder().chunks_exact(CO))
                                .enumerate()
                            {
                                for j in 0..CO {
                                    accs[u][j] = F::mul_add(xv, wr[j], accs[u][j]);
                                }
                            }
                        }
                    }
                }
                let mut acc = bias;
                if accumulate {
                    for j in 0..CO {
                        acc[j] += dst[j];
                    }
                }
                for a in &accs {
                    for j in 0..CO {
                        acc[j] += a[j];
                    }
                }
                if relu {
                    for v in acc.iter_mut() {
                        *v = v.max(0.0);
                    }
                }
                *dst = acc;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{bits_of, taps};

    #[test]
    fn taps_clip_at_borders() {
        // n = 5, k = 3, s = 1, p = 1
        assert_eq!(taps(0, 1, 1, 3, 5), 1..3);
        assert_eq!(taps(2, 1, 1, 3, 5), 0..3);
        assert_eq!(taps(4, 1, 1, 3, 5), 0..2);
        // stride 2, n = 21 → m = 11: last output reads 19..21, i.e. kk 0..2
        assert_eq!(taps(10, 2, 1, 3, 21), 0..2);
        // 1³ stride 2, no padding
        assert_eq!(taps(10, 2, 0, 1, 21), 0..1);
    }

    #[test]
    fn bits_of_sets_bit_i_for_flag_i() {
        let mut state = 9u32;
        for len in [0, 1, 7, 8, 9, 21, 63, 64] {
            let row: Vec<bool> = (0..len)
                .map(|_| {
                    state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    state >> 20 & 1 == 1
                })
                .collect();
            let want = row
                .iter()
                .enumerate()
                .fold(0u64, |b, (i, &f)| b | u64::from(f) << i);
            assert_eq!(bits_of(&row), want, "{row:?}");
        }
        assert_eq!(bits_of(&[true; 64]), u64::MAX);
    }
}
