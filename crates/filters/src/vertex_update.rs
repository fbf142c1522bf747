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
//! **Fold guard** (issue 14, [`VertexUpdate::fold_guard`]; on by default in
//! every classical method, off in the reference implementations and in
//! [`vertex_update_in_place`]): the update above can fold a face over. With
//! the guard, each face j gets a floor at the start of the call,
//! `φ_j = min(n̂_j · n_j, FOLD_GUARD_COS)` (`n̂_j` its unit normal at the
//! given positions, `n_j` its filtered normal, a degenerate face counts 0).
//! After the moves of a pass are proposed, every face whose `n̂_j · n_j`
//! would fall below `φ_j` is *folded*; each vertex of a folded face has
//! its step halved (up to [`FOLD_GUARD_HALVINGS`] times, then set to zero),
//! and the test is repeated until no face folds. So a face never turns
//! more than 60° away from its filtered normal, or, if it started beyond,
//! never farther than it started: it cannot flip against its target, and
//! it cannot drift edge-on first and flip in the next call. The rounds
//! terminate: each one lowers the step of at least one vertex of every
//! folded face, and a face whose three vertices are back at the start of
//! the pass is above its floor (by induction over the passes). Every round
//! is a pure per-face then per-vertex map, so the result does not depend on
//! the thread count; it costs one extra pass over the faces (a square root
//! each) when nothing folds.
//!
//! Used by every classical filter of this crate and by NormalNet's inference.
//! The guard works pass by pass against the filtered normals; after a
//! method's last pass, `normalnet_denoise::Denoiser::run` also checks the
//! whole result and repairs what still folded ([`mod@crate::fold_repair`],
//! issue 39).

use normalnet_mesh::geometry::triangle_centre;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::vec3::{cross, dot, sub};
use normalnet_mesh::{Mesh, Topology};
use rayon::prelude::*;

/// The fold guard's cone: a face may not turn farther than
/// `acos(FOLD_GUARD_COS)` = 60° from its filtered normal during the passes
/// of one call, unless it started farther, and then not farther than it
/// started (module docs). Chosen on noise-0.3 cow/spot (0 = only forbid
/// the flip itself: about half the folds remain; 0.9 folds least but
/// slows BNF's convergence, E_a +0.7°).
pub const FOLD_GUARD_COS: f64 = 0.5;

/// How many times the fold guard halves a vertex's step before it keeps
/// the vertex in place for the pass (steps 1, 1/2, 1/4, 1/8, then 0).
pub const FOLD_GUARD_HALVINGS: u8 = 3;

/// Reusable scratch for [`vertex_update_in_place`]: face centroids, the
/// next positions and the fold guard's floors, steps and halvings.
/// Build once per mesh size; no allocation per pass.
#[derive(Clone, Debug, Default)]
pub struct VertexUpdateBuffers {
    centres: Vec<Vec3>,
    next: Vec<Vec3>,
    steps: Vec<Vec3>,
    halvings: Vec<u8>,
    floors: Vec<f64>,
}

/// The passes of [`vertex_update_with`].
#[derive(Clone, Copy, Debug, Default)]
pub struct VertexUpdate<'a> {
    /// N_v: number of passes
    pub iterations: usize,
    /// vertices that keep their positions (one flag per vertex, len #V),
    /// e.g. `Topology::boundary_vertices()`
    pub fixed: Option<&'a [bool]>,
    /// the fold guard (module docs): `Some(cos)` keeps every face within
    /// `acos(cos)` of its filtered normal, or no farther than it started
    /// ([`FOLD_GUARD_COS`] is the default cone, `Some(0.0)` forbids only
    /// the flip itself); `None` switches it off
    pub fold_guard: Option<f64>,
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
    let update = VertexUpdate {
        iterations,
        fixed,
        fold_guard: None,
    };
    vertex_update_with(positions, faces, topology, normals, &update, buffers);
}

/// The vertex update with every option of [`VertexUpdate`]: `positions`
/// (len #V) are updated `update.iterations` times with the filtered
/// `normals` (one per face, len #F); `buffers` are resized on first use.
///
/// # Panics
/// If `normals.len() != faces.len()`, `topology` does not match `faces` and
/// `positions`, or `update.fixed` has the wrong length.
pub fn vertex_update_with(
    positions: &mut Vec<Vec3>,
    faces: &[[u32; 3]],
    topology: &Topology,
    normals: &[Vec3],
    update: &VertexUpdate,
    buffers: &mut VertexUpdateBuffers,
) {
    let fixed = update.fixed;
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
    if let Some(cone) = update.fold_guard {
        let p: &[Vec3] = positions;
        buffers.floors.resize(faces.len(), 0.0);
        buffers
            .floors
            .par_iter_mut()
            .zip(faces.par_iter().zip(normals.par_iter()))
            .with_min_len(1024)
            .for_each(|(floor, (t, &n))| *floor = facing(p, t, n).min(cone));
    }
    for _ in 0..update.iterations {
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
        if update.fold_guard.is_some() {
            guard_folds(positions, faces, topology, normals, buffers);
        }
        std::mem::swap(positions, &mut buffers.next);
    }
}

/// `n̂ · n` with `n̂` the triangle's unit normal (0 when degenerate): how
/// much the triangle faces `n`.
#[inline]
fn facing(p: &[Vec3], t: &[u32; 3], n: Vec3) -> f64 {
    let a = p[t[0] as usize];
    let normal = vec3::normalize_or_zero(cross(sub(p[t[1] as usize], a), sub(p[t[2] as usize], a)));
    dot(normal, n)
}

/// The fold guard of one pass (module docs): shortens the proposed moves
/// `buffers.next` from `positions` until no face falls below its floor.
/// The first round tests every face; later rounds only the faces around
/// the vertices the previous round moved (a face none of whose vertices
/// moved keeps its verdict, and every folded face has a vertex that moves).
fn guard_folds(
    positions: &[Vec3],
    faces: &[[u32; 3]],
    topology: &Topology,
    normals: &[Vec3],
    buffers: &mut VertexUpdateBuffers,
) {
    let floors: &[f64] = &buffers.floors;
    let is_folded = |next: &[Vec3], f: usize| facing(next, &faces[f], normals[f]) < floors[f];
    let next: &[Vec3] = &buffers.next;
    let mut folded: Vec<u32> = (0..faces.len() as u32)
        .into_par_iter()
        .with_min_len(1024)
        .filter(|&f| is_folded(next, f as usize))
        .collect();
    if folded.is_empty() {
        return;
    }
    let n_v = positions.len();
    buffers.halvings.clear();
    buffers.halvings.resize(n_v, 0);
    buffers.steps.resize(n_v, [0.0; 3]);
    buffers
        .steps
        .par_iter_mut()
        .zip(buffers.next.par_iter().zip(positions.par_iter()))
        .with_min_len(1024)
        .for_each(|(s, (&x, &p))| *s = sub(x, p));
    let mut vertices: Vec<u32> = Vec::new();
    let mut active: Vec<u32> = Vec::new();
    while !folded.is_empty() {
        // Halve the steps of the vertices of folded faces (each once).
        vertices.clear();
        vertices.extend(folded.iter().flat_map(|&f| faces[f as usize]));
        vertices.sort_unstable();
        vertices.dedup();
        vertices.retain(|&v| buffers.halvings[v as usize] <= FOLD_GUARD_HALVINGS);
        for &v in &vertices {
            let v = v as usize;
            let h = &mut buffers.halvings[v];
            *h += 1;
            buffers.next[v] = if *h > FOLD_GUARD_HALVINGS {
                positions[v]
            } else {
                vec3::add(
                    positions[v],
                    vec3::scale(buffers.steps[v], 0.5f64.powi(*h as i32)),
                )
            };
        }
        // Re-test the faces around them.
        active.clear();
        for &v in &vertices {
            active.extend_from_slice(topology.vertex_faces.row(v as usize));
        }
        active.sort_unstable();
        active.dedup();
        let next: &[Vec3] = &buffers.next;
        folded.clear();
        folded.extend(
            active
                .iter()
                .copied()
                .filter(|&f| is_folded(next, f as usize)),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::geometry::face_normals;

    #[test]
    fn own_normals_leave_mesh_unchanged() {
        let m = Mesh::tetrahedron();
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
