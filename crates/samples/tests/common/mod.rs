//! Test meshes shared by the integration tests.
#![allow(dead_code)]

use normalnet_mesh::Mesh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;

/// The cube [0, n]³ with an n×n grid of squares on each side, two triangles
/// per square, outward orientation.
pub fn grid_cube(n: i64) -> Mesh {
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let mut id = |p: [i64; 3], positions: &mut Vec<[f64; 3]>| {
        *index.entry(p).or_insert_with(|| {
            positions.push(p.map(|c| c as f64));
            (positions.len() - 1) as u32
        })
    };
    // (normal axis, side) → the two in-plane axes ordered so u × v = outward.
    for axis in 0..3 {
        for side in [0, n] {
            let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
            if side == 0 {
                std::mem::swap(&mut u, &mut v);
            }
            for i in 0..n {
                for j in 0..n {
                    let corner = |a: i64, b: i64| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[u] = a;
                        p[v] = b;
                        p
                    };
                    let q = [
                        corner(i, j),
                        corner(i + 1, j),
                        corner(i + 1, j + 1),
                        corner(i, j + 1),
                    ]
                    .map(|p| id(p, &mut positions));
                    faces.push([q[0], q[1], q[2]]);
                    faces.push([q[0], q[2], q[3]]);
                }
            }
        }
    }
    Mesh::new(positions, faces).unwrap()
}

pub fn noisy_copy(mesh: &Mesh, sigma: f64, seed: u64) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    mesh.with_positions(
        mesh.positions
            .iter()
            .map(|p| p.map(|c| c + sigma * rng.random_range(-1.0..1.0)))
            .collect(),
    )
}
