//! Rendering speed: a procedural sphere-like mesh (always) and Bunny0.2 from
//! `../shared/data/gd` (when present) at 1024×768, flat shading, 1× and 2×
//! supersampling. Setup (mesh building, reading) is outside the timed closure.

#![allow(missing_docs)] // criterion's generated functions

use criterion::{Criterion, criterion_group, criterion_main};
use normalnet_mesh::Mesh;
use normalnet_render::{RenderOptions, Shading, render};
use std::hint::black_box;

/// A UV sphere with `n × 2n` quads (4n² triangles).
fn sphere(n: usize) -> Mesh {
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for i in 0..=n {
        let theta = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let phi = std::f64::consts::PI * j as f64 / n as f64;
            positions.push([
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ]);
        }
    }
    let idx = |i: usize, j: usize| (i * 2 * n + j % (2 * n)) as u32;
    for i in 0..n {
        for j in 0..2 * n {
            faces.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            faces.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    Mesh::new(positions, faces).expect("valid sphere")
}

fn bench(c: &mut Criterion) {
    let opts = RenderOptions {
        width: 1024,
        height: 768,
        ..Default::default()
    };
    let ball = sphere(130); // 67,600 faces, about Bunny0.2's 69,451
    c.bench_function("render sphere 67k faces 1024x768 flat", |b| {
        b.iter(|| render(black_box(&ball), &opts).unwrap())
    });
    let bunny_path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gd/Bunny0.2/Noisy.obj"
    );
    match normalnet_mesh::read_mesh(bunny_path) {
        Ok(bunny) => {
            c.bench_function("render Bunny0.2 1024x768 flat", |b| {
                b.iter(|| render(black_box(&bunny), &opts).unwrap())
            });
            let smooth = RenderOptions {
                shading: Shading::Smooth,
                supersample: 2,
                ..opts.clone()
            };
            c.bench_function("render Bunny0.2 1024x768 smooth 2x supersampled", |b| {
                b.iter(|| render(black_box(&bunny), &smooth).unwrap())
            });
        }
        Err(e) => eprintln!("skipping Bunny0.2 bench: {e}"),
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
