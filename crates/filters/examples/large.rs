//! Times one method on a generated ~1M-face noisy UV sphere (peak memory:
//! run under `/usr/bin/time -v`).
//!
//! `cargo run --release -p normalnet-filters --example large -- gnf 708`
//! (`rings` R gives about 4·R² faces: 500 → 1.0M).

use normalnet_filters::Method;
use normalnet_mesh::{Mesh, NoProgress};
use std::time::Instant;

fn sphere(rings: usize) -> Mesh {
    let segs = 2 * rings;
    let mut p = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segs {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / segs as f64;
            p.push([th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()]);
        }
    }
    p.push([0.0, 0.0, -1.0]);
    // Deterministic radial noise of about 0.3 mean edge lengths.
    let l_e = std::f64::consts::PI / rings as f64;
    for (k, x) in p.iter_mut().enumerate() {
        let r = 1.0 + 0.3 * l_e * (((k * 7919) % 13) as f64 / 6.0 - 1.0);
        *x = x.map(|c| c * r);
    }
    let last = (p.len() - 1) as u32;
    let id = |i: usize, j: usize| (1 + (i - 1) * segs + j % segs) as u32;
    let mut f = Vec::new();
    for j in 0..segs {
        f.push([0, id(1, j), id(1, j + 1)]);
        f.push([last, id(rings - 1, j + 1), id(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segs {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::new(p, f).unwrap()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "gnf".into());
    let rings: usize = args
        .next()
        .map(|s| s.parse().expect("rings"))
        .unwrap_or(500);
    let mesh = sphere(rings);
    let method = Method::from_name(&name).expect("method");
    let t = Instant::now();
    let out = method.denoise(&mesh, &NoProgress).expect("denoise");
    println!(
        "{name}: {} faces, {} vertices, {:.2} s, {} threads, finite: {}",
        mesh.num_faces(),
        mesh.num_vertices(),
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads(),
        out.positions.iter().flatten().all(|c| c.is_finite())
    );
}
