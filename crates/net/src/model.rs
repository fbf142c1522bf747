//! The NormalNet network in burn (feature `burn`; Zhao et al. 2019,
//! "NormalNet: Learning-based normal filtering for mesh denoising", §3.2;
//! SPEC §6), the reference the CPU engine was checked against: a residual
//! 3D CNN mapping the
//! voxelized neighbourhood of one face to six filtered normals, one per μ_g of
//! [`MU_GS`], in the face's local frame.
//!
//! Layout: Conv3d 5³ stride 1 (padding 2) → BN → ReLU; three residual blocks
//! (conv 3³ stride 2 → BN → ReLU → conv 3³ → BN, plus a 1³ stride-2 projection
//! shortcut with BN; add; ReLU); global max pool; FC C→512→256→128 (each BN +
//! ReLU); FC 18; tanh. Weights are drawn from a truncated normal (He scale,
//! cut at 2σ), biases start at zero.
//!
//! Deviation: convolutions followed by batch norm carry no bias (the BN shift
//! makes it redundant); the paper does not say.

use burn::module::{Module, Param};
use burn::nn::conv::{Conv3d, Conv3dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, Initializer, Linear, LinearConfig, PaddingConfig3d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::arch::truncated_normal;
pub use crate::arch::{MU_GS, ModelConfig, NUM_OUTPUTS};

/// The burn form of the architecture: [`ModelConfig::init`] draws the
/// same weights as [`ModelConfig::init_weights`] (checked in the tests).
impl ModelConfig {
    /// Builds a network with truncated-normal weights drawn from `seed`.
    pub fn init(&self, device: &Device, seed: u64) -> NormalNet {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let c = self.channels;
        let conv_in = conv(&mut rng, device, 3, c[0], 5, 1, 2);
        let bn_in = BatchNormConfig::new(c[0]).init(device);
        let mut blocks = Vec::with_capacity(3);
        let mut c_in = c[0];
        for &c_out in &c {
            blocks.push(ResidualBlock {
                conv_a: conv(&mut rng, device, c_in, c_out, 3, 2, 1),
                bn_a: BatchNormConfig::new(c_out).init(device),
                conv_b: conv(&mut rng, device, c_out, c_out, 3, 1, 1),
                bn_b: BatchNormConfig::new(c_out).init(device),
                shortcut: conv(&mut rng, device, c_in, c_out, 1, 2, 0),
                bn_shortcut: BatchNormConfig::new(c_out).init(device),
            });
            c_in = c_out;
        }
        let mut fc = Vec::with_capacity(3);
        let mut bn_fc = Vec::with_capacity(3);
        for &h in &self.hidden {
            fc.push(linear(&mut rng, device, c_in, h));
            bn_fc.push(BatchNormConfig::new(h).init(device));
            c_in = h;
        }
        let out = linear(&mut rng, device, c_in, self.outputs);
        NormalNet {
            conv_in,
            bn_in,
            blocks,
            fc,
            bn_fc,
            out,
        }
    }
}

/// One residual block: two 3³ convolutions (the first with stride 2) and a
/// 1³ stride-2 projection shortcut.
#[derive(Module, Debug)]
pub struct ResidualBlock {
    conv_a: Conv3d,
    bn_a: BatchNorm,
    conv_b: Conv3d,
    bn_b: BatchNorm,
    shortcut: Conv3d,
    bn_shortcut: BatchNorm,
}

impl ResidualBlock {
    /// # Shapes
    /// - `x`: `[batch, c_in, d, d, d]`
    /// - output: `[batch, c_out, ⌈d/2⌉, ⌈d/2⌉, ⌈d/2⌉]`
    pub fn forward(&self, x: Tensor<5>) -> Tensor<5> {
        let y = relu(self.bn_a.forward(self.conv_a.forward(x.clone()))); // [b, c_out, d', d', d']
        let y = self.bn_b.forward(self.conv_b.forward(y)); // [b, c_out, d', d', d']
        let s = self.bn_shortcut.forward(self.shortcut.forward(x)); // [b, c_out, d', d', d']
        relu(y + s)
    }
}

/// One NormalNet (one iteration interval).
#[derive(Module, Debug)]
pub struct NormalNet {
    conv_in: Conv3d,
    bn_in: BatchNorm,
    blocks: Vec<ResidualBlock>,
    fc: Vec<Linear>,
    bn_fc: Vec<BatchNorm>,
    out: Linear,
}

impl NormalNet {
    /// Runs the network. Batch norm uses batch statistics (and updates its
    /// running statistics) when the tensors live on an autodiff device, the
    /// running statistics otherwise.
    ///
    /// # Shapes
    /// - `grids`: `[batch, 3, D, H, W]` (the voxel grid, channel = normal xyz)
    /// - output: `[batch, 18]` in (−1, 1): six 3-vectors, μ_g order of [`MU_GS`]
    pub fn forward(&self, grids: Tensor<5>) -> Tensor<2> {
        let x = relu(self.bn_in.forward(self.conv_in.forward(grids))); // [b, c0, D, D, D]
        let mut x = x;
        for block in &self.blocks {
            x = block.forward(x); // [b, c_k, D/2^k, ...]
        }
        let x: Tensor<3> = x.flatten(2, 4); // [b, c3, cubes]
        let mut x: Tensor<2> = x.max_dim(2).squeeze_dim(2); // [b, c3]
        for (fc, bn) in self.fc.iter().zip(&self.bn_fc) {
            x = relu(bn.forward(fc.forward(x))); // [b, hidden_k]
        }
        self.out.forward(x).tanh() // [b, 18]
    }
}

fn conv(
    rng: &mut ChaCha8Rng,
    device: &Device,
    c_in: usize,
    c_out: usize,
    k: usize,
    stride: usize,
    padding: usize,
) -> Conv3d {
    let mut layer = Conv3dConfig::new([c_in, c_out], [k, k, k])
        .with_stride([stride; 3])
        .with_padding(PaddingConfig3d::Explicit(padding, padding, padding))
        .with_bias(false)
        .with_initializer(Initializer::Zeros)
        .init(device);
    let fan_in = c_in * k * k * k;
    let values = truncated_normal(rng, c_out * fan_in, (2.0 / fan_in as f64).sqrt());
    let data = TensorData::new(values, [c_out, c_in, k, k, k]);
    layer.weight = Param::from_tensor(Tensor::from_data(data, device));
    layer
}

fn linear(rng: &mut ChaCha8Rng, device: &Device, d_in: usize, d_out: usize) -> Linear {
    let mut layer = LinearConfig::new(d_in, d_out)
        .with_initializer(Initializer::Zeros)
        .init(device);
    let dims = layer.weight.dims();
    let values = truncated_normal(rng, d_in * d_out, (2.0 / d_in as f64).sqrt());
    layer.weight = Param::from_tensor(Tensor::from_data(TensorData::new(values, dims), device));
    layer
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::SampleBatch;
    use crate::step::{adam, mse, train_step};
    use rand::Rng;

    fn random_batch(side: usize, len: usize, seed: u64) -> SampleBatch {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut batch = SampleBatch::with_capacity(side, len);
        for _ in 0..len * batch.grid_len() {
            // sparse grid: most cubes empty, as in real voxelizations
            let v = if rng.random::<f32>() < 0.1 {
                rng.random::<f32>() * 2.0 - 1.0
            } else {
                0.0
            };
            batch.grids.push(v);
        }
        for _ in 0..len * NUM_OUTPUTS {
            batch.targets.push(rng.random::<f32>() * 1.6 - 0.8);
        }
        batch.len = len;
        batch
    }

    #[test]
    fn forward_shape_and_range_per_preset() {
        let device = Device::flex();
        for (config, len) in [(ModelConfig::tiny(), 3), (ModelConfig::lite(), 2)] {
            let model = config.init(&device, 1);
            let batch = random_batch(config.grid, len, 2);
            let out = model.forward(batch.grids_tensor(&device));
            assert_eq!(out.dims(), [len, NUM_OUTPUTS]);
            let values = crate::data::tensor_to_vec(out);
            assert!(values.iter().all(|v| v.is_finite() && v.abs() < 1.0));
            // outputs depend on the input
            assert!(values[..NUM_OUTPUTS] != values[NUM_OUTPUTS..2 * NUM_OUTPUTS]);
        }
    }

    #[test]
    fn paper_preset_forward_shape() {
        let device = Device::flex();
        let config = ModelConfig::paper();
        let model = config.init(&device, 1);
        let batch = random_batch(config.grid, 1, 2);
        assert_eq!(model.forward(batch.grids_tensor(&device)).dims(), [1, 18]);
    }

    #[test]
    fn adam_steps_lower_the_loss_on_a_fixed_batch() {
        let device = Device::flex().autodiff();
        let config = ModelConfig::tiny();
        let mut model = config.init(&device, 3);
        let mut optim = adam();
        let batch = random_batch(config.grid, 16, 4);
        let (m, first) = train_step(model, &mut optim, &batch, 1e-3, &device);
        model = m;
        let mut last = first;
        for _ in 0..4 {
            let (m, loss) = train_step(model, &mut optim, &batch, 1e-3, &device);
            model = m;
            last = loss;
        }
        assert!(first.is_finite() && last.is_finite());
        assert!(last < first * 0.95, "loss {first} -> {last}");
    }

    #[test]
    fn save_load_gives_identical_outputs() {
        let device = Device::flex();
        let config = ModelConfig::tiny();
        // train one step so BN running stats differ from their init
        let train_device = Device::flex().autodiff();
        let model = config.init(&train_device, 5);
        let batch = random_batch(config.grid, 8, 6);
        let (model, _) = train_step(model, &mut adam(), &batch, 1e-3, &train_device);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("net.bpk");
        let trained = model.valid();
        let expected = crate::data::tensor_to_vec(
            trained
                .clone()
                .fork(&device)
                .forward(batch.grids_tensor(&device)),
        );
        trained.save_file(&path).unwrap();
        let loaded = config.init(&device, 99).try_load_file(&path).unwrap();
        let got = crate::data::tensor_to_vec(loaded.forward(batch.grids_tensor(&device)));
        assert_eq!(expected, got);
        let fresh = crate::data::tensor_to_vec(
            config
                .init(&device, 99)
                .forward(batch.grids_tensor(&device)),
        );
        assert_ne!(fresh, got);
        let _ = mse; // used by train_step
    }

    #[test]
    fn init_draws_the_same_weights_as_init_weights() {
        let config = ModelConfig::tiny();
        let burn = crate::export::net_weights(&config.init(&Device::flex(), 11), &config).unwrap();
        assert_eq!(burn, config.init_weights(11));
    }
}
