//! Benchmark: loader samples per second with 2 workers (procedural shapes
//! with generated noise: training-like data, no test model).
//! Run: `cargo bench -p normalnet-samples --bench loader`.
#![allow(missing_docs)] // criterion's generated functions

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use normalnet_samples::{BalancedSampler, Loader, LoaderConfig, MU_GS, SampleSource};
use normalnet_voxel::VoxelParams;
use std::hint::black_box;
use std::sync::Arc;

fn loader(c: &mut Criterion) {
    let sources: Vec<SampleSource> = (0..3u64)
        .map(|seed| {
            let (clean, noisy) =
                normalnet_voxel::shapes::noisy_pair(seed * 3 + 1, 4000, 0.3, seed).unwrap();
            SampleSource::new(noisy, &clean, VoxelParams::lite(), &MU_GS).unwrap()
        })
        .collect();
    let sampler = BalancedSampler::new(&sources);
    let items = sampler.draw_count_seeded(800, 0);
    let sources = Arc::new(sources);
    let mut group = c.benchmark_group("loader_lite_batch80");
    group.sample_size(10);
    group.throughput(Throughput::Elements(items.len() as u64));
    group.bench_function("2_workers", |b| {
        b.iter(|| {
            let config = LoaderConfig {
                batch_size: 80,
                workers: 2,
                seed: 1,
                ..Default::default()
            };
            let mut n = 0;
            for batch in Loader::new(Arc::clone(&sources), items.clone(), config).unwrap() {
                n += black_box(batch.grids.len());
            }
            n
        })
    });
    group.finish();
}

criterion_group!(benches, loader);
criterion_main!(benches);
