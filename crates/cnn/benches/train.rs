//! Training samples/s of the `lite` network (batch 80) on sheet-like grids:
//! forward + backward + Adam, and where the time goes per layer.
//! `cargo bench -p normalnet-cnn --bench train [-- THREADS]`
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use normalnet_cnn::{Loss, Trainer};
use std::time::Instant;

fn main() {
    let threads: usize = std::env::args()
        .filter_map(|a| a.parse().ok())
        .next()
        .unwrap_or(2);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    for (name, grid, channels, batch, steps) in [("lite", 21, [16, 32, 64], 80, 20)] {
        let mut w = common::random_net(7, grid, channels);
        w.stem.bias = None;
        for b in &mut w.blocks {
            b.conv_a.bias = None;
            b.conv_b.bias = None;
            b.shortcut.bias = None;
        }
        let grids: Vec<f32> = (0..batch)
            .flat_map(|i| common::sheet_grid(i as u64, grid))
            .collect();
        let targets = vec![0.1f32; batch * 18];
        pool.install(|| {
            let mut t = Trainer::new(&w).unwrap();
            t.train_step(&grids, &targets, Loss::Mse, 1e-4).unwrap();
            t.profile(true);
            let start = Instant::now();
            for _ in 0..steps {
                t.train_step(&grids, &targets, Loss::Mse, 1e-4).unwrap();
            }
            let secs = start.elapsed().as_secs_f64();
            println!(
                "train_{name} batch {batch}, {threads} threads: {:.1} ms/step, {:.0} samples/s",
                secs / steps as f64 * 1e3,
                (steps * batch) as f64 / secs
            );
            for (phase, s) in t.profile_report() {
                println!(
                    "  {phase:<28} {:>7.2} ms/step ({:.0} %)",
                    s / steps as f64 * 1e3,
                    s / secs * 100.0
                );
            }
        });
    }
}
