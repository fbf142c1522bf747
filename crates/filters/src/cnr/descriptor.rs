//! The filtered facet normal descriptor (FND) of CNR (SPEC §9.1): a face's
//! own normal and 8 bilateral-filtered normals (one pass each over the faces
//! sharing a vertex with it, σ_s ∈ {1, 2}·l_e × σ_r ∈ {0.1, 0.2, 0.35, 0.5}),
//! 27 numbers, expressed in a frame that makes it rotation invariant.
//!
//! Frame: `T = Σ_k s_k s_kᵀ` over the 9 unit vectors; the rows of `R` are
//! its eigenvectors by ascending eigenvalue (the last ≈ the dominant normal
//! direction). Eigenvector signs are free, so each row is oriented: the last
//! so that the own normal has z ≥ 0 (SPEC), the first two so that the sum of
//! the 9 vectors has a non-negative component along them (our choice: it
//! makes the descriptor a function of the geometry, not of the eigen
//! solver). `R` may then be a reflection; it is used consistently (targets
//! `R·n`, outputs `Rᵀ·y`).

use crate::symmetric_eigen;
use normalnet_mesh::FaceGeometry;
use normalnet_mesh::csr::Csr;
use normalnet_mesh::vec3::{self, Vec3};
use rayon::prelude::*;

/// σ_s of the filtered normals, in units of the mean edge length l_e.
pub const SIGMA_S: [f64; 2] = [1.0, 2.0];
/// σ_r of the filtered normals.
pub const SIGMA_R: [f64; 4] = [0.1, 0.2, 0.35, 0.5];
/// Numbers per descriptor: 9 unit vectors.
pub const FND_LEN: usize = 27;

/// A 3×3 matrix, rows first.
pub type Mat3 = [[f64; 3]; 3];

/// `m · v`.
pub fn apply(m: &Mat3, v: Vec3) -> Vec3 {
    [vec3::dot(m[0], v), vec3::dot(m[1], v), vec3::dot(m[2], v)]
}

/// `mᵀ · v`.
pub fn apply_transposed(m: &Mat3, v: Vec3) -> Vec3 {
    let mut out = [0.0; 3];
    for (r, row) in m.iter().enumerate() {
        for c in 0..3 {
            out[c] += row[c] * v[r];
        }
    }
    out
}

/// The 9 unit vectors of face `f` in world coordinates.
fn raw(f: usize, geometry: &FaceGeometry, rings: &Csr, l_e: f64) -> [Vec3; 9] {
    let n_i = geometry.normals[f];
    let c_i = geometry.centres[f];
    let mut out = [n_i; 9];
    let mut k = 1;
    for &s in &SIGMA_S {
        let ss = 2.0 * (s * l_e) * (s * l_e);
        for &r in &SIGMA_R {
            let rr = 2.0 * r * r;
            let mut sum = [0.0; 3];
            for &j in rings.row(f) {
                let j = j as usize;
                let n_j = geometry.normals[j];
                let d2 = vec3::dist2(c_i, geometry.centres[j]);
                let w = geometry.areas[j] * (-d2 / ss).exp() * (-vec3::dist2(n_i, n_j) / rr).exp();
                sum = vec3::add(sum, vec3::scale(n_j, w));
            }
            let unit = vec3::normalize_or_zero(sum);
            out[k] = if unit == [0.0; 3] { n_i } else { unit };
            k += 1;
        }
    }
    out
}

/// The frame of 9 unit vectors (module docs).
fn frame(s: &[Vec3; 9]) -> Mat3 {
    let mut t = [[0.0; 3]; 3];
    for v in s {
        for r in 0..3 {
            for c in 0..3 {
                t[r][c] += v[r] * v[c];
            }
        }
    }
    let (values, vectors) = symmetric_eigen(t);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut m = [vectors[order[0]], vectors[order[1]], vectors[order[2]]];
    let sum = s.iter().fold([0.0; 3], |acc, v| vec3::add(acc, *v));
    for row in m.iter_mut().take(2) {
        if vec3::dot(*row, sum) < 0.0 {
            *row = vec3::scale(*row, -1.0);
        }
    }
    if vec3::dot(m[2], s[0]) < 0.0 {
        m[2] = vec3::scale(m[2], -1.0);
    }
    m
}

/// The rotated descriptor of every face and its frame `R`. `rings` are the
/// 1-ring face patches (`Topology::face_rings(1)`), `l_e` the mean edge
/// length of the current mesh.
pub fn descriptors(geometry: &FaceGeometry, rings: &Csr, l_e: f64) -> Vec<([f64; FND_LEN], Mat3)> {
    (0..geometry.normals.len())
        .into_par_iter()
        .map(|f| {
            let s = raw(f, geometry, rings, l_e);
            let r = frame(&s);
            let mut d = [0.0; FND_LEN];
            for (k, v) in s.iter().enumerate() {
                let x = apply(&r, *v);
                d[3 * k..3 * k + 3].copy_from_slice(&x);
            }
            (d, r)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::geometry::mean_edge_length;
    use normalnet_mesh::{Mesh, Topology};

    fn bumpy() -> Mesh {
        Mesh::height_grid(8, |i, j| {
            let (x, y) = (i as f64, j as f64);
            0.3 * (x * 0.7).sin() * (y * 0.5).cos() + 0.05 * ((i * 7 + j * 3) % 5) as f64
        })
    }

    fn fnds(mesh: &Mesh) -> Vec<([f64; FND_LEN], Mat3)> {
        let t = Topology::new(mesh.num_vertices(), &mesh.faces);
        descriptors(
            &FaceGeometry::new(mesh),
            &t.face_rings(1),
            mean_edge_length(mesh, &t),
        )
    }

    /// Rotating and scaling the mesh leaves the descriptors unchanged, and
    /// the frames rotate with it.
    #[test]
    fn descriptors_are_rotation_and_scale_invariant() {
        let mesh = bumpy();
        let (s, c) = (0.8f64.sin(), 0.8f64.cos());
        // rotation about (1, 1, 1)/√3 by 0.8 rad (Rodrigues)
        let k = 1.0 / 3f64.sqrt();
        let rot: Mat3 = [
            [
                c + k * k * (1.0 - c),
                k * k * (1.0 - c) - k * s,
                k * k * (1.0 - c) + k * s,
            ],
            [
                k * k * (1.0 - c) + k * s,
                c + k * k * (1.0 - c),
                k * k * (1.0 - c) - k * s,
            ],
            [
                k * k * (1.0 - c) - k * s,
                k * k * (1.0 - c) + k * s,
                c + k * k * (1.0 - c),
            ],
        ];
        let moved = mesh.with_positions(
            mesh.positions
                .iter()
                .map(|&p| vec3::add(vec3::scale(apply(&rot, p), 3.7), [5.0, -2.0, 1.0]))
                .collect(),
        );
        let (a, b) = (fnds(&mesh), fnds(&moved));
        let mut worst: f64 = 0.0;
        for ((da, _), (db, _)) in a.iter().zip(&b) {
            for (x, y) in da.iter().zip(db) {
                worst = worst.max((x - y).abs());
            }
        }
        assert!(worst < 1e-6, "largest change {worst}");
        // the own normal sits on +z, with unit length
        for (d, _) in &a {
            assert!(d[2] >= 0.0 && (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_plane_has_the_trivial_descriptor() {
        let mut mesh = bumpy();
        for p in &mut mesh.positions {
            p[2] = 0.0;
        }
        for (d, r) in fnds(&mesh) {
            for k in 0..9 {
                assert!((d[3 * k + 2] - 1.0).abs() < 1e-9, "{d:?}");
            }
            // R maps the plane normal to +z
            assert!((apply(&r, [0.0, 0.0, 1.0])[2] - 1.0).abs() < 1e-9);
        }
    }
}
