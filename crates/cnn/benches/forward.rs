//! Forward samples/s of the `lite` and `paper` networks on sheet-like grids,
//! f32 and (where the path has int8 kernels) int8 parts, with the full and
//! the narrow integer ranges. `NORMALNET_ISA` picks the path.
#![allow(missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use normalnet_cnn::{Arithmetic, Cnn, Int8Range};

fn forward(c: &mut Criterion) {
    for (name, grid, channels, batch) in [
        ("lite", 21, [16, 32, 64], 64),
        ("paper", 41, [64, 128, 256], 8),
    ] {
        let w = common::random_net(7, grid, channels);
        let mut cnn = Cnn::new(&w).unwrap();
        let grids: Vec<f32> = (0..batch)
            .flat_map(|i| common::sheet_grid(i as u64, grid))
            .collect();
        let mut out = vec![0.0f32; batch * 18];
        let mut g = c.benchmark_group(format!("forward_{name}_{}", cnn.instruction_set()));
        g.throughput(Throughput::Elements(batch as u64));
        g.sample_size(10);
        g.bench_function(format!("batch{batch}"), |b| {
            b.iter(|| cnn.forward(&grids, &mut out).unwrap())
        });
        if cnn.set_arithmetic(Arithmetic::INT8_BLOCKS).int8 {
            g.bench_function(format!("batch{batch}_int8"), |b| {
                b.iter(|| cnn.forward(&grids, &mut out).unwrap())
            });
            // what denoising runs: int8 stem too, grids handed over sparse
            let stem = Arithmetic {
                int8_stem: true,
                ..Arithmetic::INT8_BLOCKS
            };
            if cnn.set_arithmetic(stem).int8_stem {
                let sparse = common::sparse_grids(&grids, cnn.grid_len());
                let samples: Vec<(&[u32], &[f32])> =
                    sparse.iter().map(|(i, v)| (&i[..], &v[..])).collect();
                g.bench_function(format!("batch{batch}_int8_stem_sparse"), |b| {
                    b.iter(|| cnn.forward_sparse(&samples, &mut out).unwrap())
                });
                // and the shortcuts in int8: every default of `normalnet denoise`
                if cnn.set_arithmetic(Arithmetic::INT8).int8_shortcut {
                    g.bench_function(format!("batch{batch}_int8_all_sparse"), |b| {
                        b.iter(|| cnn.forward_sparse(&samples, &mut out).unwrap())
                    });
                    // (the default ranges: full with VNNI, narrow on plain
                    // AVX2) and each range forced
                    for range in [Int8Range::Full, Int8Range::Narrow] {
                        cnn.set_arithmetic(Arithmetic {
                            int8_range: Some(range),
                            ..Arithmetic::INT8
                        });
                        g.bench_function(
                            format!("batch{batch}_int8_all_sparse_{}", range.name()),
                            |b| b.iter(|| cnn.forward_sparse(&samples, &mut out).unwrap()),
                        );
                    }
                }
            }
        }
        g.finish();
    }
}

criterion_group!(benches, forward);
criterion_main!(benches);
