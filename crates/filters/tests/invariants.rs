//! Geometric invariants of every classical method: translating, rotating
//! and uniformly scaling the input transforms the output alike; noise-free
//! planes and cubes stay (nearly) unchanged; degenerate faces and boundaries
//! produce no NaN.

mod common;
use common::{method, methods};
use normalnet_filters::{GtGuidedGnfParams, gt_guided_gnf};
use normalnet_mesh::geometry::{face_normals, mean_edge_length};
use normalnet_mesh::{Mesh, NoProgress, Topology, vec3};

/// UV sphere with a deterministic radial perturbation.
fn noisy_sphere(rings: usize, segs: usize, noise: f64) -> Mesh {
    let mut m = Mesh::uv_sphere(rings, segs);
    for (k, x) in m.positions.iter_mut().enumerate() {
        let r = 1.0 + noise * (((k * 7919) % 13) as f64 / 6.0 - 1.0);
        *x = x.map(|c| c * r);
    }
    m
}

/// Flat `k × k` grid in the plane z = 0 (open boundary).
fn plane(k: usize) -> Mesh {
    Mesh::height_grid(k, |_, _| 0.0)
}

/// Closed cube [0, k]³ with every side a `k × k` grid of split squares.
/// With `alternate` (and even k) the diagonals alternate so that every
/// square at a cube corner is split through the corner ("union jack");
/// otherwise all diagonals are parallel, which leaves, on every side, two
/// corner triangles whose three vertices all lie on cube edges.
fn cube(k: usize, alternate: bool) -> Mesh {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut vid = |p: [i64; 3], positions: &mut Vec<[f64; 3]>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            positions.push(p.map(|c| c as f64));
            (positions.len() - 1) as u32
        })
    };
    let k = k as i64;
    let mut faces = Vec::new();
    // For each axis and side, a grid with outward orientation.
    for axis in 0..3 {
        for side in [0, k] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for a in 0..k {
                for b in 0..k {
                    let corner = |da: i64, db: i64| {
                        let mut p = [0i64; 3];
                        p[axis] = side;
                        p[u] = a + da;
                        p[v] = b + db;
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|p| vid(p, &mut positions));
                    // Rotate the quad so that the diagonal is q[0]–q[2].
                    let q = if alternate && (a + b) % 2 == 1 {
                        [q[1], q[2], q[3], q[0]]
                    } else {
                        q
                    };
                    if side == k {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh::new(positions, faces).unwrap()
}

fn transform(mesh: &Mesh, f: impl Fn([f64; 3]) -> [f64; 3]) -> Mesh {
    mesh.with_positions(mesh.positions.iter().map(|&p| f(p)).collect())
}

/// A rotation by Rodrigues' formula about a fixed unit axis.
fn rotate(p: [f64; 3]) -> [f64; 3] {
    let k = vec3::normalize_or_zero([0.3, -0.5, 0.8]);
    let (s, c) = 0.7f64.sin_cos();
    let kxp = vec3::cross(k, p);
    let kdp = vec3::dot(k, p);
    vec3::add(
        vec3::add(vec3::scale(p, c), vec3::scale(kxp, s)),
        vec3::scale(k, kdp * (1.0 - c)),
    )
}

/// Largest distance between corresponding vertices, relative to the size of `b`.
fn relative_difference(a: &Mesh, b: &Mesh) -> f64 {
    let (lo, hi) = b.bounding_box();
    let size = vec3::dist2(lo, hi).sqrt();
    a.positions
        .iter()
        .zip(&b.positions)
        .map(|(x, y)| vec3::dist2(*x, *y).sqrt())
        .fold(0.0, f64::max)
        / size
}

fn run_all(mesh: &Mesh) -> Vec<(String, Mesh)> {
    let mut out: Vec<(String, Mesh)> = methods()
        .into_iter()
        .map(|m| (m.name().to_string(), m.denoise(mesh, &NoProgress).unwrap()))
        .collect();
    // The oracle, guided by the normals of the clean sphere's shape: use the
    // input's own normals rotated along with it (a covariant guidance).
    let gt = face_normals(mesh);
    let p = GtGuidedGnfParams {
        iterations: 3,
        ..Default::default()
    };
    out.push((
        "gt-gnf".into(),
        gt_guided_gnf(mesh, &gt, &p, &NoProgress).unwrap(),
    ));
    out
}

#[test]
fn results_are_equivariant_under_similarity_transforms() {
    let mesh = noisy_sphere(12, 24, 0.03);
    let base = run_all(&mesh);
    type Map = Box<dyn Fn([f64; 3]) -> [f64; 3]>;
    let cases: [(&str, Map); 3] = [
        ("translation", Box::new(|p| vec3::add(p, [3.0, -2.0, 7.5]))),
        ("rotation", Box::new(rotate)),
        ("scaling", Box::new(|p| vec3::scale(p, 3.7))),
    ];
    for (label, f) in &cases {
        let moved = run_all(&transform(&mesh, f));
        for ((name, a), (_, b)) in base.iter().zip(&moved) {
            let expected = transform(a, f);
            let d = relative_difference(b, &expected);
            assert!(d < 1e-9, "{name} under {label}: relative difference {d:e}");
        }
    }
}

#[test]
fn noise_free_plane_is_unchanged() {
    let mesh = plane(8);
    for (name, out) in run_all(&mesh) {
        let d = relative_difference(&out, &mesh);
        assert!(d < 1e-12, "{name}: plane moved by {d:e} of its size");
    }
}

/// Largest vertex displacement (in units of l_e) and largest normal turn
/// (degrees) of every method on `mesh`.
fn cube_changes(mesh: &Mesh) -> Vec<(String, f64, f64)> {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let l_e = mean_edge_length(mesh, &topology);
    run_all(mesh)
        .into_iter()
        .map(|(name, out)| {
            let worst = out
                .positions
                .iter()
                .zip(&mesh.positions)
                .map(|(x, y)| vec3::dist2(*x, *y).sqrt())
                .fold(0.0, f64::max)
                / l_e;
            let angle = face_normals(&out)
                .iter()
                .zip(face_normals(mesh))
                .map(|(a, b)| vec3::angle(*a, b).to_degrees())
                .fold(0.0, f64::max);
            (name, worst, angle)
        })
        .collect()
}

#[test]
fn noise_free_cube_is_nearly_unchanged() {
    // Known limitation, printed for the record: with parallel diagonals the
    // triangles spanning a cube corner have no flat 1-ring patch, so GNF's
    // guidance (and the oracle's smoothing) rounds those corners.
    for (name, worst, angle) in cube_changes(&cube(6, false)) {
        eprintln!(
            "parallel diagonals, {name}: vertices move ≤ {worst:.2e} l_e, normals turn ≤ {angle:.3}°"
        );
    }
    for (name, worst, angle) in cube_changes(&cube(6, true)) {
        eprintln!(
            "{name}: cube vertices move at most {worst:.2e} l_e, normals turn at most {angle:.3}°"
        );
        // Sun07's weight is exactly zero across a 90° edge; the Gaussian
        // kernels of GNF/BNF leak ~exp(−8) across it; L0 treats the edges
        // as features only once β is large, so it rounds them slightly.
        let (max_move, max_angle) = match name.as_str() {
            // VT: every face's binary neighbourhood (n_i·n_j ≥ ρ) stays on
            // its side, so its tensor is n_i n_iᵀ and the normal is kept.
            "sun07" | "vt" => (1e-12, 1e-9),
            "l0" => (0.05, 0.2),
            _ => (0.01, 0.2),
        };
        assert!(worst <= max_move, "{name}: cube vertex moved {worst:e} l_e");
        assert!(angle <= max_angle, "{name}: cube normal turned {angle}°");
    }
}

#[test]
fn degenerate_faces_and_boundaries_give_no_nan() {
    // An open noisy patch with a zero-area sliver, a face with a repeated
    // vertex, and an isolated vertex.
    let mut mesh = plane(5);
    for (k, p) in mesh.positions.iter_mut().enumerate() {
        p[2] = 0.05 * (((k * 31) % 7) as f64 - 3.0);
    }
    let n = mesh.positions.len() as u32;
    mesh.positions.push([2.5, 2.5, 0.0]); // n: collinear with vertices 0 and 14 (x = y)
    mesh.positions.push([9.0, 9.0, 9.0]); // n + 1: isolated
    mesh.faces.push([0, 14, n]);
    mesh.faces.push([3, 3, 4]);
    mesh.positions[14] = [2.0, 2.0, 0.0];
    mesh.positions[0] = [0.0, 0.0, 0.0];
    let mesh = Mesh::new(mesh.positions, mesh.faces).unwrap();
    for (name, out) in run_all(&mesh) {
        assert!(
            out.positions.iter().flatten().all(|c| c.is_finite()),
            "{name}: non-finite position"
        );
        assert_eq!(
            out.positions[n as usize + 1],
            [9.0, 9.0, 9.0],
            "{name}: isolated vertex moved"
        );
    }
    // A single triangle (no edge-adjacent pair, d_s = 0) and a single
    // degenerate triangle.
    for tri in [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
    ] {
        let m = Mesh::new(tri.to_vec(), vec![[0, 1, 2]]).unwrap();
        for (name, out) in run_all(&m) {
            assert!(
                out.positions.iter().flatten().all(|c| c.is_finite()),
                "{name}: non-finite position"
            );
        }
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mesh = noisy_sphere(12, 24, 0.03);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let a = one.install(|| run_all(&mesh));
    let b = three.install(|| run_all(&mesh));
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        // L0's sparse Cholesky may split work differently, the filters must not.
        if name == "l0" {
            assert!(relative_difference(x, y) < 1e-12, "{name}");
        } else {
            assert_eq!(
                x.positions, y.positions,
                "{name} depends on the thread count"
            );
        }
    }
}

/// Mean angle (degrees) between the face normals of `a` and `b`.
fn mean_angle(a: &Mesh, b: &Mesh) -> f64 {
    let (na, nb) = (face_normals(a), face_normals(b));
    na.iter()
        .zip(&nb)
        .map(|(x, y)| vec3::angle(*x, *y).to_degrees())
        .sum::<f64>()
        / na.len() as f64
}

#[test]
fn bi_and_vt_denoise_a_noisy_cube_and_keep_its_edges() {
    // Union-jack cube, every vertex pushed along a deterministic
    // pseudo-random direction by up to 0.15 l_e.
    let clean = cube(8, true);
    let mut positions = clean.positions.clone();
    for (k, p) in positions.iter_mut().enumerate() {
        let h = |s: usize| ((k * 2654435761 + s * 40503) % 1000) as f64 / 500.0 - 1.0;
        *p = vec3::add(*p, [0.15 * h(1), 0.15 * h(2), 0.15 * h(3)]);
    }
    let noisy = clean.with_positions(positions);
    let before = mean_angle(&noisy, &clean);
    for name in ["bi", "vt"] {
        let out = method(name).denoise(&noisy, &NoProgress).unwrap();
        let after = mean_angle(&out, &clean);
        eprintln!("{name}: noisy cube E_a {before:.2}° -> {after:.2}°");
        assert!(after < 0.15 * before, "{name}: E_a {before} -> {after}");
    }
}
