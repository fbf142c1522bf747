//! Small meshes for the unit tests of this crate.

use normalnet_mesh::Mesh;

/// An `n × n` grid of squares (two triangles each) in x/y, with heights
/// `z(i, j)` at the grid points.
pub fn height_grid(n: usize, z: impl Fn(usize, usize) -> f64) -> Mesh {
    let mut p = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            p.push([i as f64, j as f64, z(i, j)]);
        }
    }
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..n {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::new(p, f).expect("a grid is a valid mesh")
}
