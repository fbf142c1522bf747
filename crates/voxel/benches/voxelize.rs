//! Benchmarks: voxelized faces per second on one core (Fandisk0.3 when the
//! data is present, else a procedural shape) for each preset, the
//! per-mesh precomputation (the training loader's bench is in
//! `normalnet-samples`). Run: `cargo bench -p normalnet-voxel --bench voxelize`.
#![allow(missing_docs)] // criterion's generated functions

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use normalnet_mesh::noise::{NoiseParams, add_noise};
use normalnet_mesh::{Mesh, Topology};
use normalnet_voxel::shapes::generate_seeded;
use normalnet_voxel::{Scratch, VoxelParams, Voxelizer};
use std::hint::black_box;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

fn bench_mesh() -> (String, Mesh) {
    let path = format!("{DATA}/gd/Fandisk0.3/Noisy.obj");
    match normalnet_mesh::io::read_mesh(&path) {
        Ok(m) => ("fandisk0.3".into(), m),
        Err(_) => {
            eprintln!("{path} not found: benchmarking a procedural shape");
            let clean = generate_seeded(4, 12_000).expect("shape");
            (
                "shape4".into(),
                add_noise(&clean, &NoiseParams::default()).expect("noise"),
            )
        }
    }
}

fn voxelize(c: &mut Criterion) {
    let (name, mesh) = bench_mesh();
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let faces: Vec<usize> = (0..mesh.num_faces()).step_by(13).take(1000).collect();
    let mut group = c.benchmark_group(format!("voxelize_one_core_{name}"));
    group.sample_size(10);
    for (preset, params) in [
        ("paper", VoxelParams::paper()),
        ("lite", VoxelParams::lite()),
        ("tiny", VoxelParams::tiny()),
    ] {
        let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
        let mut grid = vec![0.0f32; params.grid_len()];
        let mut scratch = Scratch::new();
        group.throughput(Throughput::Elements(faces.len() as u64));
        group.bench_function(preset, |b| {
            b.iter(|| {
                for &f in &faces {
                    vox.voxelize_face_with(&mut scratch, f, 0.0, &mut grid);
                    black_box(&grid);
                }
            })
        });
    }
    group.finish();

    let mut group = c.benchmark_group(format!("voxelizer_new_{name}"));
    group.sample_size(10);
    group.bench_function("lite", |b| {
        b.iter(|| Voxelizer::new(&mesh, &topo, VoxelParams::lite()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, voxelize);
criterion_main!(benches);
