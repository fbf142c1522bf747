//! The CPU training engine (`normalnet_cnn::Trainer`) against burn's
//! autodiff on the same weights and batch: same loss, same gradients for
//! every parameter, and the same loss curve over a run of Adam steps.

use std::collections::HashMap;

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor};
use normalnet_cnn::{Loss, Trainer};
use normalnet_net::data::SampleBatch;
use normalnet_net::export::net_weights;
use normalnet_net::import::tensors_by_path;
use normalnet_net::step::{adam, mse, train_step};
use normalnet_net::{ModelConfig, NormalNet};

fn batch(side: usize, len: usize, seed: u64) -> SampleBatch {
    SampleBatch::sheets(side, len, seed)
}

struct Grads<'a> {
    path: Vec<String>,
    grads: &'a GradientsParams,
    out: HashMap<String, Vec<f32>>,
}

impl ModuleVisitor for Grads<'_> {
    fn enter_module(&mut self, name: &str, _container: &str) {
        self.path.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container: &str) {
        self.path.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            let values = g.into_data().convert::<f32>().try_to_vec::<f32>().unwrap();
            self.out.insert(self.path.join("."), values);
        }
    }
}

/// burn's loss and gradients (by module path) for `net` on `b`.
fn burn_gradients(net: &NormalNet, b: &SampleBatch) -> (f64, HashMap<String, Vec<f32>>) {
    let device = Device::flex().autodiff();
    let model = net.clone().fork(&device).train();
    let loss = mse(
        model.forward(b.grids_tensor(&device)),
        b.targets_tensor(&device),
    );
    let value = loss.clone().into_scalar::<f32>() as f64;
    let grads = GradientsParams::from_grads(loss.backward(), &model);
    let mut v = Grads {
        path: Vec::new(),
        grads: &grads,
        out: HashMap::new(),
    };
    model.visit(&mut v);
    (value, v.out)
}

fn norm(v: &[f32]) -> f64 {
    v.iter().map(|&x| (x as f64).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn gradients_equal_burn_autodiff() {
    let config = ModelConfig::tiny();
    let plain = Device::flex();
    let net = config.init(&plain, 21);
    let b = batch(config.grid, 6, 3);
    let (burn_loss, burn) = burn_gradients(&net, &b);
    let mut trainer = Trainer::new(&net_weights(&net, &config).unwrap()).unwrap();
    trainer.zero_grad();
    let ours_loss = trainer
        .forward_backward(&b.grids, &b.targets, Loss::Mse)
        .unwrap();
    assert!(
        (ours_loss - burn_loss).abs() < 1e-5 * burn_loss.max(1e-3),
        "loss {ours_loss} vs burn {burn_loss}"
    );
    let ours = tensors_by_path(&trainer.gradients());
    // every parameter that burn differentiates (all but running statistics)
    assert_eq!(
        burn.len(),
        3 + 3 * (1 + 2 + 1 + 2 + 1 + 2) + 3 * (2 + 2) + 2
    );
    let total = burn.values().map(|g| norm(g).powi(2)).sum::<f64>().sqrt();
    let mut worst = (0.0f64, String::new());
    for (path, g) in &burn {
        let o = &ours[path];
        assert_eq!(o.len(), g.len(), "{path}");
        let diff: Vec<f32> = o.iter().zip(g).map(|(a, b)| a - b).collect();
        // relative to the array's own size, with a floor for arrays whose
        // exact gradient is zero (a bias before batch norm)
        let rel = norm(&diff) / norm(g).max(1e-4 * total);
        assert!(
            rel < 1e-3,
            "{path}: |ours − burn| / |burn| = {rel:.2e} (|burn| = {:.3e})",
            norm(g)
        );
        if rel > worst.0 {
            worst = (rel, path.clone());
        }
    }
    eprintln!(
        "largest relative gradient difference: {:.2e} ({})",
        worst.0, worst.1
    );
}

#[test]
fn both_engines_follow_the_same_loss_curve() {
    let config = ModelConfig::tiny();
    let plain = Device::flex();
    let net = config.init(&plain, 5);
    let batches: Vec<SampleBatch> = (0..4).map(|i| batch(config.grid, 16, 100 + i)).collect();
    let steps = 40;
    let lr = 1e-3;
    let device = Device::flex().autodiff();
    let mut model = net.clone().fork(&device).train();
    let mut optim = adam();
    let mut trainer = Trainer::new(&net_weights(&net, &config).unwrap()).unwrap();
    let (mut burn_curve, mut our_curve) = (Vec::new(), Vec::new());
    for s in 0..steps {
        let b = &batches[s % batches.len()];
        let (m, l) = train_step(model, &mut optim, b, lr, &device);
        model = m;
        burn_curve.push(l);
        our_curve.push(
            trainer
                .train_step(&b.grids, &b.targets, Loss::Mse, lr)
                .unwrap(),
        );
    }
    // both learn ...
    let head = |c: &[f64]| c[..4].iter().sum::<f64>() / 4.0;
    let tail = |c: &[f64]| c[steps - 4..].iter().sum::<f64>() / 4.0;
    assert!(
        tail(&burn_curve) < 0.7 * head(&burn_curve),
        "{burn_curve:?}"
    );
    assert!(tail(&our_curve) < 0.7 * head(&our_curve), "{our_curve:?}");
    // ... and stay on the same curve: step 0 is the same computation; after
    // that Adam turns rounding-level differences of near-zero gradients into
    // full-size steps (m/√v), so the curves agree as a trend: means over
    // windows of 8 steps
    assert!((our_curve[0] - burn_curve[0]).abs() < 1e-5 * burn_curve[0]);
    for (w, (a, b)) in our_curve.chunks(8).zip(burn_curve.chunks(8)).enumerate() {
        let (a, b) = (a.iter().sum::<f64>() / 8.0, b.iter().sum::<f64>() / 8.0);
        assert!(
            (a - b).abs() < 0.25 * b,
            "steps {}..{}: ours {a} vs burn {b}\nours {our_curve:?}\nburn {burn_curve:?}",
            8 * w,
            8 * w + 8
        );
    }
}
