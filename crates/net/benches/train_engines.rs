//! Training samples/s of the `lite` network (batch 80, Adam, MSE) on the
//! CPU engine of normalnet-cnn and on burn's Flex autodiff, same weights and
//! batch, one run; with `TORCH_PYTHON=path/to/python` also PyTorch CPU f32
//! on the same network (`../shared/tools/torch_bench/bench.py`), so the
//! ratios come from one run on one machine.
//!
//! `cargo bench -p normalnet-net --bench train_engines [-- THREADS]`
#![allow(missing_docs)]

use std::time::Instant;

use burn::module::Module;
use burn::tensor::Device;
use normalnet_cnn::{Loss, Trainer};
use normalnet_net::ModelConfig;
use normalnet_net::data::SampleBatch;
use normalnet_net::export::net_weights;
use normalnet_net::step::{adam, train_step};

fn main() {
    let threads: usize = std::env::args()
        .filter_map(|a| a.parse().ok())
        .next()
        .unwrap_or(2);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let config = ModelConfig::lite();
    let b = SampleBatch::sheets(config.grid, 80, 7);
    let net = config.init(&Device::flex(), 1);
    let (ours, burn) = pool.install(|| {
        let mut t = Trainer::new(&net_weights(&net, &config).unwrap()).unwrap();
        t.train_step(&b.grids, &b.targets, Loss::Mse, 1e-4).unwrap();
        let steps = 15;
        let start = Instant::now();
        for _ in 0..steps {
            t.train_step(&b.grids, &b.targets, Loss::Mse, 1e-4).unwrap();
        }
        let ours = (steps * b.len) as f64 / start.elapsed().as_secs_f64();
        let device = Device::flex().autodiff();
        let mut model = net.clone().fork(&device).train();
        let mut optim = adam();
        let (m, _) = train_step(model, &mut optim, &b, 1e-4, &device);
        model = m;
        let steps = 3;
        let start = Instant::now();
        for _ in 0..steps {
            let (m, _) = train_step(model, &mut optim, &b, 1e-4, &device);
            model = m;
        }
        let burn = (steps * b.len) as f64 / start.elapsed().as_secs_f64();
        (ours, burn)
    });
    println!("lite training, batch 80, {threads} threads (samples/s):");
    println!("  normalnet-cnn Trainer  {ours:8.1}");
    println!(
        "  burn Flex autodiff     {burn:8.1}   (ours / burn = {:.1}×)",
        ours / burn
    );
    if let Ok(python) = std::env::var("TORCH_PYTHON") {
        let script = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/tools/torch_bench/bench.py"
        );
        let out = std::process::Command::new(python)
            .env_remove("OPENBLAS_CORETYPE")
            .env_remove("OPENBLAS_L2_SIZE")
            .args([
                script, "--preset", "lite", "--mode", "train", "--batch", "80",
            ])
            .args(["--threads", &threads.to_string(), "--reps", "5"])
            .output();
        match out {
            Ok(o) if o.status.success() => {
                let text = String::from_utf8_lossy(&o.stdout);
                let torch = text.split("\"samples_per_s\":").nth(1).and_then(|s| {
                    s.trim()
                        .trim_end_matches(['}', '\n'])
                        .trim()
                        .parse::<f64>()
                        .ok()
                });
                match torch {
                    Some(t) => println!(
                        "  PyTorch CPU f32        {t:8.1}   (ours / PyTorch = {:.2}×)",
                        ours / t
                    ),
                    None => println!("  PyTorch: could not read {text}"),
                }
            }
            Ok(o) => println!("  PyTorch failed: {}", String::from_utf8_lossy(&o.stderr)),
            Err(e) => println!("  PyTorch not run: {e}"),
        }
    }
}
