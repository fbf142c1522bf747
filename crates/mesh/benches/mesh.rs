//! Benchmarks of the mesh core: load + face geometry + topology of Bunny0.2
//! and of a generated ~1M-face mesh, and `metrics::compare` on Julius0.2.
//! Data-dependent benches are skipped (with a message) when
//! `shared/data/gd` is absent.
//!
//! `CARGO_TARGET_DIR=target/geo cargo bench -p normalnet-mesh`

// criterion_group! generates an undocumented function.
#![allow(missing_docs)]

use criterion::{Criterion, criterion_group, criterion_main};
use normalnet_mesh::geometry::FaceGeometry;
use normalnet_mesh::io::{read_mesh, write_mesh};
use normalnet_mesh::metrics::compare;
use normalnet_mesh::{Mesh, Topology};
use std::hint::black_box;
use std::path::PathBuf;

fn gd() -> Option<PathBuf> {
    let d = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gd"
    ));
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("SKIP: {} not found", d.display());
        None
    }
}

/// Cube-sphere: each cube side an `n`×`n` grid of quads split in two,
/// projected onto the unit sphere; 12·n² faces, 6·n² + 2 vertices.
fn cube_sphere(n: usize) -> Mesh {
    let mut positions = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut faces = Vec::with_capacity(12 * n * n);
    let h = n as i64;
    for axis in 0..3 {
        for sign in [-1i64, 1] {
            for i in 0..h {
                for j in 0..h {
                    let mut v = [0u32; 4];
                    for (k, (a, b)) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                        .into_iter()
                        .enumerate()
                    {
                        let mut p = [0i64; 3];
                        p[axis] = sign * h;
                        p[(axis + 1) % 3] = 2 * a - h;
                        p[(axis + 2) % 3] = 2 * b - h;
                        v[k] = *index.entry(p).or_insert_with(|| {
                            let q = p.map(|x| x as f64);
                            let l = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
                            positions.push(q.map(|x| x / l));
                            (positions.len() - 1) as u32
                        });
                    }
                    if sign > 0 {
                        faces.push([v[0], v[1], v[2]]);
                        faces.push([v[0], v[2], v[3]]);
                    } else {
                        faces.push([v[0], v[2], v[1]]);
                        faces.push([v[0], v[3], v[2]]);
                    }
                }
            }
        }
    }
    Mesh::new(positions, faces).expect("valid sphere")
}

fn load_geometry_topology(path: &std::path::Path) -> (Mesh, FaceGeometry, Topology) {
    let m = read_mesh(path).expect("readable");
    let g = FaceGeometry::new(&m);
    let t = Topology::new(m.num_vertices(), &m.faces);
    (m, g, t)
}

fn benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh");
    group.sample_size(10);
    if let Some(d) = gd() {
        let bunny = d.join("Bunny0.2/Noisy.obj");
        group.bench_function("bunny0.2_load_normals_topology", |b| {
            b.iter(|| black_box(load_geometry_topology(&bunny)))
        });
        let gt = read_mesh(d.join("Julius0.2/Original.obj")).expect("julius");
        let res = read_mesh(d.join("Julius0.2/Noisy.obj")).expect("julius");
        group.bench_function("julius0.2_metrics_compare", |b| {
            b.iter(|| black_box(compare(&gt, &res).expect("same faces")))
        });
    }
    let big = cube_sphere(289); // 1 002 252 faces
    let dir = tempfile::tempdir().expect("tempdir");
    let obj = dir.path().join("sphere1m.obj");
    let ply = dir.path().join("sphere1m.ply");
    write_mesh(&obj, &big).expect("write obj");
    write_mesh(&ply, &big).expect("write ply");
    eprintln!(
        "generated sphere: {} vertices, {} faces",
        big.num_vertices(),
        big.num_faces()
    );
    group.bench_function("sphere1m_obj_load_normals_topology", |b| {
        b.iter(|| black_box(load_geometry_topology(&obj)))
    });
    group.bench_function("sphere1m_binary_ply_load_normals_topology", |b| {
        b.iter(|| black_box(load_geometry_topology(&ply)))
    });
    group.bench_function("sphere1m_obj_read_only", |b| {
        b.iter(|| black_box(read_mesh(&obj).expect("read")))
    });
    group.bench_function("sphere1m_binary_ply_read_only", |b| {
        b.iter(|| black_box(read_mesh(&ply).expect("read")))
    });
    group.bench_function("sphere1m_face_geometry", |b| {
        b.iter(|| black_box(FaceGeometry::new(&big)))
    });
    group.bench_function("sphere1m_topology", |b| {
        b.iter(|| black_box(Topology::new(big.num_vertices(), &big.faces)))
    });
    group.bench_function("sphere1m_obj_write", |b| {
        b.iter(|| write_mesh(&obj, &big).expect("write"))
    });
    group.finish();
}

criterion_group!(mesh_benches, benches);
criterion_main!(mesh_benches);
