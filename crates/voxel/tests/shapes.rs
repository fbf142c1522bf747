//! Procedural shapes: closed, manifold, outward, no degenerate faces, near
//! the requested size, deterministic.

use normalnet_mesh::Topology;
use normalnet_mesh::geometry::{FaceGeometry, count_degenerate_faces};
use normalnet_mesh::vec3;
use normalnet_voxel::shapes::{ALL_KINDS, ShapeKind, generate, generate_seeded};

#[test]
fn shapes_are_closed_manifold_and_non_degenerate() {
    let mut total = 0;
    for seed in 0..40u64 {
        let target = 600 + 50 * (seed as usize % 7);
        let kind = ShapeKind::from_seed(seed);
        let mesh = generate_seeded(seed, target).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        assert_eq!(topo.num_boundary_edges(), 0, "seed {seed} {kind:?}");
        assert!(topo.non_manifold_edges().is_empty(), "seed {seed} {kind:?}");
        assert_eq!(count_degenerate_faces(&mesh), 0, "seed {seed}");
        // Every vertex is used, faces have three distinct vertices.
        let mut used = vec![false; mesh.num_vertices()];
        for t in &mesh.faces {
            assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
            t.iter().for_each(|&v| used[v as usize] = true);
        }
        assert!(used.iter().all(|&u| u), "seed {seed}: unused vertex");
        // Outward: positive enclosed volume.
        let g = FaceGeometry::new(&mesh);
        let vol: f64 = (0..mesh.num_faces())
            .map(|f| vec3::dot(g.centres[f], g.normals[f]) * g.areas[f] / 3.0)
            .sum();
        assert!(vol > 0.0, "seed {seed}: volume {vol}");
        let ratio = mesh.num_faces() as f64 / target as f64;
        assert!(
            (0.6..1.6).contains(&ratio),
            "seed {seed} {kind:?}: {} faces for {target}",
            mesh.num_faces()
        );
        total += mesh.num_faces();
    }
    println!("40 shapes, {total} faces");
}

#[test]
fn every_kind_has_sharp_or_smooth_features_as_designed() {
    for kind in ALL_KINDS {
        let mesh = generate(kind, 7, 1500).unwrap();
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let n = normalnet_mesh::geometry::face_normals(&mesh);
        let sharp = topo
            .edge_faces
            .iter()
            .filter(|[a, b]| vec3::angle(n[*a as usize], n[*b as usize]).to_degrees() > 30.0)
            .count();
        println!("{kind:?}: {} faces, {sharp} sharp edges", mesh.num_faces());
        if kind == ShapeKind::Blob {
            assert_eq!(sharp, 0, "a blob is smooth");
        } else {
            assert!(sharp > 10, "{kind:?} should have sharp edges");
        }
    }
}

#[test]
fn generation_is_deterministic() {
    assert_eq!(
        generate_seeded(13, 800).unwrap(),
        generate_seeded(13, 800).unwrap()
    );
    assert_ne!(
        generate_seeded(13, 800).unwrap(),
        generate_seeded(23, 800).unwrap()
    );
}
