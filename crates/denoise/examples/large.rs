//! Times one method on a generated ~1M-face noisy torus (peak memory: run
//! under `/usr/bin/time -v`).
//!
//! `cargo run --release -p normalnet-denoise --example large -- gnf 500`
//! (`rings` R gives 4·R² faces: 500 → 1.0M); further arguments `KEY=VALUE`
//! set the method's parameters (JSON values), e.g.
//! `-- normalnet 500 iterations=1 vertex_iterations=5`.

use normalnet_denoise::{Denoiser, Params};
use normalnet_mesh::{Mesh, NoProgress};
use std::time::Instant;

/// A torus of `rings × 2·rings` split quads (every vertex of valence 6:
/// no UV-sphere poles, whose valence-4R fans make vertex-ring work
/// quadratic), with deterministic normal noise of about 0.3 l_e.
fn torus(rings: usize) -> Mesh {
    let (nu, nv) = (2 * rings, rings);
    let (big, small) = (3.0, 1.0);
    let l_e = 2.0 * std::f64::consts::PI * small / nv as f64;
    let mut p = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
        for j in 0..nv {
            let v = 2.0 * std::f64::consts::PI * j as f64 / nv as f64;
            let k = i * nv + j;
            let r = small * (1.0 + 0.3 * l_e * (((k * 7919) % 13) as f64 / 6.0 - 1.0));
            p.push([
                (big + r * v.cos()) * u.cos(),
                (big + r * v.cos()) * u.sin(),
                r * v.sin(),
            ]);
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + j % nv) as u32;
    let mut f = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
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
    let mut params = Params::new();
    for kv in args {
        let (k, v) = kv.split_once('=').expect("parameters are KEY=VALUE");
        let v = serde_json::from_str(v).unwrap_or_else(|_| serde_json::Value::String(v.into()));
        params.insert(k.into(), v);
    }
    let mesh = torus(rings);
    let method = Denoiser::new(&name, &params).expect("method");
    let t = Instant::now();
    let out = method.denoise(&mesh, None, &NoProgress).expect("denoise");
    println!(
        "{name}: {} faces, {} vertices, {:.2} s, {} threads, finite: {}",
        mesh.num_faces(),
        mesh.num_vertices(),
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads(),
        out.positions.iter().flatten().all(|c| c.is_finite())
    );
}
