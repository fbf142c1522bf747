//! Training on the CPU engine: forward pass in training mode (batch
//! statistics), backward pass of every layer of SPEC §6, Adam.
//!
//! Layer by layer over the whole batch (batch norm couples the samples),
//! each layer's per-sample work in parallel. The first convolution runs as a
//! scatter of the occupied input cubes (a face neighbourhood is a surface
//! sheet) both forward and for its weight gradient; every later layer is
//! dense, channels-last, with register-blocked kernels. Weight gradients are
//! summed per fixed group of samples and then over groups in order, so a step
//! gives the same result whatever the thread count.
//!
//! [`Trainer::new`] takes [`NetWeights`] (e.g. exported from a freshly
//! initialised burn model) and [`Trainer::weights`] gives them back, running
//! statistics included, so bundles and the inference engine are unchanged.

mod batch_norm;
mod conv_grad;
mod fake_quant;
mod param;

use rayon::prelude::*;

use crate::conv::{FoldedConv, Level, SUPPORTED_CHANNELS};
use crate::conv_int8::Int8Range;
use crate::error::CnnError;
use crate::sparse_conv::Occupied;
use crate::weights::{BlockWeights, ConvWeights, LinearWeights, NetWeights};
use batch_norm::{BatchNorm, BatchStats};
use conv_grad::ConvShape;
pub use param::AdamConfig;
use param::Param;

/// First bytes of [`Trainer::state_bytes`].
const STATE_MAGIC: &[u8] = b"normalnet-trainer-1\n";

/// Samples per weight-gradient group (fixed, so sums do not depend on the
/// number of threads).
const GROUP: usize = 8;

/// The loss between the 18 outputs of a sample and its targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Loss {
    /// mean squared error over all outputs (SPEC §8)
    #[default]
    Mse,
    /// mean absolute error over all outputs
    L1,
}

/// A convolution being trained: weights `[k³][cin][cout]` (the forward
/// kernels' layout) and their transpose `[k³][cout][cin]` for the input
/// gradient; with `quant`, both on the int8 steps of that range.
#[derive(Clone, Debug)]
struct Conv {
    sh: ConvShape,
    p: Param,
    folded: FoldedConv,
    wt: Vec<f32>,
    quant: Option<Int8Range>,
}

impl Conv {
    fn new(c: &ConvWeights, layer: &str) -> Result<Conv, CnnError> {
        c.check(layer)?;
        if c.bias.is_some() {
            return Err(CnnError::Mismatch {
                layer: layer.into(),
                message: "convolution biases are not trained (batch norm follows)".into(),
            });
        }
        if !SUPPORTED_CHANNELS.contains(&c.out_channels)
            || (c.in_channels != 3 && !SUPPORTED_CHANNELS.contains(&c.in_channels))
        {
            return Err(CnnError::Mismatch {
                layer: layer.into(),
                message: format!(
                    "{} → {} channels (supported: {SUPPORTED_CHANNELS:?})",
                    c.in_channels, c.out_channels
                ),
            });
        }
        let folded = FoldedConv::new(
            c,
            &crate::weights::BatchNormWeights {
                gamma: vec![1.0; c.out_channels],
                beta: vec![0.0; c.out_channels],
                mean: vec![0.0; c.out_channels],
                var: vec![1.0; c.out_channels],
                epsilon: 0.0,
            },
        );
        let mut conv = Conv {
            sh: ConvShape {
                k: c.kernel,
                stride: c.stride,
                pad: c.padding,
                cin: c.in_channels,
                cout: c.out_channels,
            },
            p: Param::new(folded.w.clone()),
            folded,
            wt: Vec::new(),
            quant: None,
        };
        conv.refresh();
        Ok(conv)
    }

    /// Copies the parameter values (with `quant`, rounded to its steps)
    /// into the kernels' arrays.
    fn refresh(&mut self) {
        match self.quant {
            Some(range) => self.folded.w = fake_quant::weights(&self.p.value, self.sh.cout, range),
            None => self.folded.w.copy_from_slice(&self.p.value),
        }
        let (k3, ci, co) = (self.sh.k.pow(3), self.sh.cin, self.sh.cout);
        self.wt.resize(k3 * ci * co, 0.0);
        for t in 0..k3 {
            for i in 0..ci {
                for o in 0..co {
                    self.wt[(t * co + o) * ci + i] = self.folded.w[(t * ci + i) * co + o];
                }
            }
        }
    }

    /// `[k³][cin][cout]` → burn's `[cout][cin][k³]`.
    fn to_burn(&self, values: &[f32]) -> Vec<f32> {
        let (k3, ci, co) = (self.sh.k.pow(3), self.sh.cin, self.sh.cout);
        let mut w = vec![0.0; k3 * ci * co];
        for o in 0..co {
            for i in 0..ci {
                for t in 0..k3 {
                    w[(o * ci + i) * k3 + t] = values[(t * ci + i) * co + o];
                }
            }
        }
        w
    }

    fn weights(&self, values: &[f32]) -> ConvWeights {
        ConvWeights {
            weight: self.to_burn(values),
            bias: None,
            in_channels: self.sh.cin,
            out_channels: self.sh.cout,
            kernel: self.sh.k,
            stride: self.sh.stride,
            padding: self.sh.pad,
        }
    }

    /// Weight gradients of every sample (summed into `p.grad`) and, with
    /// `dx`, the input gradients (`accumulate`: added to what `dx` holds).
    #[allow(clippy::too_many_arguments)]
    fn backward(
        &mut self,
        level: Level,
        x: &[f32],
        n: usize,
        dz: &[f32],
        samples: usize,
        dx: Option<&mut [f32]>,
        accumulate: bool,
    ) {
        let (xs, zs) = (x.len() / samples, dz.len() / samples);
        let len = self.p.value.len();
        let this = &*self;
        let group = |xg: &[f32], zg: &[f32], dxg: Option<&mut [f32]>| {
            let mut dw = vec![0.0f32; len];
            for (xv, zv) in xg.chunks_exact(xs).zip(zg.chunks_exact(zs)) {
                conv_grad::weight_grad(level, &this.sh, xv, zv, n, &mut dw);
            }
            if let Some(d) = dxg {
                for (dv, zv) in d.chunks_exact_mut(xs).zip(zg.chunks_exact(zs)) {
                    conv_grad::input_grad(level, &this.sh, &this.wt, zv, n, dv, accumulate);
                }
            }
            dw
        };
        let partial: Vec<Vec<f32>> = match dx {
            Some(dx) => x
                .par_chunks(GROUP * xs)
                .zip(dz.par_chunks(GROUP * zs))
                .zip(dx.par_chunks_mut(GROUP * xs))
                .map(|((xg, zg), dxg)| group(xg, zg, Some(dxg)))
                .collect(),
            None => x
                .par_chunks(GROUP * xs)
                .zip(dz.par_chunks(GROUP * zs))
                .map(|(xg, zg)| group(xg, zg, None))
                .collect(),
        };
        add_in_order(&mut self.p.grad, &partial);
    }
}

fn add_in_order(grad: &mut [f32], partial: &[Vec<f32>]) {
    for p in partial {
        for (g, &v) in grad.iter_mut().zip(p) {
            *g += v;
        }
    }
}

/// A fully connected layer being trained: weights `[in][out]`, bias `[out]`.
#[derive(Clone, Debug)]
struct Linear {
    w: Param,
    b: Param,
    nin: usize,
    nout: usize,
}

impl Linear {
    fn new(l: &LinearWeights, layer: &str) -> Result<Linear, CnnError> {
        l.check(layer)?;
        Ok(Linear {
            w: Param::new(l.weight.clone()),
            b: Param::new(l.bias.clone().unwrap_or_else(|| vec![0.0; l.out_features])),
            nin: l.in_features,
            nout: l.out_features,
        })
    }

    fn weights(&self, w: &[f32], b: &[f32]) -> LinearWeights {
        LinearWeights {
            weight: w.to_vec(),
            bias: Some(b.to_vec()),
            in_features: self.nin,
            out_features: self.nout,
        }
    }

    /// `z[s] = x[s]·W + b` for every sample.
    fn forward(&self, x: &[f32], z: &mut [f32]) {
        let (w, b, no) = (&self.w.value, &self.b.value, self.nout);
        z.par_chunks_mut(no)
            .zip(x.par_chunks(self.nin))
            .for_each(|(zr, xr)| {
                zr.copy_from_slice(b);
                for (i, &xv) in xr.iter().enumerate() {
                    if xv != 0.0 {
                        for (o, &wv) in zr.iter_mut().zip(&w[i * no..(i + 1) * no]) {
                            *o += xv * wv;
                        }
                    }
                }
            });
    }

    /// Adds `∂L/∂W`, `∂L/∂b`; writes `∂L/∂x` into `dx` when given.
    fn backward(&mut self, x: &[f32], dz: &[f32], dx: Option<&mut [f32]>) {
        let (ni, no) = (self.nin, self.nout);
        let samples = dz.len() / no;
        self.w
            .grad
            .par_chunks_mut(no)
            .enumerate()
            .for_each(|(i, gr)| {
                for s in 0..samples {
                    let xv = x[s * ni + i];
                    if xv != 0.0 {
                        for (g, &d) in gr.iter_mut().zip(&dz[s * no..(s + 1) * no]) {
                            *g += xv * d;
                        }
                    }
                }
            });
        for s in 0..samples {
            for (g, &d) in self.b.grad.iter_mut().zip(&dz[s * no..(s + 1) * no]) {
                *g += d;
            }
        }
        if let Some(dx) = dx {
            let w = &self.w.value;
            dx.par_chunks_mut(ni)
                .zip(dz.par_chunks(no))
                .for_each(|(dxr, dzr)| {
                    for (i, d) in dxr.iter_mut().enumerate() {
                        let row = &w[i * no..(i + 1) * no];
                        *d = row.iter().zip(dzr).map(|(a, b)| a * b).sum();
                    }
                });
        }
    }
}

#[derive(Clone, Debug)]
struct Block {
    a: Conv,
    bn_a: BatchNorm,
    b: Conv,
    bn_b: BatchNorm,
    s: Conv,
    bn_s: BatchNorm,
    /// input side
    n: usize,
    /// output side
    m: usize,
}

/// Activations of one block for a batch (`[samples][m³][c]`).
#[derive(Default)]
struct BlockCache {
    /// with fake quantization: the block's input on its int8 steps (what
    /// conv a and the shortcut read)
    xq: Vec<f32>,
    za: Vec<f32>,
    aa: Vec<f32>,
    /// with fake quantization: `aa` on its int8 steps (what conv b reads)
    aaq: Vec<f32>,
    zb: Vec<f32>,
    zs: Vec<f32>,
    out: Vec<f32>,
    st_a: BatchStats,
    st_b: BatchStats,
    st_s: BatchStats,
}

/// Activations of the last batch, kept for the backward pass.
#[derive(Default)]
struct Cache {
    samples: usize,
    occupied: Vec<Occupied>,
    z0: Vec<f32>,
    a0: Vec<f32>,
    st0: BatchStats,
    blocks: Vec<BlockCache>,
    pooled: Vec<f32>,
    argmax: Vec<u32>,
    /// per hidden layer: pre-BN values, post-ReLU values, statistics
    fc: Vec<(Vec<f32>, Vec<f32>, BatchStats)>,
    out: Vec<f32>,
}

/// Wall time per phase of a step, summed over steps (when switched on).
#[derive(Default)]
struct Profile {
    on: bool,
    last: Option<std::time::Instant>,
    phases: Vec<(String, f64)>,
}

impl Profile {
    fn start(&mut self) {
        if self.on {
            self.last = Some(std::time::Instant::now());
        }
    }

    /// Charges the time since the last lap to `phase`.
    fn lap(&mut self, phase: impl FnOnce() -> String) {
        if let Some(last) = self.last {
            let now = std::time::Instant::now();
            let name = phase();
            let dt = (now - last).as_secs_f64();
            match self.phases.iter_mut().find(|(n, _)| *n == name) {
                Some(p) => p.1 += dt,
                None => self.phases.push((name, dt)),
            }
            self.last = Some(now);
        }
    }
}

/// A NormalNet network being trained on the CPU engine.
pub struct Trainer {
    grid: usize,
    level: Level,
    adam: AdamConfig,
    /// Adam steps taken
    t: i32,
    stem: Conv,
    stem_bn: BatchNorm,
    stem_side: usize,
    blocks: Vec<Block>,
    hidden: Vec<(Linear, BatchNorm)>,
    output: Linear,
    cache: Cache,
    prof: Profile,
    /// quantization-aware training: the int8 steps every convolution's
    /// weights and inputs are rounded to in the forward pass
    quant: Option<Int8Range>,
}

/// `y = relu(scale·z + shift)` per channel, in parallel over samples.
fn bn_relu(z: &[f32], st: &BatchStats, y: &mut [f32], per: usize) {
    let c = st.scale.len();
    y.par_chunks_mut(per)
        .zip(z.par_chunks(per))
        .for_each(|(ys, zs)| {
            for (yr, zr) in ys.chunks_exact_mut(c).zip(zs.chunks_exact(c)) {
                for j in 0..c {
                    yr[j] = (zr[j] * st.scale[j] + st.shift[j]).max(0.0);
                }
            }
        });
}

/// `g ⊙= [y > 0]` (the ReLU's backward pass, from its output).
fn relu_mask(g: &mut [f32], y: &[f32]) {
    g.par_chunks_mut(1 << 14)
        .zip(y.par_chunks(1 << 14))
        .for_each(|(gs, ys)| {
            for (g, &y) in gs.iter_mut().zip(ys) {
                if y <= 0.0 {
                    *g = 0.0;
                }
            }
        });
}

impl Trainer {
    /// Starts training from `weights` (conv layers without bias, as
    /// `normalnet-net` builds them).
    ///
    /// # Errors
    /// [`CnnError`] naming a layer whose shapes do not fit together, or a
    /// channel count the kernels are not compiled for.
    pub fn new(weights: &NetWeights) -> Result<Trainer, CnnError> {
        // the inference engine checks the whole architecture
        crate::Cnn::new(weights)?;
        let stem = Conv::new(&weights.stem, "stem")?;
        let stem_side = stem.sh.output_side(weights.grid);
        let mut blocks = Vec::new();
        let mut n = stem_side;
        for (i, bw) in weights.blocks.iter().enumerate() {
            let name = |w: &str| format!("block {} {w}", i + 1);
            let BlockWeights {
                conv_a,
                bn_a,
                conv_b,
                bn_b,
                shortcut,
                bn_shortcut,
            } = bw;
            let a = Conv::new(conv_a, &name("conv_a"))?;
            let m = a.sh.output_side(n);
            blocks.push(Block {
                a,
                bn_a: BatchNorm::new(bn_a),
                b: Conv::new(conv_b, &name("conv_b"))?,
                bn_b: BatchNorm::new(bn_b),
                s: Conv::new(shortcut, &name("shortcut"))?,
                bn_s: BatchNorm::new(bn_shortcut),
                n,
                m,
            });
            n = m;
        }
        let hidden = weights
            .hidden
            .iter()
            .enumerate()
            .map(|(i, (l, bn))| {
                Ok((
                    Linear::new(l, &format!("hidden {}", i + 1))?,
                    BatchNorm::new(bn),
                ))
            })
            .collect::<Result<Vec<_>, CnnError>>()?;
        Ok(Trainer {
            grid: weights.grid,
            level: Level::detect(),
            adam: AdamConfig::default(),
            t: 0,
            stem,
            stem_bn: BatchNorm::new(&weights.stem_bn),
            stem_side,
            blocks,
            hidden,
            output: Linear::new(&weights.output, "output")?,
            cache: Cache::default(),
            prof: Profile::default(),
            quant: None,
        })
    }

    /// Length of one input grid, `3 · D · H · W`.
    pub fn grid_len(&self) -> usize {
        3 * self.grid.pow(3)
    }

    /// Number of outputs per sample.
    pub fn outputs(&self) -> usize {
        self.output.nout
    }

    /// Adam steps taken so far.
    pub fn steps(&self) -> i32 {
        self.t
    }

    /// The current weights and running statistics.
    pub fn weights(&self) -> NetWeights {
        self.collect(false)
    }

    /// The gradients summed by [`Trainer::forward_backward`] since the last
    /// [`Trainer::zero_grad`], laid out like [`Trainer::weights`] (the
    /// batch-norm running statistics are zero).
    pub fn gradients(&self) -> NetWeights {
        self.collect(true)
    }

    fn collect(&self, grad: bool) -> NetWeights {
        let pick = |p: &Param| {
            if grad {
                p.grad.clone()
            } else {
                p.value.clone()
            }
        };
        let bn = |b: &BatchNorm| {
            let mut w = b.weights();
            if grad {
                w.gamma = b.gamma.grad.clone();
                w.beta = b.beta.grad.clone();
                w.mean.fill(0.0);
                w.var.fill(0.0);
            }
            w
        };
        let conv = |c: &Conv| c.weights(&pick(&c.p));
        let lin = |l: &Linear| l.weights(&pick(&l.w), &pick(&l.b));
        NetWeights {
            grid: self.grid,
            stem: conv(&self.stem),
            stem_bn: bn(&self.stem_bn),
            blocks: self
                .blocks
                .iter()
                .map(|b| BlockWeights {
                    conv_a: conv(&b.a),
                    bn_a: bn(&b.bn_a),
                    conv_b: conv(&b.b),
                    bn_b: bn(&b.bn_b),
                    shortcut: conv(&b.s),
                    bn_shortcut: bn(&b.bn_s),
                })
                .collect(),
            hidden: self.hidden.iter().map(|(l, b)| (lin(l), bn(b))).collect(),
            output: lin(&self.output),
        }
    }

    fn params_mut(&mut self) -> Vec<&mut Param> {
        let mut v: Vec<&mut Param> = vec![
            &mut self.stem.p,
            &mut self.stem_bn.gamma,
            &mut self.stem_bn.beta,
        ];
        for b in &mut self.blocks {
            v.extend([
                &mut b.a.p,
                &mut b.bn_a.gamma,
                &mut b.bn_a.beta,
                &mut b.b.p,
                &mut b.bn_b.gamma,
                &mut b.bn_b.beta,
                &mut b.s.p,
                &mut b.bn_s.gamma,
                &mut b.bn_s.beta,
            ]);
        }
        for (l, bn) in &mut self.hidden {
            v.extend([&mut l.w, &mut l.b, &mut bn.gamma, &mut bn.beta]);
        }
        v.extend([&mut self.output.w, &mut self.output.b]);
        v
    }

    /// Quantization-aware training: with `Some(range)`, the forward pass
    /// rounds every convolution's weights (per output channel) and inputs
    /// (per sample: the stem's signed values, the blocks' inputs) to the
    /// steps the int8 inference uses with `range`, and gradients pass the
    /// rounding straight through; `None` (a new trainer's): f32 throughout.
    /// The weights kept and exported stay f32.
    pub fn set_fake_quant(&mut self, range: Option<Int8Range>) {
        self.quant = range;
        let convs = std::iter::once(&mut self.stem).chain(
            self.blocks
                .iter_mut()
                .flat_map(|b| [&mut b.a, &mut b.b, &mut b.s]),
        );
        for conv in convs {
            conv.quant = range;
            conv.refresh();
        }
    }

    /// The int8 steps of quantization-aware training, if on.
    pub fn fake_quant(&self) -> Option<Int8Range> {
        self.quant
    }

    /// Switches the per-phase timing on or off (and clears it).
    pub fn profile(&mut self, on: bool) {
        self.prof = Profile {
            on,
            ..Profile::default()
        };
    }

    /// Seconds spent per phase (layer, forward / backward) since
    /// [`Trainer::profile`] switched timing on.
    pub fn profile_report(&self) -> Vec<(String, f64)> {
        self.prof.phases.clone()
    }

    fn running_mut(&mut self) -> Vec<&mut Vec<f32>> {
        let mut v: Vec<&mut BatchNorm> = vec![&mut self.stem_bn];
        for b in &mut self.blocks {
            v.extend([&mut b.bn_a, &mut b.bn_b, &mut b.bn_s]);
        }
        for (_, bn) in &mut self.hidden {
            v.push(bn);
        }
        v.into_iter()
            .flat_map(|b| [&mut b.running_mean, &mut b.running_var])
            .collect()
    }

    /// The whole training state — weights, Adam moments and step count,
    /// running statistics — as bytes, for resumable checkpoints.
    pub fn state_bytes(&mut self) -> Vec<u8> {
        let mut out = STATE_MAGIC.to_vec();
        out.extend_from_slice(&self.t.to_le_bytes());
        for p in self.params_mut() {
            for a in [&p.value, &p.m, &p.v] {
                a.iter()
                    .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
            }
        }
        for r in self.running_mut() {
            r.iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        out
    }

    /// Restores a state written by [`Trainer::state_bytes`] of a network
    /// of the same architecture.
    ///
    /// # Errors
    /// [`CnnError::BufferSize`] when `bytes` is not such a state.
    pub fn load_state_bytes(&mut self, bytes: &[u8]) -> Result<(), CnnError> {
        let floats: usize = self
            .params_mut()
            .iter()
            .map(|p| 3 * p.value.len())
            .sum::<usize>()
            + self.running_mut().iter().map(|r| r.len()).sum::<usize>();
        let expected = STATE_MAGIC.len() + 4 + 4 * floats;
        if bytes.len() != expected || !bytes.starts_with(STATE_MAGIC) {
            return Err(CnnError::BufferSize {
                what: "training state",
                actual: bytes.len(),
                expected,
            });
        }
        let mut at = STATE_MAGIC.len();
        self.t = i32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        at += 4;
        let mut read = |a: &mut Vec<f32>| {
            for x in a.iter_mut() {
                *x = f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
                at += 4;
            }
        };
        for p in self.params_mut() {
            read(&mut p.value);
            read(&mut p.m);
            read(&mut p.v);
        }
        for r in self.running_mut() {
            read(r);
        }
        self.stem.refresh();
        for b in &mut self.blocks {
            b.a.refresh();
            b.b.refresh();
            b.s.refresh();
        }
        Ok(())
    }

    /// Sets every gradient to zero.
    pub fn zero_grad(&mut self) {
        for p in self.params_mut() {
            p.grad.fill(0.0);
        }
    }

    /// One Adam step with learning rate `lr` on the summed gradients.
    pub fn adam_step(&mut self, lr: f64) {
        self.prof.start();
        self.t += 1;
        let (c, t) = (self.adam, self.t);
        for p in self.params_mut() {
            p.adam(&c, lr as f32, t);
        }
        self.stem.refresh();
        for b in &mut self.blocks {
            b.a.refresh();
            b.b.refresh();
            b.s.refresh();
        }
        self.prof.lap(|| "adam".into());
    }

    /// `zero_grad`, forward + backward on the batch, Adam step; returns the
    /// batch loss before the step.
    ///
    /// # Errors
    /// As [`Trainer::forward_backward`].
    pub fn train_step(
        &mut self,
        grids: &[f32],
        targets: &[f32],
        loss: Loss,
        lr: f64,
    ) -> Result<f64, CnnError> {
        self.zero_grad();
        let l = self.forward_backward(grids, targets, loss)?;
        self.adam_step(lr);
        Ok(l)
    }

    fn check_batch(&self, grids: &[f32], targets: &[f32]) -> Result<usize, CnnError> {
        let g = self.grid_len();
        let samples = grids.len() / g;
        if grids.is_empty() || !grids.len().is_multiple_of(g) {
            return Err(CnnError::BufferSize {
                what: "grid batch",
                actual: grids.len(),
                expected: samples.max(1) * g,
            });
        }
        if targets.len() != samples * self.outputs() {
            return Err(CnnError::BufferSize {
                what: "target batch",
                actual: targets.len(),
                expected: samples * self.outputs(),
            });
        }
        Ok(samples)
    }

    /// The loss of the batch in training mode (batch statistics), without
    /// gradients and without touching the running statistics.
    ///
    /// # Errors
    /// [`CnnError::BufferSize`] when the buffers do not hold whole samples.
    pub fn loss(&mut self, grids: &[f32], targets: &[f32], loss: Loss) -> Result<f64, CnnError> {
        let samples = self.check_batch(grids, targets)?;
        self.forward(grids, samples, false);
        Ok(self.loss_and_grad(targets, loss, None))
    }

    /// Forward pass in training mode, loss, backward pass: gradients are
    /// added to the parameters' (see [`Trainer::zero_grad`]); the running
    /// statistics of batch norm are updated. Returns the batch loss.
    ///
    /// # Shapes
    /// - `grids`: `[batch, 3, D, H, W]` flat, channel-major per sample
    /// - `targets`: `[batch, outputs]`
    ///
    /// # Errors
    /// [`CnnError::BufferSize`] when the buffers do not hold whole samples.
    pub fn forward_backward(
        &mut self,
        grids: &[f32],
        targets: &[f32],
        loss: Loss,
    ) -> Result<f64, CnnError> {
        let samples = self.check_batch(grids, targets)?;
        self.forward(grids, samples, true);
        let mut dy = vec![0.0f32; samples * self.outputs()];
        let l = self.loss_and_grad(targets, loss, Some(&mut dy));
        self.backward(dy);
        Ok(l)
    }

    /// Network outputs of the last forward pass, `[batch, outputs]`.
    pub fn last_outputs(&self) -> &[f32] {
        &self.cache.out
    }

    fn forward(&mut self, grids: &[f32], samples: usize, update: bool) {
        self.prof.start();
        let lv = self.level;
        let c = &mut self.cache;
        c.samples = samples;
        let g = 3 * self.grid.pow(3);
        c.occupied.resize_with(samples, Occupied::default);
        let quant = self.quant;
        c.occupied
            .par_iter_mut()
            .zip(grids.par_chunks(g))
            .for_each(|(o, grid)| {
                o.gather(grid, 3);
                if let Some(range) = quant {
                    fake_quant::stem_inputs(&mut o.values, range);
                }
            });
        // stem
        let n = self.stem_side;
        let per = n * n * n * self.stem.sh.cout;
        c.z0.resize(samples * per, 0.0);
        c.a0.resize(samples * per, 0.0);
        let (stem, grid) = (&self.stem, self.grid);
        c.z0.par_chunks_mut(per)
            .zip(&c.occupied)
            .for_each(|(z, o)| stem.folded.run_sparse(lv, o, grid, z, false));
        c.st0 = self.stem_bn.stats(&c.z0, samples, update);
        bn_relu(&c.z0, &c.st0, &mut c.a0, per);
        self.prof.lap(|| "stem forward".into());
        // blocks
        c.blocks.resize_with(self.blocks.len(), BlockCache::default);
        for (bi, b) in self.blocks.iter_mut().enumerate() {
            let (before, rest) = c.blocks.split_at_mut(bi);
            let bc = &mut rest[0];
            let x: &[f32] = if bi == 0 { &c.a0 } else { &before[bi - 1].out };
            let (n, m, co) = (b.n, b.m, b.a.sh.cout);
            let xs = n * n * n * b.a.sh.cin;
            let per = m * m * m * co;
            for v in [&mut bc.za, &mut bc.aa, &mut bc.zb, &mut bc.zs, &mut bc.out] {
                v.resize(samples * per, 0.0);
            }
            let x: &[f32] = match quant {
                Some(range) => {
                    bc.xq.resize(x.len(), 0.0);
                    fake_quant::block_inputs(x, xs, range, &mut bc.xq);
                    &bc.xq
                }
                None => x,
            };
            let (ca, cs) = (&b.a.folded, &b.s.folded);
            bc.za
                .par_chunks_mut(per)
                .zip(bc.zs.par_chunks_mut(per))
                .zip(x.par_chunks(xs))
                .for_each(|((za, zs), x)| {
                    ca.run(lv, x, n, za, false, false, None);
                    cs.run(lv, x, n, zs, false, false, None);
                });
            bc.st_a = b.bn_a.stats(&bc.za, samples, update);
            bn_relu(&bc.za, &bc.st_a, &mut bc.aa, per);
            let aa: &[f32] = match quant {
                Some(range) => {
                    bc.aaq.resize(bc.aa.len(), 0.0);
                    fake_quant::block_inputs(&bc.aa, per, range, &mut bc.aaq);
                    &bc.aaq
                }
                None => &bc.aa,
            };
            let cb = &b.b.folded;
            bc.zb
                .par_chunks_mut(per)
                .zip(aa.par_chunks(per))
                .for_each(|(zb, aa)| cb.run(lv, aa, m, zb, false, false, None));
            bc.st_b = b.bn_b.stats(&bc.zb, samples, update);
            bc.st_s = b.bn_s.stats(&bc.zs, samples, update);
            let (sb, ss) = (&bc.st_b, &bc.st_s);
            bc.out
                .par_chunks_mut(per)
                .zip(bc.zb.par_chunks(per).zip(bc.zs.par_chunks(per)))
                .for_each(|(o, (zb, zs))| {
                    for ((or, br), sr) in o
                        .chunks_exact_mut(co)
                        .zip(zb.chunks_exact(co))
                        .zip(zs.chunks_exact(co))
                    {
                        for j in 0..co {
                            or[j] = (br[j] * sb.scale[j]
                                + sb.shift[j]
                                + sr[j] * ss.scale[j]
                                + ss.shift[j])
                                .max(0.0);
                        }
                    }
                });
            self.prof.lap(|| format!("block {} forward", bi + 1));
        }
        // global max pool
        let last = c.blocks.last().map_or(&c.a0, |b| &b.out);
        let ch = self
            .blocks
            .last()
            .map_or(self.stem.sh.cout, |b| b.a.sh.cout);
        let per = last.len() / samples;
        c.pooled.resize(samples * ch, 0.0);
        c.argmax.resize(samples * ch, 0);
        c.pooled
            .par_chunks_mut(ch)
            .zip(c.argmax.par_chunks_mut(ch))
            .zip(last.par_chunks(per))
            .for_each(|((p, a), x)| {
                p.fill(f32::NEG_INFINITY);
                for (cube, row) in x.chunks_exact(ch).enumerate() {
                    for j in 0..ch {
                        if row[j] > p[j] {
                            p[j] = row[j];
                            a[j] = cube as u32;
                        }
                    }
                }
            });
        // fully connected
        c.fc.resize_with(self.hidden.len(), Default::default);
        for (i, (l, bn)) in self.hidden.iter_mut().enumerate() {
            let (before, rest) = c.fc.split_at_mut(i);
            let (z, h, st) = &mut rest[0];
            let x: &[f32] = if i == 0 { &c.pooled } else { &before[i - 1].1 };
            z.resize(samples * l.nout, 0.0);
            h.resize(samples * l.nout, 0.0);
            l.forward(x, z);
            *st = bn.stats(z, samples, update);
            bn_relu(z, st, h, l.nout);
        }
        let x: &[f32] = c.fc.last().map_or(&c.pooled, |f| &f.1);
        c.out.resize(samples * self.output.nout, 0.0);
        self.output.forward(x, &mut c.out);
        for v in &mut c.out {
            *v = v.tanh();
        }
        self.prof.lap(|| "pool + fc forward".into());
    }

    /// The loss of the cached outputs; with `dy`, its gradient w.r.t. the
    /// pre-tanh outputs.
    fn loss_and_grad(&self, targets: &[f32], loss: Loss, dy: Option<&mut [f32]>) -> f64 {
        let y = &self.cache.out;
        let count = y.len() as f64;
        let total: f64 = match loss {
            Loss::Mse => y
                .iter()
                .zip(targets)
                .map(|(&a, &b)| ((a - b) as f64).powi(2))
                .sum(),
            Loss::L1 => y
                .iter()
                .zip(targets)
                .map(|(&a, &b)| ((a - b) as f64).abs())
                .sum(),
        };
        if let Some(dy) = dy {
            for ((d, &a), &b) in dy.iter_mut().zip(y).zip(targets) {
                let g = match loss {
                    Loss::Mse => 2.0 * (a - b) as f64 / count,
                    Loss::L1 => ((a - b) as f64).signum() / count,
                };
                *d = (g * (1.0 - (a as f64) * (a as f64))) as f32;
            }
        }
        total / count
    }

    fn backward(&mut self, mut dz: Vec<f32>) {
        self.prof.start();
        let lv = self.level;
        let c = &self.cache;
        let samples = c.samples;
        // fully connected, last to first
        let last_x: &[f32] = c.fc.last().map_or(&c.pooled, |f| &f.1);
        let mut dx = vec![0.0f32; last_x.len()];
        self.output.backward(last_x, &dz, Some(&mut dx));
        for i in (0..self.hidden.len()).rev() {
            let (z, _, st) = &c.fc[i];
            let mut g = dx;
            let (l, bn) = &mut self.hidden[i];
            bn.backward(st, z, &mut g, samples, true);
            let x: &[f32] = if i == 0 { &c.pooled } else { &c.fc[i - 1].1 };
            dx = vec![0.0f32; x.len()];
            l.backward(x, &g, Some(&mut dx));
        }
        // max pool
        let ch = c.pooled.len() / samples;
        let last = c.blocks.last().map_or(&c.a0, |b| &b.out);
        let per = last.len() / samples;
        let mut d_out = vec![0.0f32; last.len()];
        d_out
            .par_chunks_mut(per)
            .zip(dx.par_chunks(ch).zip(c.argmax.par_chunks(ch)))
            .for_each(|(d, (g, a))| {
                for j in 0..ch {
                    d[a[j] as usize * ch + j] = g[j];
                }
            });
        self.prof.lap(|| "fc + pool backward".into());
        // residual blocks, last to first
        for bi in (0..self.blocks.len()).rev() {
            let bc = &c.blocks[bi];
            let b = &mut self.blocks[bi];
            // the inputs the forward pass read (with fake quantization, on
            // their steps; the gradients pass the rounding straight through)
            let (x, aa): (&[f32], &[f32]) = match self.quant {
                Some(_) => (&bc.xq, &bc.aaq),
                None if bi == 0 => (&c.a0, &bc.aa),
                None => (&c.blocks[bi - 1].out, &bc.aa),
            };
            relu_mask(&mut d_out, &bc.out);
            let mut d_zs = d_out.clone();
            b.bn_b
                .backward(&bc.st_b, &bc.zb, &mut d_out, samples, false);
            b.bn_s.backward(&bc.st_s, &bc.zs, &mut d_zs, samples, false);
            let mut d_aa = vec![0.0f32; bc.aa.len()];
            b.b.backward(lv, aa, b.m, &d_out, samples, Some(&mut d_aa), false);
            b.bn_a.backward(&bc.st_a, &bc.za, &mut d_aa, samples, true);
            let mut d_x = vec![0.0f32; x.len()];
            b.a.backward(lv, x, b.n, &d_aa, samples, Some(&mut d_x), false);
            b.s.backward(lv, x, b.n, &d_zs, samples, Some(&mut d_x), true);
            d_out = d_x;
            self.prof.lap(|| format!("block {} backward", bi + 1));
        }
        // stem: weight gradient scattered from the occupied cubes
        self.stem_bn
            .backward(&c.st0, &c.z0, &mut d_out, samples, true);
        dz.clear();
        let per = d_out.len() / samples;
        let (sh, grid, len) = (self.stem.sh, self.grid, self.stem.p.value.len());
        let partial: Vec<Vec<f32>> = d_out
            .par_chunks(GROUP * per)
            .zip(c.occupied.par_chunks(GROUP))
            .map(|(dg, og)| {
                let mut dw = vec![0.0f32; len];
                for (d, o) in dg.chunks_exact(per).zip(og) {
                    conv_grad::stem_weight_grad(lv, &sh, o, grid, d, &mut dw);
                }
                dw
            })
            .collect();
        add_in_order(&mut self.stem.p.grad, &partial);
        self.prof.lap(|| "stem backward".into());
    }
}
