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

/// Per-channel sums over each sample, then over samples in order.
fn channel_sums(
    data: &[f32],
    samples: usize,
    c: usize,
    f: impl Fn(usize, f32) -> f64 + Sync,
) -> Vec<f64> {
    let per = data.len() / samples;
    let partial: Vec<Vec<f64>> = data
        .par_chunks(per)
        .map(|s| {
            let mut acc = vec![0.0f64; c];
            // sum rows in f32 blocks of 64 cubes, then into f64: exact enough
            // and vectorises
            for block in s.chunks(64 * c) {
                let mut b = vec![0.0f32; c];
                for row in block.chunks_exact(c) {
                    for (j, (a, &v)) in b.iter_mut().zip(row).enumerate() {
                        *a += f(j, v) as f32;
                    }
                }
                for (a, &v) in acc.iter_mut().zip(&b) {
                    *a += v as f64;
                }
            }
            acc
        })
        .collect();
    let mut total = vec![0.0f64; c];
    for p in &partial {
        for (t, &v) in total.iter_mut().zip(p) {
            *t += v;
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
    /// statistics when `update`.
    pub(crate) fn stats(&mut self, data: &[f32], samples: usize, update: bool) -> BatchStats {
        let c = self.channels();
        let count = (data.len() / c) as f64;
        let mean: Vec<f64> = channel_sums(data, samples, c, |_, v| v as f64)
            .into_iter()
            .map(|s| s / count)
            .collect();
        let mean32: Vec<f32> = mean.iter().map(|&m| m as f32).collect();
        let var: Vec<f64> = channel_sums(data, samples, c, |j, v| {
            let d = v - mean32[j];
            (d * d) as f64
        })
        .into_iter()
        .map(|s| s / count)
        .collect();
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
        let scale: Vec<f32> = (0..c)
            .map(|j| self.gamma.value[j] * inv_std[j])
            .collect();
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
    /// input, `[samples][cubes][c]`.
    pub(crate) fn backward(&mut self, st: &BatchStats, z: &[f32], g: &mut [f32], samples: usize) {
        let c = self.channels();
        let count = (z.len() / c) as f64;
        let sum_g = channel_sums(g, samples, c, |_, v| v as f64);
        // Σ g·x̂ = inv_std · Σ g·(z − mean)
        let per = z.len() / samples;
        let partial: Vec<Vec<f64>> = z
            .par_chunks(per)
            .zip(g.par_chunks(per))
            .map(|(zs, gs)| {
                let mut acc = vec![0.0f64; c];
                for (zb, gb) in zs.chunks(64 * c).zip(gs.chunks(64 * c)) {
                    let mut b = vec![0.0f32; c];
                    for (zr, gr) in zb.chunks_exact(c).zip(gb.chunks_exact(c)) {
                        for j in 0..c {
                            b[j] += gr[j] * (zr[j] - st.mean[j]);
                        }
                    }
                    for (a, &v) in acc.iter_mut().zip(&b) {
                        *a += v as f64;
                    }
                }
                acc
            })
            .collect();
        let mut sum_gx = vec![0.0f64; c];
        for p in &partial {
            for (t, &v) in sum_gx.iter_mut().zip(p) {
                *t += v;
            }
        }
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
