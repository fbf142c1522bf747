//! One optimisation step of one network (SPEC §8): MSE between the network's
//! 18 outputs and the GT-guided targets, Adam (β₁ 0.9, β₂ 0.999, ε 1e-8).

use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor};

use crate::data::SampleBatch;
use crate::model::NormalNet;

/// The Adam optimiser of SPEC §8: β₁ 0.9, β₂ 0.999, ε 1e-8.
pub fn adam() -> ModuleOptimizer {
    AdamConfig::new()
        .with_beta_1(0.9)
        .with_beta_2(0.999)
        .with_epsilon(1e-8)
        .init()
}

/// Mean squared error over all outputs of a batch.
///
/// # Shapes
/// - `output`, `target`: `[batch, 18]`
pub fn mse(output: Tensor<2>, target: Tensor<2>) -> Tensor<1> {
    (output - target).powi_scalar(2).mean()
}

/// One Adam step on `batch` with learning rate `lr`; returns the updated
/// model and the batch loss before the update. `device` must be an autodiff
/// device (the model lives there).
pub fn train_step(
    model: NormalNet,
    optim: &mut ModuleOptimizer,
    batch: &SampleBatch,
    lr: f64,
    device: &Device,
) -> (NormalNet, f64) {
    let grids = batch.grids_tensor(device);
    let targets = batch.targets_tensor(device);
    let loss = mse(model.forward(grids), targets);
    let value = loss.clone().into_scalar::<f32>() as f64;
    let grads = loss.backward();
    let grads = GradientsParams::from_grads(grads, &model);
    let model = optim.step(lr, model, grads);
    (model, value)
}
