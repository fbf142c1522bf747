//! Microseconds per sample in every layer, one thread, f32 and int8 residual
//! blocks, the stem as scatter and as row convolutions (f32 or int8), on sheet-like grids of a random `lite` (or `paper`) network:
//! `cargo run --release -p normalnet-cnn --example layers -- [lite|paper] [samples]`.
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use normalnet_cnn::{Cnn, Precision};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map_or("lite", String::as_str);
    let samples: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let (grid, channels) = match preset {
        "paper" => (41, [64, 128, 256]),
        _ => (21, [16, 32, 64]),
    };
    let mut cnn = Cnn::new(&common::random_net(7, grid, channels)).expect("network");
    let grids: Vec<f32> = (0..samples)
        .flat_map(|i| common::sheet_grid(i as u64, grid))
        .collect();
    let mut out = vec![0.0f32; samples * 18];
    let forms = [
        (Precision::F32, false, false),
        (Precision::F32, true, false),
        (Precision::Int8, false, false),
        (Precision::Int8, true, false),
        (Precision::Int8, true, true),
    ];
    for (precision, rows, int8_stem) in forms {
        if cnn.set_precision(precision) != precision {
            println!("{precision:?}: not available on this CPU");
            continue;
        }
        if cnn.set_row_stem(rows) != rows {
            println!("row stem: not available for this network or CPU");
            continue;
        }
        if cnn.set_int8_stem(int8_stem) != int8_stem {
            println!("int8 row stem: not available for this network or CPU");
            continue;
        }
        let stem = match (rows, int8_stem) {
            (true, true) => "int8 row stem",
            (true, false) => "row stem",
            _ => "scatter stem",
        };
        cnn.forward_profiled(&grids, &mut out).expect("warm-up");
        let times = cnn.forward_profiled(&grids, &mut out).expect("forward");
        let mut total = 0.0;
        println!("{preset} {precision:?}, {stem}, µs per sample, one thread:");
        for (layer, s) in times.named() {
            let us = 1e6 * s / samples as f64;
            total += us;
            println!("  {layer:<36} {us:9.1}");
        }
        println!("  {:<36} {total:9.1}", "total");
    }
}
