//! Batch norm in training mode over channels-last activations
//! `[samples][cubes][c]`: batch statistics (biased variance, as burn and
//! PyTorch normalise), running statistics updated with momentum 0.1, and
//! the backward pass. Reductions are summed per sample in f64 and then in
//! sample order, so results do not depend on the thread count.

use rayon::prelude::*;

use super::param::Param;
use crate::weights::BatchNormWeights;

/// Momentum of the running statistics (burn's and PyTorch's default).
const MOMENTUM: f64 = 0.1;

/// A batch norm layer being trained.
#[derive(Clone, Debug)]
pub(crate) struct BatchNorm {
    pub gamma: Param,
    pub beta: Param,
    pub running_mean: Vec<f32>,
    pub running_var: Vec<f32>,
    pub epsilon: f64,
}

/// Statistics of one batch and the affine map `y = scale·z + shift` they give.
#[derive(Clone, Debug, Default)]
pub(crate) struct BatchStats {
    pub mean: Vec<f32>,
    pub inv_std: Vec<f32>,
    pub scale: Vec<f32>,
    pub shift: Vec<f32>,
}

/// Two per-channel sums `(Σ f, Σ g)` over `data` (and `other`, the same
/// shape, when given): f32 within blocks of 64 cubes, f64 across blocks,
/// samples in order (thread-count independent).
fn channel_sums2(
    data: &[f32],
    other: Option<&[f32]>,
    samples: usize,
    c: usize,
    f: impl Fn(usize, f32, f32) -> (f32, f32) + Sync,
) -> (Vec<f64>, Vec<f64>) {
    let per = data.len() / samples;
    let one = |s: usize| {
        let d = &data[s * per..(s + 1) * per];
        let o = other.map(|o| &o[s * per..(s + 1) * per]);
        let mut acc = (vec![0.0f64; c], vec![0.0f64; c]);
        let (mut a, mut b) = (vec![0.0f32; c], vec![0.0f32; c]);
        for start in (0..per).step_by(64 * c) {
            let end = (start + 64 * c).min(per);
            a.fill(0.0);
            b.fill(0.0);
            for r in (start..end).step_by(c) {
                let row = &d[r..r + c];
                match o {
                    Some(o) => {
                        let orow = &o[r..r + c];
                        for j in 0..c {
                            let (x, y) = f(j, row[j], orow[j]);
                            a[j] += x;
                            b[j] += y;
                        }
                    }
                    None => {
                        for j in 0..c {
                            let (x, y) = f(j, row[j], 0.0);
                            a[j] += x;
                            b[j] += y;
                        }
                    }
                }
            }
            for j in 0..c {
                acc.0[j] += a[j] as f64;
                acc.1[j] += b[j] as f64;
            }
        }
        acc
    };
    let partial: Vec<(Vec<f64>, Vec<f64>)> = (0..samples).into_par_iter().map(one).collect();
    let mut total = (vec![0.0f64; c], vec![0.0f64; c]);
    for (a, b) in &partial {
        for j in 0..c {
            total.0[j] += a[j];
            total.1[j] += b[j];
        }
    }
    total
}

impl BatchNorm {
    pub(crate) fn new(w: &BatchNormWeights) -> BatchNorm {
        BatchNorm {
            gamma: Param::new(w.gamma.clone()),
            beta: Param::new(w.beta.clone()),
            running_mean: w.mean.clone(),
            running_var: w.var.clone(),
            epsilon: w.epsilon,
        }
    }

    pub(crate) fn weights(&self) -> BatchNormWeights {
        BatchNormWeights {
            gamma: self.gamma.value.clone(),
            beta: self.beta.value.clone(),
            mean: self.running_mean.clone(),
            var: self.running_var.clone(),
            epsilon: self.epsilon,
        }
    }

    pub(crate) fn channels(&self) -> usize {
        self.gamma.value.len()
    }

    /// Statistics of `data` (`[samples][cubes][c]`); updates the running
    /// statistics when `update`. One pass: sums of `z − K` and `(z − K)²`
    /// with `K` the running mean (close to the batch mean, so no
    /// cancellation).
    pub(crate) fn stats(&mut self, data: &[f32], samples: usize, update: bool) -> BatchStats {
        let c = self.channels();
        let count = (data.len() / c) as f64;
        let k = self.running_mean.clone();
        let (s1, s2) = channel_sums2(data, None, samples, c, |j, v, _| {
            let d = v - k[j];
            (d, d * d)
        });
        let mean: Vec<f64> = (0..c).map(|j| k[j] as f64 + s1[j] / count).collect();
        let var: Vec<f64> = (0..c)
            .map(|j| (s2[j] / count - (s1[j] / count).powi(2)).max(0.0))
            .collect();
        let mean32: Vec<f32> = mean.iter().map(|&m| m as f32).collect();
        if update {
            for j in 0..c {
                self.running_mean[j] =
                    ((1.0 - MOMENTUM) * self.running_mean[j] as f64 + MOMENTUM * mean[j]) as f32;
                self.running_var[j] =
                    ((1.0 - MOMENTUM) * self.running_var[j] as f64 + MOMENTUM * var[j]) as f32;
            }
        }
        let inv_std: Vec<f32> = var
            .iter()
            .map(|&v| (1.0 / (v + self.epsilon).sqrt()) as f32)
            .collect();
        let scale: Vec<f32> = (0..c).map(|j| self.gamma.value[j] * inv_std[j]).collect();
        let shift = (0..c)
            .map(|j| self.beta.value[j] - mean32[j] * scale[j])
            .collect();
        BatchStats {
            mean: mean32,
            inv_std,
            scale,
            shift,
        }
    }

    /// Backward pass: `g` holds `∂L/∂y` on entry and `∂L/∂z` on return;
    /// adds `∂L/∂γ`, `∂L/∂β` to the parameter gradients. `z`: the layer's
    /// input, `[samples][cubes][c]`. With `relu`, `y` is followed by a ReLU
    /// and `g` is the gradient of its output (the mask is recomputed from
    /// `z`, so the ReLU's output need not be read).
    pub(crate) fn backward(
        &mut self,
        st: &BatchStats,
        z: &[f32],
        g: &mut [f32],
        samples: usize,
        relu: bool,
    ) {
        let c = self.channels();
        let count = (z.len() / c) as f64;
        let per = z.len() / samples;
        if relu {
            // the ReLU's backward pass, its mask recomputed from z
            g.par_chunks_mut(per)
                .zip(z.par_chunks(per))
                .for_each(|(gs, zs)| {
                    for (gr, zr) in gs.chunks_exact_mut(c).zip(zs.chunks_exact(c)) {
                        for j in 0..c {
                            if zr[j] * st.scale[j] + st.shift[j] <= 0.0 {
                                gr[j] = 0.0;
                            }
                        }
                    }
                });
        }
        // Σ g and Σ g·(z − mean): plain loops (they vectorise)
        let (sum_g, mut sum_gx) = channel_sums2(g, Some(z), samples, c, |j, gv, zv| {
            (gv, gv * (zv - st.mean[j]))
        });
        for j in 0..c {
            sum_gx[j] *= st.inv_std[j] as f64;
            self.gamma.grad[j] += sum_gx[j] as f32;
            self.beta.grad[j] += sum_g[j] as f32;
        }
        // dz = γ·inv_std·(g − Σg/N − x̂·Σgx̂/N),  x̂ = (z − mean)·inv_std
        let a: Vec<f32> = (0..c)
            .map(|j| self.gamma.value[j] * st.inv_std[j])
            .collect();
        let mg: Vec<f32> = (0..c).map(|j| (sum_g[j] / count) as f32).collect();
        let mx: Vec<f32> = (0..c)
            .map(|j| (sum_gx[j] / count) as f32 * st.inv_std[j])
            .collect();
        g.par_chunks_mut(per)
            .zip(z.par_chunks(per))
            .for_each(|(gs, zs)| {
                for (gr, zr) in gs.chunks_exact_mut(c).zip(zs.chunks_exact(c)) {
                    for j in 0..c {
                        gr[j] = a[j] * (gr[j] - mg[j] - (zr[j] - st.mean[j]) * mx[j]);
                    }
                }
            });
    }
}
