//! Training samples: GT-guided targets, their local frame, A_p categories.

use normalnet_mesh::Topology;
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3;
use normalnet_samples::source::{NO_CATEGORY, NUM_CATEGORIES};
use normalnet_samples::{MU_GS, SampleError, SampleSource};
use normalnet_voxel::VoxelParams;

mod common;
use common::{grid_cube, noisy_copy};

#[test]
fn cube_is_closed_and_outward() {
    let m = grid_cube(4);
    let t = Topology::new(m.num_vertices(), &m.faces);
    assert_eq!(t.num_boundary_edges(), 0);
    assert!(t.non_manifold_edges().is_empty());
    let n = face_normals(&m);
    let c = 2.0;
    for (f, normal) in n.iter().enumerate() {
        let centre = m.corners(f).iter().fold([0.0; 3], |s, p| vec3::add(s, *p));
        let out = vec3::sub(vec3::scale(centre, 1.0 / 3.0), [c; 3]);
        assert!(vec3::dot(out, *normal) > 0.0);
    }
}

/// μ_g → 0: each target is the mean of the normals of the faces with the
/// same ground-truth normal, so on a clean mesh the GT normal itself.
#[test]
fn tiny_mu_g_targets_equal_gt_normals() {
    let clean = grid_cube(6);
    let src = SampleSource::new(clean.clone(), &clean, VoxelParams::tiny(), &[1e-3; 6]).unwrap();
    let gt = face_normals(&clean);
    for (f, g) in gt.iter().enumerate() {
        for t in src.world_targets(f) {
            assert!(vec3::dist2(*t, *g) < 1e-20, "face {f}: {t:?} vs {g:?}");
        }
    }
    // Larger μ_g blends across the edges: some edge face differs from GT.
    let blended = SampleSource::new(clean.clone(), &clean, VoxelParams::tiny(), &MU_GS).unwrap();
    let max_dev = (0..clean.num_faces())
        .map(|f| vec3::angle(blended.world_targets(f)[5], gt[f]).to_degrees())
        .fold(0.0, f64::max);
    assert!(
        max_dev > 1.0,
        "μ_g = 0.5 left every face at its GT normal ({max_dev}°)"
    );
}

#[test]
fn noisy_targets_are_closer_to_gt_than_noisy_normals() {
    let clean = grid_cube(8);
    let noisy = noisy_copy(&clean, 0.15, 1);
    let src = SampleSource::new(noisy.clone(), &clean, VoxelParams::tiny(), &MU_GS).unwrap();
    let gt = face_normals(&clean);
    let nn = face_normals(&noisy);
    let (mut e_noisy, mut e_target) = (0.0, 0.0);
    for f in 0..clean.num_faces() {
        e_noisy += vec3::angle(nn[f], gt[f]).to_degrees();
        e_target += vec3::angle(src.world_targets(f)[2], gt[f]).to_degrees();
    }
    let n = clean.num_faces() as f64;
    println!(
        "mean angle to GT: noisy {:.2}°, target(μ_g=0.35) {:.2}°",
        e_noisy / n,
        e_target / n
    );
    assert!(e_target < 0.5 * e_noisy);
}

#[test]
fn sample_targets_live_in_the_grid_frame() {
    let clean = grid_cube(8);
    let noisy = noisy_copy(&clean, 0.1, 2);
    let params = VoxelParams::tiny();
    let src = SampleSource::new(noisy, &clean, params, &MU_GS).unwrap();
    let mut grid = vec![0.0f32; params.grid_len()];
    for (f, yaw) in [(0usize, 0.0), (57, 1.3), (300, -2.0)] {
        let t = src.sample(f, yaw, &mut grid);
        let frame = src.voxelizer().frame(f, yaw);
        for k in 0..6 {
            let local = [t[3 * k] as f64, t[3 * k + 1] as f64, t[3 * k + 2] as f64];
            let world = frame.to_world(local);
            assert!(vec3::dist2(world, src.world_targets(f)[k]) < 1e-12);
        }
        // The face's own cube (the grid centre) is occupied.
        let side = params.side();
        let c = (params.t_s * side + params.t_s) * side + params.t_s;
        let cells = params.num_cells();
        assert!(grid[cells + c] > 0.5, "centre cube y = {}", grid[cells + c]);
    }
}

#[test]
fn cube_categories_are_sharp_or_flat() {
    let clean = grid_cube(10);
    let src = SampleSource::new(clean.clone(), &clean, VoxelParams::tiny(), &MU_GS).unwrap();
    let sizes: Vec<usize> = (0..NUM_CATEGORIES)
        .map(|c| src.category_faces(c).len())
        .collect();
    assert_eq!(sizes.iter().sum::<usize>(), clean.num_faces());
    assert!(
        sizes[0] > 0 && sizes[3] > 0 && sizes[1] == 0 && sizes[2] == 0,
        "{sizes:?}"
    );
    // Faces whose 2-ring reaches an edge: within two rings of the border
    // of a side; the central (10−4)² squares of each side are flat.
    assert_eq!(sizes[3], 6 * 2 * 6 * 6, "{sizes:?}");
    assert!(src.categories().iter().all(|&c| c != NO_CATEGORY));
    assert!(
        src.a_p()
            .iter()
            .all(|&a| a.abs() < 1e-9 || (a - 90.0).abs() < 1e-9)
    );
}

#[test]
fn mismatched_pairs_and_bad_mu_are_rejected() {
    let a = grid_cube(3);
    let b = grid_cube(4);
    let err = SampleSource::new(a.clone(), &b, VoxelParams::tiny(), &MU_GS).unwrap_err();
    assert!(matches!(err, SampleError::PairMismatch(_)), "{err}");
    let mut c = a.clone();
    c.faces.swap(0, 1);
    let err = SampleSource::new(c, &a, VoxelParams::tiny(), &MU_GS).unwrap_err();
    assert!(err.to_string().contains("face 0"), "{err}");
    let err = SampleSource::new(a.clone(), &a, VoxelParams::tiny(), &[0.3; 5]).unwrap_err();
    assert!(err.to_string().contains("mu_gs"), "{err}");
    let err = SampleSource::new(a.clone(), &a, VoxelParams::tiny(), &[0.0; 6]).unwrap_err();
    assert!(err.to_string().contains("mu_gs"), "{err}");
}

/// Residual targets are the plain targets minus the face's input normal,
/// in the same local frame; the input normal is a unit vector there.
#[test]
fn residual_targets_are_targets_minus_the_input_normal() {
    let clean = grid_cube(6);
    let noisy = noisy_copy(&clean, 0.2, 3);
    let plain = SampleSource::new(noisy.clone(), &clean, VoxelParams::tiny(), &MU_GS).unwrap();
    let residual = SampleSource::new(noisy.clone(), &clean, VoxelParams::tiny(), &MU_GS)
        .unwrap()
        .with_residual(true);
    let grid_len = VoxelParams::tiny().grid_len();
    let (mut g1, mut g2) = (vec![0.0f32; grid_len], vec![0.0f32; grid_len]);
    let nn = face_normals(&noisy);
    for f in [0, 7, 40] {
        let mut s = normalnet_voxel::Scratch::new();
        let (t, frame) = plain.sample_with(&mut s, f, 0.7, &mut g1);
        let (r, _) = residual.sample_with(&mut s, f, 0.7, &mut g2);
        assert_eq!(g1, g2);
        let input = residual.local_input(&frame, f);
        let back = frame.to_world([input[0] as f64, input[1] as f64, input[2] as f64]);
        assert!(vec3::dist2(back, nn[f]) < 1e-10);
        for k in 0..18 {
            assert!(
                (t[k] - (r[k] + input[k % 3])).abs() < 1e-6,
                "face {f} value {k}"
            );
        }
        assert!(r.iter().any(|v| v.abs() > 1e-4));
    }
}
