//! Meshes the unit tests build (test builds only).

use normalnet_mesh::Mesh;

/// A `k × k` grid of unit squares, each split into two triangles, with
/// vertex `(x, y)` at height `z(x, y)`.
pub(crate) fn height_grid(k: usize, z: impl Fn(usize, usize) -> f64) -> Mesh {
    let mut p = Vec::new();
    for y in 0..=k {
        for x in 0..=k {
            p.push([x as f64, y as f64, z(x, y)]);
        }
    }
    let id = |x: usize, y: usize| (y * (k + 1) + x) as u32;
    let mut f = Vec::new();
    for y in 0..k {
        for x in 0..k {
            f.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
            f.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
        }
    }
    Mesh::new(p, f).expect("a grid is a valid mesh")
}
