//! Per-face and per-mesh geometric quantities (SPEC §1): face normals, areas,
//! centres, vertex normals, mean edge length `l_e`, mean centre distance `d_s`.

use crate::mesh::Mesh;
use crate::topology::{NO_FACE, Topology};
use crate::vec3::{self, Vec3};
use rayon::prelude::*;

/// Unit normal of the triangle `(a, b, c)`, zero when degenerate.
#[inline]
pub fn triangle_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    vec3::normalize_or_zero(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
}

/// Area of the triangle `(a, b, c)`.
#[inline]
pub fn triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f64 {
    0.5 * vec3::norm(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
}

/// Centroid of the triangle `(a, b, c)`.
#[inline]
pub fn triangle_centre(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0)
}

/// Unit face normals, one `[f64; 3]` per face (len #F); zero for degenerate faces.
pub fn face_normals(mesh: &Mesh) -> Vec<Vec3> {
    (0..mesh.num_faces())
        .into_par_iter()
        .map(|f| {
            let [a, b, c] = mesh.corners(f);
            triangle_normal(a, b, c)
        })
        .collect()
}

/// Face areas (len #F).
pub fn face_areas(mesh: &Mesh) -> Vec<f64> {
    (0..mesh.num_faces())
        .into_par_iter()
        .map(|f| {
            let [a, b, c] = mesh.corners(f);
            triangle_area(a, b, c)
        })
        .collect()
}

/// Face centroids (len #F).
pub fn face_centres(mesh: &Mesh) -> Vec<Vec3> {
    (0..mesh.num_faces())
        .into_par_iter()
        .map(|f| {
            let [a, b, c] = mesh.corners(f);
            triangle_centre(a, b, c)
        })
        .collect()
}

/// Number of degenerate faces (zero normal).
pub fn count_degenerate_faces(mesh: &Mesh) -> usize {
    face_normals(mesh)
        .iter()
        .filter(|n| vec3::norm2(**n) == 0.0)
        .count()
}

/// Normals, areas and centres of every face for one set of positions:
/// rebuilt explicitly each pass, never a lazy cache.
#[derive(Clone, Debug)]
pub struct FaceGeometry {
    /// unit normals, zero for degenerate faces (len #F)
    pub normals: Vec<Vec3>,
    /// areas (len #F)
    pub areas: Vec<f64>,
    /// centroids (len #F)
    pub centres: Vec<Vec3>,
}

impl FaceGeometry {
    /// Computes all three quantities in one parallel sweep.
    pub fn new(mesh: &Mesh) -> FaceGeometry {
        let n = mesh.num_faces();
        let mut g = FaceGeometry {
            normals: vec![[0.0; 3]; n],
            areas: vec![0.0; n],
            centres: vec![[0.0; 3]; n],
        };
        g.update(mesh);
        g
    }

    /// Recomputes in place for new positions (same faces).
    pub fn update(&mut self, mesh: &Mesh) {
        self.normals
            .par_iter_mut()
            .zip(self.areas.par_iter_mut())
            .zip(self.centres.par_iter_mut())
            .enumerate()
            .for_each(|(f, ((n, a), c))| {
                let [p, q, r] = mesh.corners(f);
                let x = vec3::cross(vec3::sub(q, p), vec3::sub(r, p));
                *n = vec3::normalize_or_zero(x);
                *a = 0.5 * vec3::norm(x);
                *c = triangle_centre(p, q, r);
            });
    }
}

/// Vertex normals for the noise model (SPEC §1): normalised *unweighted* sum
/// of incident unit face normals (OpenMesh `calc_vertex_normal_fast`); zero for
/// isolated vertices.
pub fn vertex_normals(mesh: &Mesh, face_normals: &[Vec3]) -> Vec<Vec3> {
    let mut sum = vec![[0.0; 3]; mesh.num_vertices()];
    for (t, n) in mesh.faces.iter().zip(face_normals) {
        for &v in t {
            sum[v as usize] = vec3::add(sum[v as usize], *n);
        }
    }
    sum.into_iter().map(vec3::normalize_or_zero).collect()
}

/// Area-weighted vertex normals, one unit `[f64; 3]` per vertex (len #V):
/// the normalised sum of `(q − p) × (r − p)` (twice the area times the unit
/// normal) over the faces around each vertex, in face order (so the bits do
/// not depend on the thread count). Zero for isolated vertices and where the
/// sum vanishes. What the attribute writers ([`crate::io::write_mesh_file`])
/// store as the normals of a denoised surface.
pub fn area_weighted_vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut sum = vec![[0.0; 3]; mesh.num_vertices()];
    for (f, t) in mesh.faces.iter().enumerate() {
        let [p, q, r] = mesh.corners(f);
        let x = vec3::cross(vec3::sub(q, p), vec3::sub(r, p));
        for &v in t {
            sum[v as usize] = vec3::add(sum[v as usize], x);
        }
    }
    sum.into_iter().map(vec3::normalize_or_zero).collect()
}

/// Chunk length of the deterministic parallel sums below.
const SUM_CHUNK: usize = 4096;

/// `l_e`: mean length over unique edges (deterministic: the same bits for
/// any thread count).
pub fn mean_edge_length(mesh: &Mesh, topology: &Topology) -> f64 {
    if topology.edges.is_empty() {
        return 0.0;
    }
    // Fixed chunks summed in order: the same bits whatever the thread count
    // (a rayon `sum` may associate differently from run to run).
    let partial: Vec<f64> = topology
        .edges
        .par_chunks(SUM_CHUNK)
        .map(|c| {
            c.iter()
                .map(|&[a, b]| {
                    vec3::dist2(mesh.positions[a as usize], mesh.positions[b as usize]).sqrt()
                })
                .sum::<f64>()
        })
        .collect();
    partial.iter().sum::<f64>() / topology.edges.len() as f64
}

/// `d_s`: mean distance between the centres of edge-adjacent faces (each
/// interior manifold edge counted once); 0 when no face has an edge neighbour.
pub fn mean_centre_distance(topology: &Topology, centres: &[Vec3]) -> f64 {
    let partial: Vec<(f64, usize)> = topology
        .edge_faces
        .par_chunks(SUM_CHUNK)
        .map(|c| {
            c.iter()
                .filter(|[a, b]| *a != NO_FACE && *b != NO_FACE)
                .fold((0.0, 0), |(s, n), &[a, b]| {
                    (
                        s + vec3::dist2(centres[a as usize], centres[b as usize]).sqrt(),
                        n + 1,
                    )
                })
        })
        .collect();
    let (sum, count) = partial
        .iter()
        .fold((0.0, 0usize), |x, y| (x.0 + y.0, x.1 + y.1));
    if count == 0 { 0.0 } else { sum / count as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_quantities() {
        let m = Mesh::unit_square();
        let t = Topology::new(4, &m.faces);
        let g = FaceGeometry::new(&m);
        assert_eq!(g.normals, vec![[0.0, 0.0, 1.0]; 2]);
        assert_eq!(g.areas, vec![0.5, 0.5]);
        let le = mean_edge_length(&m, &t);
        assert!((le - (4.0 + 2f64.sqrt()) / 5.0).abs() < 1e-15);
        let ds = mean_centre_distance(&t, &g.centres);
        assert!((ds - (2.0f64 / 9.0).sqrt()).abs() < 1e-12, "{ds}");
        let vn = vertex_normals(&m, &g.normals);
        assert!(vn.iter().all(|n| *n == [0.0, 0.0, 1.0]));
    }

    #[test]
    fn degenerate_face_has_zero_normal_not_nan() {
        let m = Mesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let g = FaceGeometry::new(&m);
        assert_eq!(g.normals[0], [0.0; 3]);
        assert_eq!(g.areas[0], 0.0);
        assert_eq!(count_degenerate_faces(&m), 1);
    }
}
