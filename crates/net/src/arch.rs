//! The NormalNet architecture without any deep-learning framework (SPEC §6):
//! preset sizes ([`ModelConfig`]), the six μ_g outputs, and freshly
//! initialised weights as plain arrays ([`NetWeights`]) for the CPU engine of
//! `normalnet-cnn`.
//!
//! Layout: Conv3d 5³ stride 1 (padding 2) → BN → ReLU; three residual blocks
//! (conv 3³ stride 2 → BN → ReLU → conv 3³ → BN, plus a 1³ stride-2 projection
//! shortcut with BN; add; ReLU); global max pool; FC C→512→256→128 (each BN +
//! ReLU); FC 18; tanh. Weights are drawn from a truncated normal (He scale,
//! cut at 2σ), biases start at zero, batch norm at the identity.
//!
//! Deviation: convolutions followed by batch norm carry no bias (the BN shift
//! makes it redundant); the paper does not say.

use normalnet_cnn::{BatchNormWeights, BlockWeights, ConvWeights, LinearWeights, NetWeights};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::NetError;

/// The six guidance widths μ_g of the network outputs (SPEC §6), in output order.
pub const MU_GS: [f64; 6] = [0.25, 0.30, 0.35, 0.40, 0.45, 0.50];

/// Number of outputs per sample: one 3-vector per μ_g.
pub const NUM_OUTPUTS: usize = 3 * MU_GS.len();

/// Batch-norm ε (burn's and PyTorch's default).
pub const BN_EPSILON: f64 = 1e-5;

/// Architecture numbers of one network. Presets: [`ModelConfig::paper`],
/// [`ModelConfig::lite`] (the default on CPU), [`ModelConfig::tiny`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelConfig {
    /// Grid side D = H = W = 2·T_s + 1 (41 paper, 21 lite, 15 tiny).
    pub grid: usize,
    /// Channels of the three residual blocks; the first convolution has the
    /// first block's channel count (paper 64/128/256).
    pub channels: [usize; 3],
    /// Widths of the three hidden fully connected layers (paper 512/256/128).
    pub hidden: [usize; 3],
    /// Number of outputs (3 × number of μ_g values; 18).
    pub outputs: usize,
}

impl ModelConfig {
    /// The paper's network: 41³ grid, 64/128/256 channels.
    pub fn paper() -> ModelConfig {
        ModelConfig {
            grid: 41,
            channels: [64, 128, 256],
            hidden: [512, 256, 128],
            outputs: NUM_OUTPUTS,
        }
    }

    /// The CPU default: 21³ grid, 16/32/64 channels.
    pub fn lite() -> ModelConfig {
        ModelConfig {
            grid: 21,
            channels: [16, 32, 64],
            ..ModelConfig::paper()
        }
    }

    /// For tests and very large meshes: 15³ grid, 8/16/32 channels.
    pub fn tiny() -> ModelConfig {
        ModelConfig {
            grid: 15,
            channels: [8, 16, 32],
            ..ModelConfig::paper()
        }
    }

    /// The preset of this name (`paper`, `lite`, `tiny`).
    pub fn preset(name: &str) -> Result<ModelConfig, NetError> {
        match name {
            "paper" => Ok(ModelConfig::paper()),
            "lite" => Ok(ModelConfig::lite()),
            "tiny" => Ok(ModelConfig::tiny()),
            _ => Err(NetError::InvalidParameter {
                name: "preset",
                message: format!("unknown preset {name:?} (expected paper, lite or tiny)"),
            }),
        }
    }

    /// Checks that every size is positive.
    pub fn validate(&self) -> Result<(), NetError> {
        let bad = |name, message: &str| {
            Err(NetError::InvalidParameter {
                name,
                message: message.to_string(),
            })
        };
        if self.grid == 0 {
            return bad("grid", "must be positive");
        }
        if self.channels.contains(&0) {
            return bad("channels", "must all be positive");
        }
        if self.hidden.contains(&0) {
            return bad("hidden", "must all be positive");
        }
        if self.outputs == 0 {
            return bad("outputs", "must be positive");
        }
        Ok(())
    }

    /// Multiply-adds of one forward pass of one sample (convolutions and fully
    /// connected layers; batch norm, ReLU and pooling excluded).
    pub fn macs_per_sample(&self) -> u64 {
        let mut d = self.grid as u64;
        let c0 = self.channels[0] as u64;
        let mut macs = d * d * d * c0 * 3 * 125;
        let mut c_in = c0;
        for &c in &self.channels {
            let c = c as u64;
            let d_out = (d - 1) / 2 + 1; // 3³ stride 2 padding 1, and 1³ stride 2
            let cubes = d_out * d_out * d_out;
            macs += cubes * c * c_in * 27; // conv a
            macs += cubes * c * c * 27; // conv b
            macs += cubes * c * c_in; // projection
            c_in = c;
            d = d_out;
        }
        let mut w_in = c_in;
        for &h in &self.hidden {
            macs += w_in * h as u64;
            w_in = h as u64;
        }
        macs + w_in * self.outputs as u64
    }

    /// A network of this architecture with truncated-normal weights drawn
    /// from `seed` (the same values, in the same order, as the burn model of
    /// the `burn` feature), zero biases and identity batch norms.
    pub fn init_weights(&self, seed: u64) -> NetWeights {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        self.weights_from(|n, std| truncated_normal(&mut rng, n, std))
    }

    /// A network of this architecture with every weight zero (identity
    /// batch norms): the shapes to read a weight file into, without drawing
    /// random numbers.
    pub fn zero_weights(&self) -> NetWeights {
        self.weights_from(|n, _| vec![0.0; n])
    }

    /// The network whose convolution and linear weights are `draw(count,
    /// He std)`, drawn in layer order.
    fn weights_from(&self, mut draw: impl FnMut(usize, f64) -> Vec<f32>) -> NetWeights {
        let rng = &mut draw;
        let c = self.channels;
        let stem = conv(rng, 3, c[0], 5, 1, 2);
        let mut blocks = Vec::with_capacity(3);
        let mut c_in = c[0];
        for &c_out in &c {
            let conv_a = conv(rng, c_in, c_out, 3, 2, 1);
            let conv_b = conv(rng, c_out, c_out, 3, 1, 1);
            let shortcut = conv(rng, c_in, c_out, 1, 2, 0);
            blocks.push(BlockWeights {
                conv_a,
                bn_a: batch_norm(c_out),
                conv_b,
                bn_b: batch_norm(c_out),
                shortcut,
                bn_shortcut: batch_norm(c_out),
            });
            c_in = c_out;
        }
        let mut hidden = Vec::with_capacity(3);
        for &h in &self.hidden {
            hidden.push((linear(rng, c_in, h), batch_norm(h)));
            c_in = h;
        }
        let output = linear(rng, c_in, self.outputs);
        NetWeights {
            grid: self.grid,
            stem,
            stem_bn: batch_norm(c[0]),
            blocks,
            hidden,
            output,
        }
    }
}

/// Samples `n` values of a normal(0, std) truncated at ±2·std (redrawn).
pub(crate) fn truncated_normal(rng: &mut ChaCha8Rng, n: usize, std: f64) -> Vec<f32> {
    let normal = Normal::new(0.0, 1.0).expect("unit normal is valid");
    (0..n)
        .map(|_| {
            loop {
                let z: f64 = normal.sample(rng);
                if z.abs() <= 2.0 {
                    break (z * std) as f32;
                }
            }
        })
        .collect()
}

fn conv(
    draw: &mut impl FnMut(usize, f64) -> Vec<f32>,
    c_in: usize,
    c_out: usize,
    k: usize,
    stride: usize,
    padding: usize,
) -> ConvWeights {
    let fan_in = c_in * k * k * k;
    ConvWeights {
        weight: draw(c_out * fan_in, (2.0 / fan_in as f64).sqrt()),
        bias: None,
        in_channels: c_in,
        out_channels: c_out,
        kernel: k,
        stride,
        padding,
    }
}

fn linear(
    draw: &mut impl FnMut(usize, f64) -> Vec<f32>,
    d_in: usize,
    d_out: usize,
) -> LinearWeights {
    LinearWeights {
        weight: draw(d_in * d_out, (2.0 / d_in as f64).sqrt()),
        bias: Some(vec![0.0; d_out]),
        in_features: d_in,
        out_features: d_out,
    }
}

fn batch_norm(channels: usize) -> BatchNormWeights {
    BatchNormWeights {
        gamma: vec![1.0; channels],
        beta: vec![0.0; channels],
        mean: vec![0.0; channels],
        var: vec![1.0; channels],
        epsilon: BN_EPSILON,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn macs_count_matches_hand_count_for_lite() {
        // first conv: 21³ · 16 · 3 · 125 = 55,566,000 multiply-adds
        let macs = ModelConfig::lite().macs_per_sample();
        assert!(macs > 55_566_000 && macs < 120_000_000, "{macs}");
    }

    #[test]
    fn init_weights_compile_and_depend_on_the_seed() {
        let config = ModelConfig::tiny();
        let a = config.init_weights(1);
        let cnn = normalnet_cnn::Cnn::new(&a).expect("fresh weights compile");
        assert_eq!(cnn.outputs(), NUM_OUTPUTS);
        assert_eq!(a, config.init_weights(1));
        assert_ne!(a.stem.weight, config.init_weights(2).stem.weight);
        // He scale, cut at 2σ
        let std = (2.0f64 / (3.0 * 125.0)).sqrt() as f32;
        assert!(a.stem.weight.iter().all(|w| w.abs() <= 2.0 * std));
    }
}
