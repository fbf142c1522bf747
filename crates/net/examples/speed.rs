//! Throughput of one network on the Flex CPU backend: forward samples/s at
//! batch 64 and 256, train-step time at batch 80, GFLOP/s from the counted
//! multiply-adds. `cargo run -p normalnet-net --example speed -- [preset] [reps]`.

use burn::tensor::Device;
use normalnet_net::ModelConfig;
use normalnet_net::data::SampleBatch;
use normalnet_net::step::{adam, train_step};
use std::time::Instant;

fn batch(side: usize, len: usize) -> SampleBatch {
    let mut b = SampleBatch::with_capacity(side, len);
    let n = len * b.grid_len();
    // a sparse, deterministic pattern (~5 % occupied cubes)
    b.grids = (0..n)
        .map(|i| {
            if (i * 2654435761usize) % 100 < 5 {
                0.5
            } else {
                0.0
            }
        })
        .collect();
    b.targets = vec![0.1; len * 18];
    b.len = len;
    b
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map(String::as_str).unwrap_or("lite");
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let config = ModelConfig::preset(preset).expect("preset");
    let macs = config.macs_per_sample() as f64;
    println!(
        "preset {preset}: {:.1} M multiply-adds per sample, threads {}",
        macs / 1e6,
        rayon::current_num_threads()
    );
    let device = Device::flex();
    let model = config.init(&device, 0);
    for len in [64usize, 256] {
        let b = batch(config.grid, len);
        let _ = model.forward(b.grids_tensor(&device)).into_data(); // warm-up
        let t = Instant::now();
        for _ in 0..reps {
            let _ = model.forward(b.grids_tensor(&device)).into_data();
        }
        let s = t.elapsed().as_secs_f64() / reps as f64;
        println!(
            "forward batch {len}: {:.3} s, {:.1} samples/s, {:.1} GFLOP/s",
            s,
            len as f64 / s,
            2.0 * macs * len as f64 / s / 1e9
        );
    }
    let ad = Device::flex().autodiff();
    let mut model = config.init(&ad, 0);
    let mut optim = adam();
    let b = batch(config.grid, 80);
    let (m, _) = train_step(model, &mut optim, &b, 1e-4, &ad);
    model = m;
    let t = Instant::now();
    for _ in 0..reps {
        let (m, _) = train_step(model, &mut optim, &b, 1e-4, &ad);
        model = m;
    }
    let s = t.elapsed().as_secs_f64() / reps as f64;
    println!(
        "train step batch 80: {:.3} s, {:.1} samples/s, {:.1} GFLOP/s (3× forward MACs)",
        s,
        80.0 / s,
        3.0 * 2.0 * macs * 80.0 / s / 1e9
    );
}
