//! Microseconds per sample in every layer, one thread, f32 and int8 residual
//! blocks, the stem as scatter and as row convolutions (f32 or int8), on sheet-like grids of a random `lite` (or `paper`) network:
//! `cargo run --release -p normalnet-cnn --example layers -- [lite|paper] [samples]`.
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use normalnet_cnn::{Arithmetic, Cnn};

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
        (Arithmetic::F32, false),
        (Arithmetic::F32, true),
        (Arithmetic::INT8_BLOCKS, false),
        (Arithmetic::INT8_BLOCKS, true),
        (
            Arithmetic {
                int8_stem: true,
                ..Arithmetic::INT8_BLOCKS
            },
            true,
        ),
    ];
    for (arithmetic, rows) in forms {
        if cnn.set_row_stem(rows) != rows {
            println!("row stem: not available for this network or CPU");
            continue;
        }
        if cnn.set_arithmetic(arithmetic) != arithmetic {
            println!("{arithmetic:?}: not available for this network or CPU");
            continue;
        }
        let int8_stem = arithmetic.int8_stem;
        let stem = match (rows, int8_stem) {
            (true, true) => "int8 row stem",
            (true, false) => "row stem",
            _ => "scatter stem",
        };
        cnn.forward_profiled(&grids, &mut out).expect("warm-up");
        let times = cnn.forward_profiled(&grids, &mut out).expect("forward");
        let mut total = 0.0;
        let blocks = if arithmetic.int8 { "int8" } else { "f32" };
        println!("{preset} {blocks} blocks, {stem}, µs per sample, one thread:");
        for (layer, s) in times.named() {
            let us = 1e6 * s / samples as f64;
            total += us;
            println!("  {layer:<36} {us:9.1}");
        }
        println!("  {:<36} {total:9.1}", "total");
    }
}
