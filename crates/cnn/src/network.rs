//! `Cnn`: a compiled network — folded layers, forward pass over a batch.

use crate::conv::{CubeMask, FoldedConv, Level, Region, SUPPORTED_CHANNELS};
use crate::conv_int8::{self, Int8Conv, Int8Range};
use crate::error::CnnError;
use crate::sparse_conv::Occupied;
use crate::stem_rows::{self, Int8Stem, Rows};
use crate::weights::{BatchNormWeights, LinearWeights, NetWeights};
use normalnet_isa::Isa;
use rayon::prelude::*;

/// Samples per register block of the fully connected layers.
const SAMPLES: usize = 8;

/// A linear layer with batch norm folded in, `[in][out]` weights.
#[derive(Clone, Debug)]
struct FoldedLinear {
    w: Vec<f32>,
    b: Vec<f32>,
    outputs: usize,
}

impl FoldedLinear {
    fn new(l: &LinearWeights, bn: Option<&BatchNormWeights>) -> FoldedLinear {
        let (scale, shift) = match bn {
            Some(bn) => bn.affine(),
            None => (vec![1.0; l.out_features], vec![0.0; l.out_features]),
        };
        let (ni, no) = (l.in_features, l.out_features);
        let mut w = l.weight.clone();
        for i in 0..ni {
            for o in 0..no {
                w[i * no + o] *= scale[o];
            }
        }
        let b = (0..no)
            .map(|o| l.bias.as_ref().map_or(0.0, |b| b[o]) * scale[o] + shift[o])
            .collect();
        FoldedLinear { w, b, outputs: no }
    }

    fn run(&self, isa: Isa, x: &[f32], out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if isa.has_avx512() {
            // SAFETY: a path runs only where the CPU has its features.
            return unsafe { self.run_avx512(x, out) };
        }
        #[cfg(target_arch = "x86_64")]
        if isa.has_avx2() {
            // SAFETY: as above.
            return unsafe { self.run_avx2(x, out) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = isa; // one path: the plain code
        self.run_plain(x, out);
    }

    /// The inputs of each block of [`SAMPLES`] samples that not all its
    /// samples have zero (the others add nothing).
    fn used_inputs(x: &[f32], ni: usize) -> Vec<Vec<usize>> {
        x.chunks_exact(SAMPLES * ni)
            .map(|x| {
                (0..ni)
                    .filter(|&i| (0..SAMPLES).any(|s| x[s * ni + i] != 0.0))
                    .collect()
            })
            .collect()
    }

    /// [`Self::run_avx512`] for 8-wide vectors: blocks of [`SAMPLES`]
    /// samples × 8 outputs summed in registers (8 accumulators, the weight
    /// vector and the broadcast input of the 16 registers), the same
    /// products in the same order as `run_plain`: the same values.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_avx2(&self, x: &[f32], out: &mut [f32]) {
        use std::arch::x86_64::*;
        let no = self.outputs;
        let ni = self.w.len() / no;
        if !no.is_multiple_of(8) {
            return self.run_plain(x, out);
        }
        let blocks = x.len() / (SAMPLES * ni);
        let used = Self::used_inputs(x, ni);
        for ob in (0..no).step_by(8) {
            for (bi, used) in used.iter().enumerate() {
                let x = &x[bi * SAMPLES * ni..(bi + 1) * SAMPLES * ni];
                let out = &mut out[bi * SAMPLES * no..(bi + 1) * SAMPLES * no];
                // SAFETY (all loads and stores): ob + 8 ≤ no; rows of `no`
                // weights, samples of `ni` inputs and `no` outputs.
                unsafe {
                    let mut acc = [_mm256_loadu_ps(self.b.as_ptr().add(ob)); SAMPLES];
                    for &i in used {
                        let w = _mm256_loadu_ps(self.w.as_ptr().add(i * no + ob));
                        for (s, a) in acc.iter_mut().enumerate() {
                            let xv = _mm256_set1_ps(*x.get_unchecked(s * ni + i));
                            *a = _mm256_add_ps(*a, _mm256_mul_ps(xv, w));
                        }
                    }
                    for (s, a) in acc.iter().enumerate() {
                        _mm256_storeu_ps(out.as_mut_ptr().add(s * no + ob), *a);
                    }
                }
            }
        }
        let done = blocks * SAMPLES;
        self.run_plain(&x[done * ni..], &mut out[done * no..]);
    }

    /// [`Self::run_plain`] for 16-wide vectors: blocks of [`SAMPLES`]
    /// samples × 32 outputs summed in registers (each weight vector loaded
    /// once per block, no store per multiply-add), the rest as
    /// `run_plain`. Every output sums the same products in the same order
    /// (an input all the block's samples have zero is skipped, as
    /// `run_plain` skips it per sample): the same values (up to the sign of
    /// an exact zero).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn run_avx512(&self, x: &[f32], out: &mut [f32]) {
        use std::arch::x86_64::*;
        const R: usize = 2;
        let no = self.outputs;
        let ni = self.w.len() / no;
        if !no.is_multiple_of(16 * R) {
            return self.run_plain(x, out);
        }
        let blocks = x.len() / (SAMPLES * ni);
        let used = Self::used_inputs(x, ni);
        // output blocks outer: a block's weight columns stay in cache
        // across the sample blocks
        for ob in (0..no).step_by(16 * R) {
            for (bi, used) in used.iter().enumerate() {
                let x = &x[bi * SAMPLES * ni..(bi + 1) * SAMPLES * ni];
                let out = &mut out[bi * SAMPLES * no..(bi + 1) * SAMPLES * no];
                // SAFETY (all loads and stores): ob + 16·R ≤ no; rows of
                // `no` weights, samples of `ni` inputs and `no` outputs.
                unsafe {
                    let b: [__m512; R] =
                        std::array::from_fn(|r| _mm512_loadu_ps(self.b.as_ptr().add(ob + 16 * r)));
                    let mut acc = [b; SAMPLES];
                    for &i in used {
                        let w = self.w.as_ptr().add(i * no + ob);
                        let wv: [__m512; R] =
                            std::array::from_fn(|r| _mm512_loadu_ps(w.add(16 * r)));
                        for (s, a) in acc.iter_mut().enumerate() {
                            let xv = _mm512_set1_ps(*x.get_unchecked(s * ni + i));
                            for (a, &w) in a.iter_mut().zip(&wv) {
                                *a = _mm512_add_ps(*a, _mm512_mul_ps(xv, w));
                            }
                        }
                    }
                    for (s, a) in acc.iter().enumerate() {
                        for (r, &v) in a.iter().enumerate() {
                            _mm512_storeu_ps(out.as_mut_ptr().add(s * no + ob + 16 * r), v);
                        }
                    }
                }
            }
        }
        let done = blocks * SAMPLES;
        self.run_plain(&x[done * ni..], &mut out[done * no..]);
    }

    /// `x` `[k, inputs]` → `out` `[k, outputs]`: each weight row is read
    /// once for the `k` samples; every sample sums in the same order as
    /// alone (the same bits for any `k`).
    #[inline(always)]
    fn run_plain(&self, x: &[f32], out: &mut [f32]) {
        let no = self.outputs;
        let ni = self.w.len() / no;
        for o in out.chunks_exact_mut(no) {
            o.copy_from_slice(&self.b);
        }
        for i in 0..ni {
            let row = &self.w[i * no..(i + 1) * no];
            for (xs, o) in x.chunks_exact(ni).zip(out.chunks_exact_mut(no)) {
                let xv = xs[i];
                if xv != 0.0 {
                    for (o, &w) in o.iter_mut().zip(row) {
                        *o += xv * w;
                    }
                }
            }
        }
    }
}

#[derive(Clone, Debug)]
struct Block {
    a: FoldedConv,
    b: FoldedConv,
    shortcut: FoldedConv,
    /// output side
    m: usize,
    /// `a` and `b` in 8-bit integers, once [`Cnn::set_arithmetic`] asked for them
    int8: Option<(Int8Conv, Int8Conv)>,
    /// the shortcut in 8-bit integers, reading the bytes quantized for `a`
    shortcut_int8: Option<Int8Conv>,
}

/// Which parts of a network run in 8-bit integers; the rest, and every part
/// the kernel path or the network's shape cannot run so, in f32. One value
/// for [`Cnn::set_arithmetic`] and the NormalNet parameters (keys `int8`,
/// `int8_stem`, `int8_shortcut`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct Arithmetic {
    /// the residual blocks' 3³ convolutions: 8-bit inputs and weights,
    /// exact i32 sums, f32 scale, bias and ReLU (about 1 % of a layer's
    /// output range per value), on every path with int8 kernels (AVX-512
    /// VNNI, AVX-VNNI, AVX2: the same sums) and input channels a multiple
    /// of 4, outputs 16 to 256
    pub int8: bool,
    /// with `int8`, the first 5³ convolution (the row stem) in 8-bit
    /// integers too (on the validation set +0.004° mean E_a without the
    /// chaotic cone s42, −0.036° with it, for a stem about twice as fast)
    pub int8_stem: bool,
    /// with `int8`, the residual blocks' 1³ shortcuts in 8-bit integers
    /// too, on the bytes quantized for the block's first convolution
    pub int8_shortcut: bool,
    /// with `int8`, the integer ranges ([`Int8Range`]). `None` (the
    /// default): the network's own ([`Cnn::set_int8_range`]) where the path
    /// has VNNI (`vpdpbusd`), the narrow ones where plain AVX2 sums the
    /// bytes (AVX2, AVX-512 without VNNI: `vpmaddubsw` is exact only for
    /// narrow numbers). On the validation suite the shipped bundle gives a
    /// mean E_a of 11.79° narrow against 11.75° full, and plain AVX2 runs
    /// Fandisk0.3 1.4× faster (docs/experiments.md). `Some(range)`: that
    /// range on every path.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub int8_range: Option<Int8Range>,
}

impl Arithmetic {
    /// f32 throughout: equal to the training engine; a new [`Cnn`]'s.
    pub const F32: Arithmetic = Arithmetic {
        int8: false,
        int8_stem: false,
        int8_shortcut: false,
        int8_range: None,
    };
    /// Every part that has int8 kernels in 8-bit integers.
    pub const INT8: Arithmetic = Arithmetic {
        int8: true,
        int8_stem: true,
        int8_shortcut: true,
        int8_range: None,
    };
    /// The residual blocks' 3³ convolutions alone in 8-bit integers.
    pub const INT8_BLOCKS: Arithmetic = Arithmetic {
        int8: true,
        int8_stem: false,
        int8_shortcut: false,
        int8_range: None,
    };

    /// Each part in int8 where both `self` and `other` have it (the
    /// arithmetic every network of a bundle runs).
    pub fn and(self, other: Arithmetic) -> Arithmetic {
        Arithmetic {
            int8: self.int8 && other.int8,
            int8_stem: self.int8_stem && other.int8_stem,
            int8_shortcut: self.int8_shortcut && other.int8_shortcut,
            int8_range: match self.int8_range == other.int8_range {
                true => self.int8_range,
                false => None,
            },
        }
    }
}

/// [`Arithmetic::INT8`]: NormalNet's default arithmetic.
impl Default for Arithmetic {
    fn default() -> Self {
        Arithmetic::INT8
    }
}

/// A trained NormalNet network compiled for fast CPU inference.
#[derive(Clone, Debug)]
pub struct Cnn {
    grid: usize,
    stem: FoldedConv,
    stem_side: usize,
    blocks: Vec<Block>,
    hidden: Vec<FoldedLinear>,
    output: FoldedLinear,
    /// the kernel path (`level` is its f32 kernels)
    isa: Isa,
    level: Level,
    largest: usize,
    /// the largest side of the input or any layer's output (the cube masks
    /// of the sparse pass cover at most [`CubeMask::MAX_SIDE`])
    widest: usize,
    background: Background,
    /// the arithmetic asked for ([`Cnn::set_arithmetic`])
    asked: Arithmetic,
    /// the blocks run their `int8` convolutions (asked, and this path and
    /// every block have them)
    int8: bool,
    /// the stem runs as row convolutions (`stem_rows`) instead of the scatter
    row_stem: bool,
    /// the row stem in 8-bit integers, once [`Cnn::set_arithmetic`] asked for them
    stem_int8: Option<Int8Stem>,
    /// the integer ranges the network was trained for ([`Cnn::set_int8_range`])
    int8_range: Int8Range,
    /// the ranges its quantized parts (`Block::int8`, `stem_int8`) have
    quantized: Option<Int8Range>,
}

/// Activations of an all-empty grid: every cube whose receptive field holds
/// no occupied voxel has exactly these values, so only the cubes near the
/// surface sheet are computed (the others are copied).
#[derive(Clone, Debug, Default)]
struct Background {
    /// per block, the output of `conv_a` (after BN + ReLU)
    a: Vec<Vec<f32>>,
    /// per block, the block output
    y: Vec<Vec<f32>>,
}

/// Largest per-thread buffers [`Cnn`] keeps between calls (the lite
/// networks need 2.4 MB; the paper preset's 70 MB are allocated per call,
/// a few times per thread: once per piece of work rayon splits off).
const KEPT_SCRATCH: usize = 16 << 20;

/// Per-thread buffers of one forward pass.
struct Scratch {
    occupied: Occupied,
    rows: Rows,
    x: Vec<f32>,
    t: Vec<f32>,
    y: Vec<f32>,
    v: Vec<f32>,
    /// cubes of the current activation whose receptive field is occupied
    near: CubeMask,
    near_a: CubeMask,
    near_s: CubeMask,
    near_y: CubeMask,
    /// an input quantized for the int8 convolutions
    quantized: Vec<u8>,
    /// the input W rows an int8 convolution reads
    rows_read: Vec<bool>,
}

impl Cnn {
    /// Compiles `weights`: checks shapes, folds batch norm, reorders weights.
    ///
    /// # Errors
    /// [`CnnError`] naming the layer whose shapes do not fit, or a channel
    /// count the kernels are not compiled for (8, 16, 32, 64, 128, 256).
    pub fn new(weights: &NetWeights) -> Result<Cnn, CnnError> {
        let mismatch = |layer: &str, message: String| CnnError::Mismatch {
            layer: layer.to_string(),
            message,
        };
        let supported = |layer: &str, c: usize| {
            if SUPPORTED_CHANNELS.contains(&c) {
                Ok(())
            } else {
                Err(mismatch(
                    layer,
                    format!("{c} output channels (supported: {SUPPORTED_CHANNELS:?})"),
                ))
            }
        };
        weights.stem.check("stem")?;
        weights.stem_bn.check("stem", weights.stem.out_channels)?;
        if weights.stem.in_channels != 3 || weights.stem.stride != 1 {
            return Err(mismatch(
                "stem",
                "expected 3 input channels and stride 1".into(),
            ));
        }
        supported("stem", weights.stem.out_channels)?;
        let stem = FoldedConv::new(&weights.stem, &weights.stem_bn);
        let stem_side = stem.output_side(weights.grid);
        let mut largest = stem_side.pow(3) * stem.cout;
        let mut widest = weights.grid.max(stem_side);
        let (mut n, mut c) = (stem_side, stem.cout);
        let mut blocks = Vec::new();
        for (i, bw) in weights.blocks.iter().enumerate() {
            let name = format!("block {}", i + 1);
            for (conv, bn, what) in [
                (&bw.conv_a, &bw.bn_a, "conv_a"),
                (&bw.conv_b, &bw.bn_b, "conv_b"),
                (&bw.shortcut, &bw.bn_shortcut, "shortcut"),
            ] {
                let layer = format!("{name} {what}");
                conv.check(&layer)?;
                bn.check(&layer, conv.out_channels)?;
                supported(&layer, conv.out_channels)?;
            }
            if bw.conv_a.in_channels != c || bw.shortcut.in_channels != c {
                return Err(mismatch(
                    &name,
                    format!(
                        "expects {} input channels, previous layer gives {c}",
                        bw.conv_a.in_channels
                    ),
                ));
            }
            let m = bw.conv_a.output_side(n);
            let cout = bw.conv_a.out_channels;
            if bw.conv_b.in_channels != cout
                || bw.conv_b.out_channels != cout
                || bw.shortcut.out_channels != cout
                || bw.conv_b.output_side(m) != m
                || bw.shortcut.output_side(n) != m
            {
                return Err(mismatch(
                    &name,
                    "conv_b / shortcut shapes do not match conv_a".into(),
                ));
            }
            blocks.push(Block {
                a: FoldedConv::new(&bw.conv_a, &bw.bn_a),
                b: FoldedConv::new(&bw.conv_b, &bw.bn_b),
                shortcut: FoldedConv::new(&bw.shortcut, &bw.bn_shortcut),
                m,
                int8: None,
                shortcut_int8: None,
            });
            largest = largest.max(m.pow(3) * cout);
            widest = widest.max(m);
            n = m;
            c = cout;
        }
        let mut hidden = Vec::new();
        let mut width = c;
        for (i, (l, bn)) in weights.hidden.iter().enumerate() {
            let layer = format!("hidden {}", i + 1);
            l.check(&layer)?;
            bn.check(&layer, l.out_features)?;
            if l.in_features != width {
                return Err(mismatch(
                    &layer,
                    format!(
                        "expects {} inputs, previous layer gives {width}",
                        l.in_features
                    ),
                ));
            }
            hidden.push(FoldedLinear::new(l, Some(bn)));
            width = l.out_features;
        }
        weights.output.check("output")?;
        if weights.output.in_features != width {
            return Err(mismatch(
                "output",
                format!(
                    "expects {} inputs, previous layer gives {width}",
                    weights.output.in_features
                ),
            ));
        }
        let output = FoldedLinear::new(&weights.output, None);
        let mut cnn = Cnn {
            grid: weights.grid,
            stem,
            stem_side,
            blocks,
            hidden,
            output,
            isa: normalnet_isa::active(),
            level: Level::detect(),
            largest,
            widest,
            background: Background::default(),
            asked: Arithmetic::F32,
            int8: false,
            row_stem: false,
            stem_int8: None,
            int8_range: Int8Range::Full,
            quantized: None,
        };
        cnn.set_row_stem(true);
        cnn.record_background();
        Ok(cnn)
    }

    /// Records the activations of an all-empty grid on this network's path
    /// (the values every cube far from the surface takes).
    fn record_background(&mut self) {
        let mut s = self.scratch();
        let mut out = vec![0.0; self.outputs()];
        let mut background = Background::default();
        self.run(
            Grid::Sparse(&[], &[]),
            &mut s,
            Some(&mut out),
            Some(&mut background),
            None,
        );
        self.background = background;
    }

    /// Length of one input grid, `3 · D · H · W`.
    pub fn grid_len(&self) -> usize {
        3 * self.grid.pow(3)
    }

    /// Number of outputs per sample (18 for six μ_g).
    pub fn outputs(&self) -> usize {
        self.output.outputs
    }

    /// The kernel path this network runs ([`normalnet_isa::active`] unless
    /// [`Self::set_isa`] chose another), by its `NORMALNET_ISA` name.
    pub fn instruction_set(&self) -> &'static str {
        self.isa.name()
    }

    /// The kernel path this network runs.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Runs this network's kernels on `isa` instead of the process's path
    /// (tests and benchmarks compare paths in one process). The empty
    /// grid's activations are recomputed on the new path, the stem goes
    /// back to its default form ([`Self::set_row_stem`]`(true)`), and int8
    /// parts, where the new path has no int8 kernels, fall back to f32
    /// (call [`Self::set_arithmetic`] again after moving to a path that has
    /// them).
    ///
    /// # Errors
    /// [`CnnError::Isa`] when this CPU does not run `isa`.
    pub fn set_isa(&mut self, isa: Isa) -> Result<(), CnnError> {
        if !isa.runs_here() {
            return Err(CnnError::Isa {
                asked: isa.name(),
                detected: Isa::detected().name(),
            });
        }
        self.isa = isa;
        self.level = Level::of(isa);
        if !conv_int8::supported(isa) {
            self.int8 = false;
        }
        self.set_row_stem(true);
        self.record_background();
        Ok(())
    }

    /// Chooses which parts run in 8-bit integers and returns the
    /// arithmetic in effect ([`Self::arithmetic`]): int8 parts need a path
    /// with int8 kernels and channel counts they handle; the others stay
    /// f32.
    pub fn set_arithmetic(&mut self, arithmetic: Arithmetic) -> Arithmetic {
        self.asked = arithmetic;
        self.int8 = false;
        if arithmetic.int8 && conv_int8::supported(self.isa) {
            let range = self.range_for(arithmetic);
            if self.quantized != Some(range) {
                for b in &mut self.blocks {
                    b.int8 = None;
                    b.shortcut_int8 = None;
                }
                self.stem_int8 = None;
                self.quantized = Some(range);
            }
            for b in &mut self.blocks {
                if b.int8.is_none() {
                    b.int8 = Int8Conv::new(&b.a, range).zip(Int8Conv::new(&b.b, range));
                    b.shortcut_int8 = Int8Conv::new(&b.shortcut, range)
                        .filter(|_| b.shortcut.k == 1 && b.shortcut.pad <= b.a.pad)
                        .map(|q| q.reading_layout(b.a.pad));
                }
            }
            self.int8 = self.blocks.iter().all(|b| b.int8.is_some());
            if self.stem_int8.is_none() && stem_rows::serves(&self.stem, self.grid) {
                self.stem_int8 = Int8Stem::new(&self.stem, range);
            }
        }
        self.arithmetic()
    }

    /// Sets the integer ranges the network was trained for
    /// ([`Int8Range::Full`] for a new network and the shipped bundle; a
    /// bundle's `int8_range`). The int8 parts are quantized again where
    /// their ranges change ([`Arithmetic::int8_range`] says which run), and
    /// the arithmetic asked for stays; returns the arithmetic in effect.
    pub fn set_int8_range(&mut self, range: Int8Range) -> Arithmetic {
        self.int8_range = range;
        self.set_arithmetic(self.asked)
    }

    /// The integer ranges the network was trained for.
    pub fn int8_range(&self) -> Int8Range {
        self.int8_range
    }

    /// The integer ranges its int8 parts run with (`None` with f32 blocks).
    pub fn int8_range_in_use(&self) -> Option<Int8Range> {
        self.quantized.filter(|_| self.int8)
    }

    /// The ranges `arithmetic` runs on this network's path: the asked
    /// ones, else [`Int8Range::default_on`] the path.
    fn range_for(&self, arithmetic: Arithmetic) -> Int8Range {
        arithmetic
            .int8_range
            .unwrap_or(self.int8_range.default_on(self.isa))
    }

    /// The arithmetic in effect: int8 blocks where asked and possible; the
    /// stem in int8 where also asked, the row stem in effect and quantized;
    /// the shortcuts where also asked and every one quantized.
    pub fn arithmetic(&self) -> Arithmetic {
        Arithmetic {
            int8: self.int8,
            int8_stem: self.runs_int8_stem(),
            int8_shortcut: self.runs_int8_shortcut(),
            int8_range: self.asked.int8_range,
        }
    }

    fn runs_int8_stem(&self) -> bool {
        // VNNI code, or AVX2's `vpmaddwd` with the same sums (int8
        // blocks mean a path with one of them)
        self.asked.int8_stem && self.int8 && self.row_stem && self.stem_int8.is_some()
    }

    fn runs_int8_shortcut(&self) -> bool {
        self.asked.int8_shortcut
            && self.int8
            && self.blocks.iter().all(|b| b.shortcut_int8.is_some())
    }

    /// Chooses how the stem runs: as 1D convolutions along the grid rows
    /// (AVX-512 or AVX2, 3 → 16 channels: the lite stem; the default where
    /// it applies) or as the scatter of occupied cubes (everywhere else).
    /// Both compute the same convolution up to f32 rounding; returns the
    /// form in effect (true: rows). For benchmarks and cross-checks.
    pub fn set_row_stem(&mut self, rows: bool) -> bool {
        self.row_stem = rows
            && matches!(self.level, Level::Avx512 | Level::Avx2)
            && stem_rows::serves(&self.stem, self.grid);
        self.row_stem
    }

    /// Runs the network on a batch.
    ///
    /// # Shapes
    /// - `grids`: `[batch, 3, D, H, W]` flat, channel-major per sample
    /// - `out`: `[batch, outputs]` flat, after tanh
    ///
    /// # Errors
    /// [`CnnError::BufferSize`] when the buffers do not hold whole samples of
    /// the same batch size.
    pub fn forward(&self, grids: &[f32], out: &mut [f32]) -> Result<(), CnnError> {
        self.check_buffers(grids, out)?;
        let g = self.grid_len();
        self.forward_runs(|i| Grid::Dense(&grids[i * g..(i + 1) * g]), out);
        Ok(())
    }

    /// [`Self::forward`] on sparse grids: per sample, the indices of its
    /// occupied cubes (`(d·H + h)·W + w`, ascending) and their three channel
    /// values, cube after cube (what `normalnet_voxel::SparseGrid` holds).
    /// The same outputs as `forward` on the dense grids, without writing,
    /// reading or clearing `3·D·H·W` values per sample.
    ///
    /// # Errors
    /// [`CnnError::BufferSize`] when `out` does not hold one output row per
    /// sample; [`CnnError::SparseSample`] naming a sample whose indices are
    /// not ascending or outside the grid, or whose values are not three per
    /// cube.
    pub fn forward_sparse(
        &self,
        samples: &[(&[u32], &[f32])],
        out: &mut [f32],
    ) -> Result<(), CnnError> {
        let no = self.outputs();
        if out.len() != samples.len() * no {
            return Err(CnnError::BufferSize {
                what: "output batch",
                actual: out.len(),
                expected: samples.len() * no,
            });
        }
        let cubes = self.grid.pow(3);
        for (sample, &(index, values)) in samples.iter().enumerate() {
            let bad = |message: String| CnnError::SparseSample { sample, message };
            if values.len() != 3 * index.len() {
                return Err(bad(format!(
                    "{} values for {} cubes (3 channels each)",
                    values.len(),
                    index.len()
                )));
            }
            if let Some(w) = index.windows(2).position(|w| w[0] >= w[1]) {
                return Err(bad(format!(
                    "cube indices not ascending at position {}",
                    w + 1
                )));
            }
            if let Some(&last) = index.last().filter(|&&i| i as usize >= cubes) {
                return Err(bad(format!(
                    "cube index {last} outside the {cubes}-cube grid"
                )));
            }
        }
        self.forward_runs(|i| Grid::Sparse(samples[i].0, samples[i].1), out);
        Ok(())
    }

    /// The network on `out.len() / outputs` samples, sample `i` given by
    /// `sample(i)`.
    fn forward_runs<'a>(&self, sample: impl Fn(usize) -> Grid<'a> + Sync, out: &mut [f32]) {
        let no = self.outputs();
        // Runs of a few samples, so that a thread slowed by other work (the
        // voxelizer shares the cores) does not leave the others idle at the
        // end of the batch; each run uses its thread's buffers, kept between
        // calls up to KEPT_SCRATCH (fresh ones were 2.4 MB per thread and
        // batch to fault in and zero)
        const RUN: usize = 8;
        let width = self.pooled_width();
        let mut pooled = vec![0.0f32; out.len() / no * width];
        // the convolutions sample by sample
        let runs = |s: &mut Scratch, r: usize, pooled: &mut [f32]| {
            for (i, p) in pooled.chunks_exact_mut(width).enumerate() {
                self.run(sample(RUN * r + i), s, None, None, None);
                p.copy_from_slice(&s.v[..width]);
            }
        };
        let chunks = pooled.par_chunks_mut(RUN * width).enumerate();
        if self.keeps_scratch() {
            chunks.for_each(|(r, pooled)| self.with_thread_scratch(|s| runs(s, r, pooled)));
        } else {
            // buffers too large to keep: one set per piece of work rayon
            // splits off (a few per thread and call), not one per run
            chunks.for_each_init(|| self.scratch(), |s, (r, pooled)| runs(s, r, pooled));
        }
        // the fully connected head on larger groups: each weight read once
        // per group
        const HEAD: usize = 64;
        pooled
            .par_chunks(HEAD * width)
            .zip(out.par_chunks_mut(HEAD * no))
            .for_each(|(pooled, out)| self.head(pooled, out));
    }

    /// `grids` holds whole samples and `out` one output row for each.
    fn check_buffers(&self, grids: &[f32], out: &[f32]) -> Result<(), CnnError> {
        let (g, no) = (self.grid_len(), self.outputs());
        if !grids.len().is_multiple_of(g) || out.len() != grids.len() / g * no {
            return Err(CnnError::BufferSize {
                what: "output batch",
                actual: out.len(),
                expected: grids.len() / g * no,
            });
        }
        Ok(())
    }

    /// Calls `f` with this thread's buffers, made for this network and kept
    /// for the next call (networks that [`Self::keeps_scratch`]; larger ones
    /// take theirs per rayon split in `forward_runs`).
    fn with_thread_scratch<R>(&self, f: impl FnOnce(&mut Scratch) -> R) -> R {
        thread_local! {
            static SCRATCH: std::cell::RefCell<Option<Scratch>> =
                const { std::cell::RefCell::new(None) };
        }
        debug_assert!(self.keeps_scratch());
        SCRATCH.with(|cell| match cell.try_borrow_mut() {
            Ok(mut slot) => {
                let s = match slot.take() {
                    Some(s) if s.x.len() >= self.largest => slot.insert(s),
                    _ => slot.insert(self.scratch()),
                };
                f(s)
            }
            // a nested call takes fresh buffers
            Err(_) => f(&mut self.scratch()),
        })
    }

    /// Whether this network's per-thread buffers are kept between calls.
    fn keeps_scratch(&self) -> bool {
        4 * self.largest * std::mem::size_of::<f32>() <= KEPT_SCRATCH
    }

    fn scratch(&self) -> Scratch {
        Scratch {
            occupied: Occupied::default(),
            rows: Rows::default(),
            x: vec![0.0; self.largest],
            t: vec![0.0; self.largest],
            y: vec![0.0; self.largest],
            v: vec![0.0; self.largest],
            near: CubeMask::default(),
            near_a: CubeMask::default(),
            near_s: CubeMask::default(),
            near_y: CubeMask::default(),
            quantized: Vec::new(),
            rows_read: Vec::new(),
        }
    }

    /// One sample. With `record`, computes every cube and records the
    /// activations (the background); otherwise computes only the cubes near
    /// the occupied voxels and copies the background elsewhere.
    fn run(
        &self,
        grid: Grid,
        s: &mut Scratch,
        out: Option<&mut [f32]>,
        mut record: Option<&mut Background>,
        mut profile: Option<&mut LayerTimes>,
    ) {
        let lv = self.level;
        let int8_shortcut = self.runs_int8_shortcut();
        // only the cubes near the surface (masks of grids up to 64 cubes a
        // side), unless the empty grid's activations are being recorded
        let sparse = record.is_none() && self.widest <= CubeMask::MAX_SIDE;
        let mut clock = std::time::Instant::now();
        let mut lap = |slot: usize, profile: &mut Option<&mut LayerTimes>| {
            if let Some(p) = profile.as_deref_mut() {
                let now = std::time::Instant::now();
                let last = p.seconds.len() - 1;
                p.seconds[slot.min(last)] += (now - clock).as_secs_f64();
                clock = now;
            }
        };
        match grid {
            Grid::Dense(grid) => s.occupied.gather(grid, 3),
            Grid::Sparse(index, values) => s.occupied.set(index, values),
        }
        lap(0, &mut profile);
        let mut n = self.stem_side;
        let mut c = self.stem.cout;
        let stem_out = &mut s.x[..n * n * n * c];
        // the stem's largest output, where the stem tells it
        let mut stem_max: Option<f32> = None;
        match self.row_stem {
            #[cfg(target_arch = "x86_64")]
            true => {
                let int8 = self.runs_int8_stem();
                s.rows
                    .build(&s.occupied, [self.grid, self.stem.pad, n], !int8);
                let near = sparse.then_some(&mut s.near);
                let (p, g) = (self.stem.pad, self.grid);
                match &self.stem_int8 {
                    Some(q) if int8 => {
                        let scale = s.rows.quantize(&s.occupied, q.range());
                        // SAFETY (both): int8 precision means
                        // `conv_int8::supported` on this network's path (VNNI
                        // with F and BW, or AVX2 and FMA); `set_row_stem`
                        // checked `serves`.
                        stem_max = Some(match self.isa.has_vnni() {
                            true => unsafe {
                                stem_rows::run_int8(q, p, &s.rows, scale, g, stem_out, true, near)
                            },
                            false => unsafe {
                                let avx_vnni = self.isa.uses_avx_vnni();
                                // plain AVX2 reads narrow bytes as they are
                                if !avx_vnni && q.range() == Int8Range::Full {
                                    s.rows.widen();
                                }
                                stem_rows::avx2::run_int8(
                                    q, p, &s.rows, scale, g, stem_out, true, near, avx_vnni,
                                )
                            },
                        });
                    }
                    // SAFETY (both): `set_row_stem` checked the level (AVX-512F, or AVX2 and
                    // FMA) and `serves`.
                    _ => match self.level {
                        Level::Avx512 => unsafe {
                            stem_rows::run(&self.stem, &s.rows, g, stem_out, true, near)
                        },
                        _ => unsafe {
                            stem_rows::avx2::run(&self.stem, &s.rows, g, stem_out, true, near)
                        },
                    },
                }
            }
            _ => {
                self.stem
                    .run_sparse(lv, &s.occupied, self.grid, stem_out, true);
                if sparse {
                    self.stem.reach_mask(&s.occupied, self.grid, &mut s.near);
                }
            }
        }
        lap(1, &mut profile);
        for (bi, b) in self.blocks.iter().enumerate() {
            let (m, co) = (b.m, b.a.cout);
            let x = &s.x[..n * n * n * c];
            let y = &mut s.y[..m * m * m * co];
            let t = &mut s.t[..m * m * m * co];
            if sparse {
                b.a.window_mask(&s.near, &mut s.near_a);
                b.shortcut.window_mask(&s.near, &mut s.near_s);
                b.b.window_mask(&s.near_a, &mut s.near_y);
                s.near_y.union_with(&s.near_s);
                let (near_a, near_y) = (&s.near_a, &s.near_y);
                let only = |mask, background| Some(Region { mask, background });
                lap(2 + 3 * bi, &mut profile);
                let region_a = only(near_a, Some(&self.background.a[bi]));
                let region_b = only(near_y, Some(&self.background.y[bi]));
                match &b.int8 {
                    #[cfg(target_arch = "x86_64")]
                    Some((qa, qb)) if self.int8 => {
                        let shortcut = b.shortcut_int8.as_ref().filter(|_| int8_shortcut);
                        s.rows_read.clear();
                        s.rows_read.resize(n * n, false);
                        qa.rows_read(near_a, n, &mut s.rows_read);
                        match shortcut {
                            Some(q) => q.rows_read(near_y, n, &mut s.rows_read),
                            None => b
                                .shortcut
                                .run(lv, x, n, y, false, false, only(near_y, None)),
                        }
                        // the block's input is the stem's output in block 1
                        let max = stem_max.take();
                        let rows = (Some(&s.rows_read[..]), max);
                        let (xq, sx) = conv_int8::quantize(
                            self.isa,
                            x,
                            n,
                            qa.input_pad(),
                            qa.range(),
                            rows,
                            &mut s.quantized,
                        );
                        // SAFETY: `set_arithmetic` enables int8 only where
                        // `conv_int8::supported` on this network's path.
                        if let Some(q) = shortcut {
                            unsafe {
                                q.run(self.isa, xq, sx, n, y, false, false, only(near_y, None))
                            };
                        }
                        lap(2 + 3 * bi, &mut profile);
                        // SAFETY: as above.
                        unsafe { qa.run(self.isa, xq, sx, n, t, false, true, region_a) };
                        lap(3 + 3 * bi, &mut profile);
                        s.rows_read.clear();
                        s.rows_read.resize(m * m, false);
                        qb.rows_read(near_y, m, &mut s.rows_read);
                        let rows = (Some(&s.rows_read[..]), None);
                        let (tq, st) = conv_int8::quantize(
                            self.isa,
                            t,
                            m,
                            qb.input_pad(),
                            qb.range(),
                            rows,
                            &mut s.quantized,
                        );
                        // SAFETY: as above.
                        unsafe { qb.run(self.isa, tq, st, m, y, true, true, region_b) };
                    }
                    _ => {
                        b.shortcut
                            .run(lv, x, n, y, false, false, only(near_y, None));
                        lap(2 + 3 * bi, &mut profile);
                        b.a.run(lv, x, n, t, false, true, region_a);
                        lap(3 + 3 * bi, &mut profile);
                        b.b.run(lv, t, m, y, true, true, region_b);
                    }
                }
                lap(4 + 3 * bi, &mut profile);
                std::mem::swap(&mut s.near, &mut s.near_y);
            } else {
                b.shortcut.run(lv, x, n, y, false, false, None);
                b.a.run(lv, x, n, t, false, true, None);
                b.b.run(lv, t, m, y, true, true, None);
                if let Some(r) = record.as_deref_mut() {
                    r.a.push(t.to_vec());
                    r.y.push(y.to_vec());
                }
            }
            std::mem::swap(&mut s.x, &mut s.y);
            n = m;
            c = co;
        }
        // global max pool over cubes
        let x = &s.x[..n * n * n * c];
        let pooled = &mut s.v[..c];
        pooled.fill(f32::NEG_INFINITY);
        for row in x.chunks_exact(c) {
            for (p, &v) in pooled.iter_mut().zip(row) {
                *p = p.max(v);
            }
        }
        if let Some(out) = out {
            self.head(&s.v[..c], out);
        }
        lap(usize::MAX, &mut profile);
    }

    /// Channels of the last block: the width of the pooled features.
    fn pooled_width(&self) -> usize {
        self.blocks.last().map_or(self.stem.cout, |b| b.a.cout)
    }

    /// The fully connected layers and tanh on the pooled features of `k`
    /// samples (`pooled` `[k, width]`, `out` `[k, outputs]`).
    fn head(&self, pooled: &[f32], out: &mut [f32]) {
        let k = out.len() / self.outputs();
        let mut x = pooled.to_vec();
        let mut y = Vec::new();
        for l in &self.hidden {
            y.clear();
            y.resize(k * l.outputs, 0.0);
            l.run(self.isa, &x, &mut y);
            for v in y.iter_mut() {
                *v = v.max(0.0);
            }
            std::mem::swap(&mut x, &mut y);
        }
        self.output.run(self.isa, &x, out);
        for v in out.iter_mut() {
            *v = v.tanh();
        }
    }

    /// [`Self::forward`] on one thread with a clock around every layer: the
    /// seconds spent per layer over the batch (see [`LayerTimes::named`]).
    ///
    /// # Errors
    /// As [`Self::forward`].
    pub fn forward_profiled(&self, grids: &[f32], out: &mut [f32]) -> Result<LayerTimes, CnnError> {
        self.check_buffers(grids, out)?;
        let (g, no) = (self.grid_len(), self.outputs());
        let mut times = LayerTimes {
            seconds: vec![0.0; 3 + 3 * self.blocks.len()],
            blocks: self.blocks.len(),
        };
        let mut s = self.scratch();
        for (grid, o) in grids.chunks_exact(g).zip(out.chunks_exact_mut(no)) {
            self.run(Grid::Dense(grid), &mut s, Some(o), None, Some(&mut times));
        }
        Ok(times)
    }
}

/// One input sample.
#[derive(Clone, Copy)]
enum Grid<'a> {
    /// `[3, D, H, W]`
    Dense(&'a [f32]),
    /// the occupied cubes' indices (ascending) and their values, channels-last
    Sparse(&'a [u32], &'a [f32]),
}

/// Seconds per layer of [`Cnn::forward_profiled`].
#[derive(Clone, Debug, PartialEq)]
pub struct LayerTimes {
    /// indexed like [`LayerTimes::named`]
    pub seconds: Vec<f64>,
    blocks: usize,
}

impl LayerTimes {
    /// `(layer, seconds)` in network order: gathering the occupied voxels,
    /// the stem, per block the shortcut (with the masks of the cubes to
    /// compute) and the two 3³ convolutions, then the head.
    pub fn named(&self) -> Vec<(String, f64)> {
        let mut v = vec![
            ("gather occupied voxels".to_string(), self.seconds[0]),
            ("stem 5³ conv + masks".to_string(), self.seconds[1]),
        ];
        for b in 0..self.blocks {
            v.push((
                format!("block {} shortcut 1³ + masks", b + 1),
                self.seconds[2 + 3 * b],
            ));
            v.push((
                format!("block {} conv a 3³", b + 1),
                self.seconds[3 + 3 * b],
            ));
            v.push((
                format!("block {} conv b 3³", b + 1),
                self.seconds[4 + 3 * b],
            ));
        }
        let last = self.seconds.len() - 1;
        v.push((
            "max pool + fully connected + tanh".to_string(),
            self.seconds[last],
        ));
        v
    }
}
