//! Voxelizer invariants: translation, scale and rotation (up to yaw) leave
//! the grid unchanged; occupancy on Fandisk0.3 (paper §3.3: 40–60 cubes per
//! face for the paper preset).

use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Topology};
use normalnet_voxel::frame::{Mat3, mat_mul, mat_vec, transpose};
use normalnet_voxel::{Scratch, VoxelParams, Voxelizer};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A bumpy height field (irregular, non-planar): n×n squares, random heights.
fn bumpy(n: usize, seed: u64) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut positions = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (
                i as f64 + rng.random_range(-0.2..0.2),
                j as f64 + rng.random_range(-0.2..0.2),
            );
            let z = 0.8 * (x * 0.4).sin() * (y * 0.3).cos() + rng.random_range(-0.1..0.1);
            positions.push([x, y, z]);
        }
    }
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..n {
            if (i + j) % 3 == 0 {
                faces.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                faces.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    Mesh::new(positions, faces).unwrap()
}

fn grids(
    mesh: &Mesh,
    params: VoxelParams,
    faces: &[u32],
    yaws: Option<&[f64]>,
) -> (Vec<f32>, Vec<normalnet_voxel::Frame>) {
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let vox = Voxelizer::new(mesh, &topo, params).unwrap();
    let mut out = vec![0.0f32; faces.len() * params.grid_len()];
    let frames = vox.voxelize_batch_yaw(faces, yaws, &mut out);
    (out, frames)
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn random_rotation(rng: &mut ChaCha8Rng) -> Mat3 {
    // Rodrigues from a random axis and angle.
    let axis = vec3::normalize_or_zero([0; 3].map(|_| rng.random_range(-1.0..1.0)));
    let t: f64 = rng.random_range(0.3..3.0);
    let (s, c) = t.sin_cos();
    let k: Mat3 = [
        [0.0, -axis[2], axis[1]],
        [axis[2], 0.0, -axis[0]],
        [-axis[1], axis[0], 0.0],
    ];
    let k2 = mat_mul(&k, &k);
    let mut r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] += s * k[i][j] + (1.0 - c) * k2[i][j];
        }
    }
    r
}

fn transformed(mesh: &Mesh, f: impl Fn(Vec3) -> Vec3) -> Mesh {
    mesh.with_positions(mesh.positions.iter().map(|&p| f(p)).collect())
}

#[test]
fn grid_is_invariant_to_translation_scale_and_rotation() {
    let mesh = bumpy(24, 3);
    let faces: Vec<u32> = (0..mesh.num_faces() as u32).step_by(37).collect();
    for params in [VoxelParams::tiny(), VoxelParams::lite()] {
        let (base, base_frames) = grids(&mesh, params, &faces, None);
        let occupied = base.iter().filter(|x| **x != 0.0).count();
        assert!(occupied > faces.len() * 20, "grids look empty: {occupied}");

        let moved = transformed(&mesh, |p| vec3::add(p, [123.4, -56.7, 8.9]));
        let (g, _) = grids(&moved, params, &faces, None);
        let d = max_diff(&base, &g);
        assert!(d < 1e-6, "translation changed the grid by {d}");

        let scaled = transformed(&mesh, |p| vec3::scale(p, 3.7));
        let (g, _) = grids(&scaled, params, &faces, None);
        let d = max_diff(&base, &g);
        assert!(d < 1e-6, "scaling changed the grid by {d}");

        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..3 {
            let q = random_rotation(&mut rng);
            let rotated = transformed(&mesh, |p| mat_vec(&q, p));
            let (_, frames) = grids(&rotated, params, &faces, None);
            // R1·Q = Y(θ)·R0: recover θ per face, voxelize the original with it.
            let yaws: Vec<f64> = frames
                .iter()
                .zip(&base_frames)
                .map(|(r1, r0)| {
                    let m = mat_mul(&mat_mul(&r1.rotation, &q), &transpose(&r0.rotation));
                    assert!((m[1][1] - 1.0).abs() < 1e-9, "not a yaw: {m:?}");
                    m[0][2].atan2(m[0][0])
                })
                .collect();
            let (expected, _) = grids(&mesh, params, &faces, Some(&yaws));
            let (g, _) = grids(&rotated, params, &faces, None);
            let d = max_diff(&expected, &g);
            assert!(d < 1e-6, "rotation changed the grid by {d} beyond the yaw");
        }
    }
}

#[test]
fn yaw_rotates_grid_and_frame_together() {
    // A yaw of a quarter turn permutes the grid axes exactly: local
    // (x, y, z) → (z, y, −x) for Y(π/2) = [[0,0,1],[0,1,0],[−1,0,0]].
    let mesh = bumpy(20, 9);
    let params = VoxelParams::tiny();
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
    let f = 400;
    let mut a = vec![0.0f32; params.grid_len()];
    let mut b = vec![0.0f32; params.grid_len()];
    vox.voxelize_face(f, &mut a);
    let frame = vox.voxelize_face_yaw(f, std::f64::consts::FRAC_PI_2, &mut b);
    assert!((frame.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    let side = params.side();
    let cells = side.pow(3);
    let mut compared = 0;
    for i in 0..side {
        for j in 0..side {
            for k in 0..side {
                let src = (i * side + j) * side + k;
                // new x = old z, new z = −old x
                let (ni, nk) = (k, side - 1 - i);
                let dst = (ni * side + j) * side + nk;
                let va = [a[src], a[cells + src], a[2 * cells + src]];
                let vb = [b[dst], b[cells + dst], b[2 * cells + dst]];
                let rotated = [va[2], va[1], -va[0]];
                for c in 0..3 {
                    assert!(
                        (rotated[c] - vb[c]).abs() < 1e-5,
                        "cell {i} {j} {k}: {rotated:?} vs {vb:?}"
                    );
                }
                compared += (va != [0.0; 3]) as usize;
            }
        }
    }
    assert!(compared > 50);
}

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

/// Paper §3.3: "each face is split into about 40∼60 cubes" (T_s = 20, α_c = 8).
#[test]
fn fandisk_occupancy_per_face() {
    let path = format!("{DATA}/gd/Fandisk0.3/Noisy.obj");
    if !std::path::Path::new(&path).exists() {
        println!("SKIP: {path} not found");
        return;
    }
    let mesh = normalnet_mesh::io::read_mesh(&path).unwrap();
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    for params in [
        VoxelParams::paper(),
        VoxelParams::lite(),
        VoxelParams::tiny(),
    ] {
        let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
        let mut grid = vec![0.0f32; params.grid_len()];
        let mut scratch = Scratch::new();
        let (mut occupied, mut candidates, mut n, mut visited) = (0usize, 0usize, 0usize, 0usize);
        for f in (0..mesh.num_faces()).step_by(97) {
            vox.voxelize_face_with(&mut scratch, f, 0.0, &mut grid);
            occupied += scratch.last_occupied();
            candidates += scratch.last_candidates();
            visited += scratch.last_visited();
            n += 1;
        }
        // Cubes met by the central face f itself (the paper's "each face is
        // split into about 40~60 cubes").
        let mut own = 0usize;
        for f in (0..mesh.num_faces()).step_by(97) {
            let c = cubes_of_face(&vox, &mesh, f);
            // The cubes' projections cover the face's projection on its
            // dominant axis plane (area ≥ a_f/√3).
            let area = vox.geometry().areas[f] / vox.cube_side().powi(2);
            assert!(
                c as f64 >= area / 3f64.sqrt(),
                "face {f}: {c} cubes for area {area}"
            );
            own += c;
        }
        let own_mean = own as f64 / n as f64;
        assert!(own_mean > 5.0, "{own_mean}");
        println!(
            "{:?}: {} faces sampled, cubes met by the central face {:.1}, occupied cubes per grid {:.1}, faces voxelized per grid {:.1} (visited {:.1}), cubes per voxelized face {:.1}",
            params,
            n,
            own_mean,
            occupied as f64 / n as f64,
            candidates as f64 / n as f64,
            visited as f64 / n as f64,
            occupied as f64 / candidates as f64
        );
    }
}

fn cubes_of_face(vox: &Voxelizer, mesh: &Mesh, f: usize) -> usize {
    let params = vox.params();
    let frame = vox.frame(f, 0.0);
    let shift = params.t_s as f64 + 0.5;
    let tri = mesh
        .corners(f)
        .map(|p| frame.point_to_local(p).map(|x| x / vox.cube_side() + shift));
    let t = normalnet_voxel::tri_box_overlap::CubeTester::new(tri);
    let side = params.side();
    let Some(r) = t.cube_range(side) else {
        return 0;
    };
    let mut count = 0;
    for i in r[0].0..=r[0].1 {
        for j in r[1].0..=r[1].1 {
            for k in r[2].0..=r[2].1 {
                count += t.overlaps(i, j, k) as usize;
            }
        }
    }
    count
}

#[test]
fn batch_equals_single_faces_and_ignores_thread_count() {
    let mesh = bumpy(16, 4);
    let params = VoxelParams::tiny();
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let vox = Voxelizer::new(&mesh, &topo, params).unwrap();
    let faces: Vec<u32> = (0..mesh.num_faces() as u32).rev().step_by(5).collect();
    let mut batch = vec![1.0f32; faces.len() * params.grid_len()];
    let frames = vox.voxelize_batch(&faces, &mut batch);
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut batch1 = vec![0.0f32; batch.len()];
    one_thread.install(|| vox.voxelize_batch(&faces, &mut batch1));
    assert_eq!(batch, batch1);
    let mut grid = vec![7.0f32; params.grid_len()];
    for (i, &f) in faces.iter().enumerate() {
        let frame = vox.voxelize_face(f as usize, &mut grid);
        assert_eq!(frame, frames[i]);
        assert_eq!(
            &batch[i * params.grid_len()..(i + 1) * params.grid_len()],
            &grid[..]
        );
    }
}
