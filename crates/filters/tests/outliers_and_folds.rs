//! Issue 14: one stray vertex (at 1e30, or 1e6 × the extent away) moves no
//! other vertex beyond what the method does without it, for every classical
//! method; the fold guard keeps every face that faced its filtered normal
//! facing it, and does not depend on the thread count.

mod common;
use common::methods;
use normalnet_filters::{
    VertexUpdate, VertexUpdateBuffers, vertex_update_in_place, vertex_update_with,
};
use normalnet_mesh::geometry::mean_edge_length;
use normalnet_mesh::outliers::without_vertices;
use normalnet_mesh::{Mesh, NoProgress, Topology, vec3};

/// UV sphere with a deterministic pseudo-random radial perturbation of
/// `noise` (relative to the radius).
fn noisy_sphere(rings: usize, segs: usize, noise: f64) -> Mesh {
    let mut m = Mesh::uv_sphere(rings, segs);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for x in m.positions.iter_mut() {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let u = (state >> 11) as f64 / (1u64 << 53) as f64;
        let r = 1.0 + noise * (2.0 * u - 1.0);
        *x = x.map(|c| c * r);
    }
    m
}

/// Largest distance between corresponding vertices, `skip` excluded.
fn max_distance(a: &Mesh, b: &Mesh, skip: usize) -> f64 {
    a.positions
        .iter()
        .zip(&b.positions)
        .enumerate()
        .filter(|(i, _)| *i != skip)
        .map(|(_, (p, q))| vec3::dist2(*p, *q).sqrt())
        .fold(0.0, f64::max)
}

/// Tolerances: against the method run on the mesh without the stray vertex
/// and its faces, every other vertex must match to 1e-12·l_e (the same
/// computation); against the method on the intact mesh (the vertex at its
/// own place), to 0.5·l_e (the stray vertex's faces are left out, so its
/// neighbours move differently) — without the outlier handling, Sun07 and
/// L0 moved vertices by up to 1e28.
#[test]
fn issue_14_a_stray_vertex_moves_no_other_vertex() {
    let mesh = noisy_sphere(16, 32, 0.04);
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let l_e = mean_edge_length(&mesh, &topology);
    let (lo, hi) = mesh.bounding_box();
    let extent = vec3::norm(vec3::sub(hi, lo));
    let v = 200;
    for method in methods() {
        let intact = method.denoise(&mesh, &NoProgress).unwrap();
        for far in [[1e30, 0.0, 0.0], [0.0, 0.0, 1e6 * extent]] {
            let mut stray = mesh.clone();
            stray.positions[v] = vec3::add(stray.positions[v], far);
            let out = method.denoise(&stray, &NoProgress).unwrap();
            let name = method.name();
            assert_eq!(
                out.positions[v], stray.positions[v],
                "{name}: the outlier stays"
            );
            assert_eq!(out.faces, mesh.faces);

            let mut remove = vec![false; mesh.num_vertices()];
            remove[v] = true;
            let (inner, kept) = without_vertices(&stray, &remove).unwrap();
            let alone = method.denoise_all(&inner, &NoProgress).unwrap();
            for (p, &old) in alone.positions.iter().zip(&kept) {
                let d = vec3::dist2(*p, out.positions[old as usize]).sqrt();
                assert!(d <= 1e-12 * l_e, "{name}: vertex {old} off by {d}");
            }

            let d = max_distance(&out, &intact, v);
            eprintln!("{name} {far:?}: max distance to the intact result {d:.3e} (l_e {l_e:.3e})");
            assert!(
                d <= 0.5 * l_e,
                "{name}: a vertex moved {d} from the intact result"
            );
        }
    }
}

/// `(b − a) × (c − a) · n` of every face.
fn facing(positions: &[[f64; 3]], faces: &[[u32; 3]], normals: &[[f64; 3]]) -> Vec<f64> {
    faces
        .iter()
        .zip(normals)
        .map(|(t, n)| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            vec3::dot(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)), *n)
        })
        .collect()
}

/// A rough sphere and filtered normals that disagree with it (its own
/// normals tilted pseudo-randomly by up to ~50°): the plain update folds
/// faces against their filtered normals.
fn folding_case() -> (Mesh, Topology, Vec<[f64; 3]>) {
    let mesh = noisy_sphere(14, 28, 0.15);
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut state = 7u64;
    let normals = normalnet_mesh::geometry::face_normals(&mesh)
        .into_iter()
        .map(|n| {
            let mut r = [0.0; 3];
            for c in r.iter_mut() {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                *c = ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1.6;
            }
            vec3::normalize_or_zero(vec3::add(n, r))
        })
        .collect();
    (mesh, topology, normals)
}

#[test]
fn issue_14_fold_guard_keeps_faces_facing_their_filtered_normals() {
    let (mesh, topology, normals) = folding_case();
    let before = facing(&mesh.positions, &mesh.faces, &normals);
    let run = |guard: bool| {
        let mut p = mesh.positions.clone();
        let update = VertexUpdate {
            iterations: 20,
            fixed: None,
            fold_guard: guard.then_some(normalnet_filters::FOLD_GUARD_COS),
        };
        let mut b = VertexUpdateBuffers::default();
        vertex_update_with(&mut p, &mesh.faces, &topology, &normals, &update, &mut b);
        p
    };
    let newly_folded = |p: &[[f64; 3]]| {
        let after = facing(p, &mesh.faces, &normals);
        before
            .iter()
            .zip(&after)
            .filter(|(b, a)| **b >= 0.0 && **a < 0.0)
            .count()
    };
    let plain = run(false);
    let guarded = run(true);
    let (n_plain, n_guarded) = (newly_folded(&plain), newly_folded(&guarded));
    eprintln!("folded faces: plain {n_plain}, guarded {n_guarded}");
    assert!(n_plain > 0, "the case must fold without the guard");
    assert_eq!(n_guarded, 0);
    // The guard only holds moves back: vertices still move.
    assert!(max_distance(&mesh.with_positions(guarded.clone()), &mesh, usize::MAX) > 0.0);
    // Off, it is the plain update (bit for bit).
    let mut p = mesh.positions.clone();
    let mut b = VertexUpdateBuffers::default();
    vertex_update_in_place(&mut p, &mesh.faces, &topology, &normals, 20, &mut b);
    assert_eq!(p, plain);
}

#[test]
fn issue_14_fold_guard_does_not_depend_on_the_thread_count() {
    let (mesh, topology, normals) = folding_case();
    let run = || {
        let mut p = mesh.positions.clone();
        let update = VertexUpdate {
            iterations: 20,
            fixed: None,
            fold_guard: Some(normalnet_filters::FOLD_GUARD_COS),
        };
        let mut b = VertexUpdateBuffers::default();
        vertex_update_with(&mut p, &mesh.faces, &topology, &normals, &update, &mut b);
        p
    };
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let one = pool(1).install(run);
    let three = pool(3).install(run);
    assert_eq!(one, three);
}
