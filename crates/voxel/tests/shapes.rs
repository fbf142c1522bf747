//! Procedural shapes: closed, manifold, outward, no degenerate faces, near
//! the requested size, deterministic.

use normalnet_mesh::Topology;
use normalnet_mesh::geometry::{FaceGeometry, count_degenerate_faces};
use normalnet_mesh::vec3;
use normalnet_voxel::shapes::build::ConvexPolyhedron;
use normalnet_voxel::shapes::{ALL_KINDS, NAMED_KINDS, ShapeKind, generate, generate_seeded};

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

#[test]
fn planes_cut_the_polyhedron_their_duality_predicts() {
    let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut cube: Vec<([f64; 3], f64)> = axes
        .iter()
        .flat_map(|&a| [(a, 0.5), (vec3::scale(a, -1.0), 0.5)])
        .collect();
    let p = ConvexPolyhedron::from_planes(&cube).unwrap();
    assert_eq!(p.vertices.len(), 8);
    assert_eq!(p.facets.len(), 6);
    assert!(p.facets.iter().all(|f| f.len() == 4));
    assert!(
        p.vertices
            .iter()
            .all(|v| v.iter().all(|c| (c.abs() - 0.5).abs() < 1e-12))
    );
    assert!((p.shortest_edge() - 1.0).abs() < 1e-12);
    // a plane outside the cube cuts nothing
    cube.push((vec3::normalize_or_zero([1.0, 1.0, 1.0]), 5.0));
    let q = ConvexPolyhedron::from_planes(&cube).unwrap();
    assert_eq!((q.vertices.len(), q.facets.len()), (8, 6));
    // one that cuts a corner adds a triangle and two corners
    cube.push((vec3::normalize_or_zero([1.0, 1.0, 1.0]), 0.8));
    let q = ConvexPolyhedron::from_planes(&cube).unwrap();
    assert_eq!((q.vertices.len(), q.facets.len()), (10, 7));
    // planes that face one half-space only bound nothing
    let open: Vec<([f64; 3], f64)> = [
        [0.0, 0.0, 1.0],
        [0.8, 0.0, 0.6],
        [-0.8, 0.0, 0.6],
        [0.0, 0.8, 0.6],
    ]
    .map(|n| (n, 1.0))
    .to_vec();
    assert!(ConvexPolyhedron::from_planes(&open).is_none());
    // the regular dodecahedron: planes along the icosahedron's corners
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let dodeca: Vec<([f64; 3], f64)> = [
        [0.0, 1.0, t],
        [0.0, -1.0, t],
        [0.0, 1.0, -t],
        [0.0, -1.0, -t],
        [1.0, t, 0.0],
        [-1.0, t, 0.0],
        [1.0, -t, 0.0],
        [-1.0, -t, 0.0],
        [t, 0.0, 1.0],
        [-t, 0.0, 1.0],
        [t, 0.0, -1.0],
        [-t, 0.0, -1.0],
    ]
    .map(|n| (vec3::normalize_or_zero(n), 1.0))
    .to_vec();
    let d = ConvexPolyhedron::from_planes(&dodeca).unwrap();
    assert_eq!(d.vertices.len(), 20);
    assert!(d.facets.len() == 12 && d.facets.iter().all(|f| f.len() == 5));
}

#[test]
fn polyhedra_are_named_only_and_have_flat_facets_and_sharp_edges() {
    assert_eq!(
        ShapeKind::from_name("polyhedron").unwrap(),
        ShapeKind::Polyhedron
    );
    assert!(NAMED_KINDS.iter().all(|k| !ALL_KINDS.contains(k)));
    for seed in 0..8 {
        let mesh = generate(ShapeKind::Polyhedron, seed, 2000).unwrap();
        let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
        let n = normalnet_mesh::geometry::face_normals(&mesh);
        // facets: classes of faces joined across edges that do not bend
        let mut class: Vec<usize> = (0..n.len()).collect();
        fn root(c: &mut [usize], mut f: usize) -> usize {
            while c[f] != f {
                c[f] = c[c[f]];
                f = c[f];
            }
            f
        }
        let mut sharp = 0;
        for &[a, b] in &topo.edge_faces {
            let turn = vec3::angle(n[a as usize], n[b as usize]).to_degrees();
            if turn > 10.0 {
                sharp += 1;
            } else {
                assert!(turn < 1e-3, "seed {seed}: a facet bends by {turn}°");
                let (ra, rb) = (root(&mut class, a as usize), root(&mut class, b as usize));
                class[ra] = rb;
            }
        }
        let facets = (0..n.len()).filter(|&f| root(&mut class, f) == f).count();
        println!(
            "seed {seed}: {} faces, {facets} facets, {sharp} sharp edges",
            mesh.num_faces()
        );
        assert!((6..=20).contains(&facets), "seed {seed}: {facets} facets");
        assert!(sharp > 30);
    }
}
