//! Vertex update from filtered face normals: Sun, Rosin, Martin, Langbein
//! (2007), "Fast and effective feature-preserving mesh denoising", IEEE TVCG
//! 13(5), doi:10.1109/TVCG.2007.1065, Eq. (8); SPEC §4.
//!
//! One pass moves every vertex `x_i ← x_i + (1/|F(i)|) Σ_{j∈F(i)} n_j (n_j · (c_j − x_i))`
//! with `F(i)` the faces incident to vertex i, `n_j` the filtered normals and
//! `c_j` the centroids of the *current* positions, recomputed every pass
//! (Jacobi style: all vertices read the previous pass). Vertices without faces
//! stay where they are; a zero filtered normal (degenerate face) contributes
//! nothing but still counts in `|F(i)|`, as in the reference code.
//! Boundary vertices move like the others unless the caller fixes them
//! ([`vertex_update_in_place_fixed`]): GuidedDenoising's GNF moves them, its
//! BNF keeps them fixed.
//!
//! Used by every classical filter of this crate and by NormalNet's inference.

use normalnet_mesh::geometry::triangle_centre;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Topology};
use rayon::prelude::*;

/// Reusable scratch for [`vertex_update_in_place`]: face centroids and the
/// next positions. Build once per mesh size; no allocation per pass.
#[derive(Clone, Debug, Default)]
pub struct VertexUpdateBuffers {
    centres: Vec<Vec3>,
    next: Vec<Vec3>,
}

/// `iterations` vertex-update passes with the filtered `normals` (one
/// `[f64; 3]` per face, len #F), returning the moved mesh (same faces).
///
/// # Panics
/// If `normals.len() != mesh.num_faces()` or the topology was built for
/// another mesh (a broken invariant of the caller).
pub fn vertex_update(
    mesh: &Mesh,
    topology: &Topology,
    normals: &[Vec3],
    iterations: usize,
) -> Mesh {
    let mut positions = mesh.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    vertex_update_in_place(
        &mut positions,
        &mesh.faces,
        topology,
        normals,
        iterations,
        &mut buffers,
    );
    mesh.with_positions(positions)
}

/// In-place form of [`vertex_update`] for hot loops: `positions` (len #V) are
/// updated `iterations` times; `buffers` are resized on first use and reused.
///
/// # Panics
/// If `normals.len() != faces.len()` or `topology` does not match `faces`.
pub fn vertex_update_in_place(
    positions: &mut Vec<Vec3>,
    faces: &[[u32; 3]],
    topology: &Topology,
    normals: &[Vec3],
    iterations: usize,
    buffers: &mut VertexUpdateBuffers,
) {
    vertex_update_in_place_fixed(
        positions, faces, topology, normals, iterations, None, buffers,
    );
}

/// [`vertex_update_in_place`] where vertices flagged in `fixed` (len #V, e.g.
/// `Topology::boundary_vertices()`) keep their positions.
///
/// # Panics
/// As [`vertex_update_in_place`], or if `fixed` has the wrong length.
pub fn vertex_update_in_place_fixed(
    positions: &mut Vec<Vec3>,
    faces: &[[u32; 3]],
    topology: &Topology,
    normals: &[Vec3],
    iterations: usize,
    fixed: Option<&[bool]>,
    buffers: &mut VertexUpdateBuffers,
) {
    if let Some(fixed) = fixed {
        assert_eq!(fixed.len(), positions.len(), "one flag per vertex");
    }
    assert_eq!(normals.len(), faces.len(), "one filtered normal per face");
    assert_eq!(
        topology.num_faces(),
        faces.len(),
        "topology of another mesh"
    );
    assert_eq!(
        topology.num_vertices,
        positions.len(),
        "topology of another mesh"
    );
    buffers.centres.resize(faces.len(), [0.0; 3]);
    buffers.next.resize(positions.len(), [0.0; 3]);
    for _ in 0..iterations {
        {
            let p: &[Vec3] = positions;
            buffers
                .centres
                .par_iter_mut()
                .zip(faces.par_iter())
                .with_min_len(1024)
                .for_each(|(c, t)| {
                    *c = triangle_centre(p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
                });
        }
        let centres = &buffers.centres;
        let p: &[Vec3] = positions;
        buffers
            .next
            .par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(i, out)| {
                let x_i = p[i];
                let row = topology.vertex_faces.row(i);
                if row.is_empty() || fixed.is_some_and(|fx| fx[i]) {
                    *out = x_i;
                    return;
                }
                let mut sum = [0.0; 3];
                for &j in row {
                    let n_j = normals[j as usize];
                    let d = vec3::dot(n_j, vec3::sub(centres[j as usize], x_i));
                    sum = vec3::add(sum, vec3::scale(n_j, d));
                }
                *out = vec3::add(x_i, vec3::scale(sum, 1.0 / row.len() as f64));
            });
        std::mem::swap(positions, &mut buffers.next);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::geometry::face_normals;

    fn tetrahedron() -> Mesh {
        Mesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn own_normals_leave_mesh_unchanged() {
        let m = tetrahedron();
        let t = Topology::new(m.num_vertices(), &m.faces);
        let out = vertex_update(&m, &t, &face_normals(&m), 5);
        for (a, b) in out.positions.iter().zip(&m.positions) {
            assert!(vec3::dist2(*a, *b) < 1e-28, "{a:?} {b:?}");
        }
    }

    #[test]
    fn flattens_a_bump_onto_the_plane() {
        // A fan of 4 triangles around a raised centre vertex; target normal +z.
        let m = Mesh::new(
            vec![
                [0.0, 0.0, 0.3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, -1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
        )
        .unwrap();
        let t = Topology::new(5, &m.faces);
        let normals = vec![[0.0, 0.0, 1.0]; 4];
        let out = vertex_update(&m, &t, &normals, 200);
        // All vertices converge to one plane z = const.
        let z0 = out.positions[0][2];
        for p in &out.positions {
            assert!((p[2] - z0).abs() < 1e-6, "{p:?}");
        }
    }

    #[test]
    fn fixed_vertices_do_not_move() {
        let m = Mesh::new(
            vec![
                [0.0, 0.0, 0.3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [0.0, -1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]],
        )
        .unwrap();
        let t = Topology::new(5, &m.faces);
        let fixed = t.boundary_vertices();
        assert_eq!(fixed, vec![false, true, true, true, true]);
        let mut p = m.positions.clone();
        let normals = vec![[0.0, 0.0, 1.0]; 4];
        let mut b = VertexUpdateBuffers::default();
        vertex_update_in_place_fixed(&mut p, &m.faces, &t, &normals, 100, Some(&fixed), &mut b);
        assert_eq!(&p[1..], &m.positions[1..]);
        assert!(p[0][2].abs() < 1e-9, "{:?}", p[0]);
    }

    #[test]
    fn zero_normals_and_isolated_vertices_stay_finite() {
        let m = Mesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [5.0, 5.0, 5.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let t = Topology::new(4, &m.faces);
        let out = vertex_update(&m, &t, &face_normals(&m), 3);
        assert_eq!(out.positions, m.positions);
    }
}
