//! Mesh-wide means used for kernel widths (`d_s`, `l_e`, SPEC §1), summed in
//! fixed-size chunks so that the result — and every filter that scales by it —
//! does not depend on the number of rayon threads (a plain parallel `sum`
//! associates differently per thread count and changes the last bits).

use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, NO_FACE, Topology};
use rayon::prelude::*;

/// Chunk length of the deterministic reductions.
const CHUNK: usize = 4096;

/// `Σ_k f(k)` over `0..n` and the number of `Some` terms, summed per fixed
/// chunk in parallel, then the chunk sums in order.
fn deterministic_sum(n: usize, f: impl Fn(usize) -> Option<f64> + Sync) -> (f64, usize) {
    let chunks: Vec<(f64, usize)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut s = 0.0;
            let mut k = 0;
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                if let Some(x) = f(i) {
                    s += x;
                    k += 1;
                }
            }
            (s, k)
        })
        .collect();
    chunks
        .iter()
        .fold((0.0, 0), |(s, k), (x, j)| (s + x, k + j))
}

/// `d_s`: mean distance between the centres of edge-adjacent faces (one per
/// interior edge), 0 when there is none. Same definition as
/// `normalnet_mesh::geometry::mean_centre_distance`, thread-count independent.
pub fn mean_centre_distance(topology: &Topology, centres: &[Vec3]) -> f64 {
    let (sum, count) = deterministic_sum(topology.edge_faces.len(), |e| {
        let [a, b] = topology.edge_faces[e];
        (a != NO_FACE && b != NO_FACE)
            .then(|| vec3::dist2(centres[a as usize], centres[b as usize]).sqrt())
    });
    if count == 0 { 0.0 } else { sum / count as f64 }
}

/// `l_e`: mean length over unique edges, 0 without edges. Same definition
/// as `normalnet_mesh::geometry::mean_edge_length`, thread-count independent.
pub fn mean_edge_length(mesh: &Mesh, topology: &Topology) -> f64 {
    let (sum, count) = deterministic_sum(topology.edges.len(), |e| {
        let [a, b] = topology.edges[e];
        Some(vec3::dist2(mesh.positions[a as usize], mesh.positions[b as usize]).sqrt())
    });
    if count == 0 { 0.0 } else { sum / count as f64 }
}

/// The spatial width `σ = sigma_over_ds · d_s` of a filtering pass, with
/// `d_s` from the current face centres; `None` when it is not positive and
/// finite (no edge-adjacent faces, or a collapsed mesh), in which case the
/// pass keeps the normals it was given.
pub(crate) fn spatial_sigma(
    topology: &Topology,
    centres: &[Vec3],
    sigma_over_ds: f64,
) -> Option<f64> {
    let sigma = sigma_over_ds * mean_centre_distance(topology, centres);
    (sigma > 0.0 && sigma.is_finite()).then_some(sigma)
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::geometry;

    #[test]
    fn agrees_with_the_mesh_crate() {
        let mut p = Vec::new();
        for y in 0..60 {
            for x in 0..60 {
                p.push([x as f64, y as f64, ((x * y) % 7) as f64 * 0.1]);
            }
        }
        let mut f = Vec::new();
        for y in 0..59u32 {
            for x in 0..59u32 {
                let id = |x: u32, y: u32| y * 60 + x;
                f.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                f.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        let m = Mesh::new(p, f).unwrap();
        let t = Topology::new(m.num_vertices(), &m.faces);
        let c = geometry::face_centres(&m);
        let a = mean_centre_distance(&t, &c);
        let b = geometry::mean_centre_distance(&t, &c);
        assert!((a - b).abs() < 1e-12 * b);
        let a = mean_edge_length(&m, &t);
        let b = geometry::mean_edge_length(&m, &t);
        assert!((a - b).abs() < 1e-12 * b);
    }
}
