//! The training engine: its loss equals a literal f64 evaluation of the
//! network in training mode, its gradients equal central finite differences
//! of that f64 evaluation for every layer, a step does not depend on the
//! thread count, and Adam lowers the loss.

mod common;

use common::{conv_ref, linear_ref};
use normalnet_cnn::{BatchNormWeights, Int8Range, Loss, NetWeights, Trainer};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Batch norm with batch statistics over `xs` (each `[c][per]`), in place.
fn bn_train_ref(xs: &mut [Vec<f64>], bn: &BatchNormWeights) {
    let c = bn.gamma.len();
    let per = xs[0].len() / c;
    let count = (per * xs.len()) as f64;
    for ch in 0..c {
        let vals = || xs.iter().flat_map(|x| x[ch * per..(ch + 1) * per].iter());
        let mean = vals().sum::<f64>() / count;
        let var = vals().map(|v| (v - mean).powi(2)).sum::<f64>() / count;
        let inv = 1.0 / (var + bn.epsilon).sqrt();
        for x in xs.iter_mut() {
            for v in &mut x[ch * per..(ch + 1) * per] {
                *v = bn.gamma[ch] as f64 * (*v - mean) * inv + bn.beta[ch] as f64;
            }
        }
    }
}

fn relu(xs: &mut [Vec<f64>]) {
    xs.iter_mut().flatten().for_each(|v| *v = v.max(0.0));
}

/// Outputs of a batch in training mode, literally, in f64.
fn reference_train(w: &NetWeights, grids: &[f32], batch: usize) -> Vec<Vec<f64>> {
    let g = grids.len() / batch;
    let mut xs: Vec<Vec<f64>> = Vec::new();
    let mut n = 0;
    for b in 0..batch {
        let x: Vec<f64> = grids[b * g..(b + 1) * g]
            .iter()
            .map(|&v| v as f64)
            .collect();
        let (y, m) = conv_ref(&x, 3, w.grid, &w.stem);
        xs.push(y);
        n = m;
    }
    bn_train_ref(&mut xs, &w.stem_bn);
    relu(&mut xs);
    let mut c = w.stem.out_channels;
    for bw in &w.blocks {
        let co = bw.conv_a.out_channels;
        let mut ts = Vec::new();
        let mut ss = Vec::new();
        let mut m = 0;
        for x in &xs {
            let (t, mm) = conv_ref(x, c, n, &bw.conv_a);
            ts.push(t);
            ss.push(conv_ref(x, c, n, &bw.shortcut).0);
            m = mm;
        }
        bn_train_ref(&mut ts, &bw.bn_a);
        relu(&mut ts);
        let mut ys: Vec<Vec<f64>> = ts
            .iter()
            .map(|t| conv_ref(t, co, m, &bw.conv_b).0)
            .collect();
        bn_train_ref(&mut ys, &bw.bn_b);
        bn_train_ref(&mut ss, &bw.bn_shortcut);
        for (y, s) in ys.iter_mut().zip(&ss) {
            for (a, b) in y.iter_mut().zip(s) {
                *a += b;
            }
        }
        relu(&mut ys);
        xs = ys;
        n = m;
        c = co;
    }
    let per = n * n * n;
    let mut vs: Vec<Vec<f64>> = xs
        .iter()
        .map(|x| {
            (0..c)
                .map(|ch| {
                    x[ch * per..(ch + 1) * per]
                        .iter()
                        .cloned()
                        .fold(f64::NEG_INFINITY, f64::max)
                })
                .collect()
        })
        .collect();
    for (l, bn) in &w.hidden {
        let mut hs: Vec<Vec<f64>> = vs.iter().map(|v| linear_ref(v, l)).collect();
        bn_train_ref(&mut hs, bn);
        relu(&mut hs);
        vs = hs;
    }
    vs.iter()
        .map(|v| {
            linear_ref(v, &w.output)
                .into_iter()
                .map(f64::tanh)
                .collect()
        })
        .collect()
}

fn reference_loss(w: &NetWeights, grids: &[f32], targets: &[f32], batch: usize, loss: Loss) -> f64 {
    let out = reference_train(w, grids, batch);
    let mut sum = 0.0;
    for (b, o) in out.iter().enumerate() {
        for (k, &y) in o.iter().enumerate() {
            let d = y - targets[b * o.len() + k] as f64;
            sum += match loss {
                Loss::Mse => d * d,
                Loss::L1 => d.abs(),
            };
        }
    }
    sum / (out.len() * out[0].len()) as f64
}

/// Every trainable array of a network, by name (running statistics left out).
fn arrays(w: &mut NetWeights) -> Vec<(String, &mut Vec<f32>)> {
    let mut v: Vec<(String, &mut Vec<f32>)> = vec![
        ("stem".into(), &mut w.stem.weight),
        ("stem_bn.gamma".into(), &mut w.stem_bn.gamma),
        ("stem_bn.beta".into(), &mut w.stem_bn.beta),
    ];
    for (i, b) in w.blocks.iter_mut().enumerate() {
        v.push((format!("block{i}.conv_a"), &mut b.conv_a.weight));
        v.push((format!("block{i}.bn_a.gamma"), &mut b.bn_a.gamma));
        v.push((format!("block{i}.bn_a.beta"), &mut b.bn_a.beta));
        v.push((format!("block{i}.conv_b"), &mut b.conv_b.weight));
        v.push((format!("block{i}.bn_b.gamma"), &mut b.bn_b.gamma));
        v.push((format!("block{i}.shortcut"), &mut b.shortcut.weight));
        v.push((format!("block{i}.bn_s.beta"), &mut b.bn_shortcut.beta));
    }
    for (i, (l, bn)) in w.hidden.iter_mut().enumerate() {
        v.push((format!("fc{i}.weight"), &mut l.weight));
        v.push((format!("fc{i}.bias"), l.bias.as_mut().unwrap()));
        v.push((format!("fc{i}.bn.gamma"), &mut bn.gamma));
    }
    v.push(("out.weight".into(), &mut w.output.weight));
    v.push(("out.bias".into(), w.output.bias.as_mut().unwrap()));
    v
}

struct Case {
    w: NetWeights,
    grids: Vec<f32>,
    targets: Vec<f32>,
    batch: usize,
}

fn case(seed: u64, grid: usize, channels: [usize; 3], batch: usize) -> Case {
    let w = common::random_net_with(seed, grid, channels, [16, 16, 8], false);
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(seed * 10 + i as u64, grid))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 5);
    let targets = (0..batch * 18)
        .map(|_| rng.random_range(-0.9..0.9))
        .collect();
    Case {
        w,
        grids,
        targets,
        batch,
    }
}

fn gradient_check(loss: Loss) {
    let c = case(7, 9, [8, 16, 32], 3);
    let mut trainer = Trainer::new(&c.w).unwrap();
    let fast = trainer.loss(&c.grids, &c.targets, loss).unwrap();
    let slow = reference_loss(&c.w, &c.grids, &c.targets, c.batch, loss);
    assert!(
        (fast - slow).abs() < 1e-5 * slow.abs().max(1.0),
        "loss {fast} vs reference {slow}"
    );
    trainer.zero_grad();
    trainer
        .forward_backward(&c.grids, &c.targets, loss)
        .unwrap();
    let mut grads = trainer.gradients();
    let mut w = c.w.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let grad_arrays = arrays(&mut grads);
    let names: Vec<String> = grad_arrays.iter().map(|(n, _)| n.clone()).collect();
    let grad_values: Vec<Vec<f32>> = grad_arrays.into_iter().map(|(_, g)| g.clone()).collect();
    for (a, (name, analytic)) in names.iter().zip(&grad_values).enumerate() {
        let (mut den, mut diff) = (0.0f64, 0.0f64);
        for _ in 0..6 {
            let j = rng.random_range(0..analytic.len());
            let original = arrays(&mut w)[a].1[j];
            let h = 2e-5f32.max(original.abs() * 2e-5);
            arrays(&mut w)[a].1[j] = original + h;
            let up_delta = (original + h) as f64 - original as f64;
            let up = reference_loss(&w, &c.grids, &c.targets, c.batch, loss);
            arrays(&mut w)[a].1[j] = original - h;
            let down_delta = original as f64 - (original - h) as f64;
            let down = reference_loss(&w, &c.grids, &c.targets, c.batch, loss);
            arrays(&mut w)[a].1[j] = original;
            let fd = (up - down) / (up_delta + down_delta);
            den += 1.0;
            diff += (fd - analytic[j] as f64).abs();
        }
        let scale =
            grad_values[a].iter().map(|v| v.abs() as f64).sum::<f64>() / analytic.len() as f64;
        // gradients that are zero in exact arithmetic (a bias before batch norm)
        // compare against an absolute floor
        let rel = diff / den / scale.max(1e-5);
        assert!(
            rel < 2e-3,
            "{name}: mean |analytic − finite difference| = {:.3e}, {rel:.2e} of the mean |gradient| {scale:.3e}",
            diff / den
        );
    }
}

#[test]
fn gradients_equal_finite_differences_mse() {
    gradient_check(Loss::Mse);
}

#[test]
fn gradients_equal_finite_differences_l1() {
    gradient_check(Loss::L1);
}

#[test]
fn a_step_does_not_depend_on_the_thread_count() {
    let c = case(3, 15, [8, 16, 32], 19);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut t = Trainer::new(&c.w).unwrap();
            let l = t.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
            (l, t.weights())
        })
    };
    let (l1, w1) = run(1);
    let (l3, w3) = run(3);
    assert_eq!(l1, l3);
    assert!(
        w1 == w3,
        "weights after one step differ between 1 and 3 threads"
    );
}

#[test]
fn adam_lowers_the_loss_and_updates_running_statistics() {
    let c = case(5, 15, [8, 16, 32], 16);
    let mut t = Trainer::new(&c.w).unwrap();
    let first = t.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    let mut last = first;
    for _ in 0..10 {
        last = t.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    }
    assert!(last < 0.8 * first, "loss {first} → {last}");
    let w = t.weights();
    assert_ne!(w.stem_bn.mean, c.w.stem_bn.mean);
    assert_ne!(w.stem.weight, c.w.stem.weight);
    // the trained weights run on the inference engine
    let cnn = normalnet_cnn::Cnn::new(&w).unwrap();
    let mut out = vec![0.0f32; c.batch * 18];
    cnn.forward(&c.grids, &mut out).unwrap();
    assert!(out.iter().all(|v| v.is_finite()));
}

/// Quantization-aware training on the narrow int8 steps: the loss moves a
/// little from the f32 network's and comes back with it off; every
/// convolution's gradient points where the f32 one does (the rounding is
/// passed straight through); Adam steps lower the loss; the weights kept and
/// exported stay f32 (not on the steps).
#[test]
fn fake_quantization_trains_near_the_f32_network() {
    let c = case(12, 15, [8, 16, 32], 16);
    let mut t = Trainer::new(&c.w).unwrap();
    let gradients = |t: &mut Trainer| {
        t.zero_grad();
        let l = t.forward_backward(&c.grids, &c.targets, Loss::Mse).unwrap();
        (l, t.gradients())
    };
    let (f32_loss, mut f32_grads) = gradients(&mut t);
    let f32_eval = t.loss(&c.grids, &c.targets, Loss::Mse).unwrap();
    assert_eq!(t.fake_quant(), None);
    t.set_fake_quant(Some(Int8Range::Narrow));
    assert_eq!(t.fake_quant(), Some(Int8Range::Narrow));
    let (q_loss, mut q_grads) = gradients(&mut t);
    assert!(
        q_loss != f32_loss && (q_loss - f32_loss).abs() < 0.05 * f32_loss,
        "loss f32 {f32_loss}, narrow steps {q_loss}"
    );
    for ((name, a), (_, b)) in arrays(&mut f32_grads).into_iter().zip(arrays(&mut q_grads)) {
        if !(name.contains("conv") || name.contains("shortcut") || name == "stem") {
            continue;
        }
        let dot: f64 = a
            .iter()
            .zip(b.iter())
            .map(|(x, y)| f64::from(*x) * f64::from(*y))
            .sum();
        let norm = |v: &[f32]| v.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt();
        let cosine = dot / (norm(a) * norm(b));
        // (0.74–0.86 on this case; unrelated directions would be near 0)
        assert!(cosine > 0.6, "{name}: cosine {cosine}");
        assert_ne!(a, b, "{name}: the rounding shows in the gradient");
    }
    // (batch norm's sums are shifted by its running mean, which the steps
    // in between moved: equal to float rounding)
    t.set_fake_quant(None);
    let again = t.loss(&c.grids, &c.targets, Loss::Mse).unwrap();
    assert!(
        (again - f32_eval).abs() < 1e-6 * f32_eval,
        "{again} vs {f32_eval}"
    );
    t.set_fake_quant(Some(Int8Range::Narrow));
    let first = t.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    let mut last = first;
    for _ in 0..10 {
        last = t.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    }
    assert!(last < 0.8 * first, "loss {first} → {last}");
    // the f32 weights: a channel's weights are not all multiples of one step
    let w = t.weights();
    let conv = &w.blocks[1].conv_b;
    let per_out = conv.weight.len() / conv.out_channels;
    let channel = &conv.weight[..per_out];
    let step = channel.iter().fold(0.0f32, |m, v| m.max(v.abs())) / 63.0;
    assert!(
        channel
            .iter()
            .any(|v| ((v / step) - (v / step).round()).abs() > 0.01),
        "exported weights were rounded"
    );
}

#[test]
fn weights_round_trip_and_bad_batches_are_refused() {
    let c = case(9, 15, [8, 16, 32], 2);
    let t = Trainer::new(&c.w).unwrap();
    assert!(t.weights() == c.w);
    let mut t = t;
    assert!(
        t.forward_backward(&c.grids[..100], &c.targets, Loss::Mse)
            .is_err()
    );
    assert!(
        t.forward_backward(&c.grids, &c.targets[..5], Loss::Mse)
            .is_err()
    );
    let mut biased = c.w.clone();
    biased.stem.bias = Some(vec![0.0; 8]);
    assert!(Trainer::new(&biased).is_err());
}

#[test]
fn a_saved_state_resumes_exactly() {
    let c = case(4, 15, [8, 16, 32], 8);
    let mut a = Trainer::new(&c.w).unwrap();
    a.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    let state = a.state_bytes();
    let mut b = Trainer::new(&c.w).unwrap();
    b.load_state_bytes(&state).unwrap();
    assert_eq!(b.steps(), 1);
    let la = a.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    let lb = b.train_step(&c.grids, &c.targets, Loss::Mse, 1e-3).unwrap();
    assert_eq!(la, lb);
    assert!(a.weights() == b.weights());
    assert!(b.load_state_bytes(&state[..state.len() - 4]).is_err());
}
