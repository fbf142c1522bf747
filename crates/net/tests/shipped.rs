//! The shipped bundle (`models/lite`) on a generated noisy shape: one
//! filtering pass of network 1 is (approximately) rotation-equivariant.
//! The voxel frame aligns each face's 2-ring mean normal with y, so a rotated
//! mesh gives the same grids up to a rotation about y (the free yaw); a
//! network trained with random yaw augmentation should then answer with the
//! rotated normals. Exactness modulo yaw is tested in `inference.rs`; this
//! measures how yaw-invariant the trained network actually is.

use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{NoProgress, Topology};
use normalnet_net::Bundle;
use normalnet_net::pipeline::filtered_normals;
use normalnet_voxel::frame::{Mat3, mat_vec};
use std::path::Path;

fn rotation(axis: Vec3, angle: f64) -> Mat3 {
    let [x, y, z] = vec3::normalize_or_zero(axis);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

#[test]
fn trained_network_is_nearly_rotation_equivariant() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite");
    if !path.join("manifest.toml").is_file() {
        println!("SKIP: no shipped bundle at {}", path.display());
        return;
    }
    let bundle = Bundle::load(&path).unwrap();
    let (_, noisy) = normalnet_voxel::shapes::noisy_pair(21, 600, 0.3, 5).unwrap();
    let r = rotation([0.2, 0.9, -0.4], 2.0);
    let rotated = noisy.with_positions(noisy.positions.iter().map(|p| mat_vec(&r, *p)).collect());
    let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
    let run = |m| {
        filtered_normals(
            m,
            &topology,
            &bundle.engines[0],
            bundle.manifest.networks[0].residual,
            bundle.voxel_params(),
            bundle.output_for_mu_g(0.35),
            128,
            None,
            &NoProgress,
        )
        .unwrap()
        .0
    };
    let a = run(&noisy);
    let b = run(&rotated);
    let dev: Vec<f64> = a
        .iter()
        .zip(&b)
        .map(|(x, y)| vec3::angle(mat_vec(&r, *x), *y).to_degrees())
        .collect();
    let mean = dev.iter().sum::<f64>() / dev.len() as f64;
    // how much the pass changes the normals, for scale
    let noisy_normals = normalnet_mesh::geometry::face_normals(&noisy);
    let moved: f64 = a
        .iter()
        .zip(&noisy_normals)
        .map(|(x, y)| vec3::angle(*x, *y).to_degrees())
        .sum::<f64>()
        / a.len() as f64;
    println!("mean deviation from equivariance {mean:.2}°, mean change of the pass {moved:.2}°");
    assert!(
        mean < 0.3 * moved,
        "rotating the mesh changes the outputs by {mean:.2}° on average (the pass itself moves normals by {moved:.2}°)"
    );
}

/// The fold guard (on by default) on the shipped example: no more folded
/// faces than without it, and E_a no worse beyond noise.
#[test]
fn the_fold_guard_folds_no_more_faces_on_the_example() {
    let Some((bundle, noisy, clean)) = shipped_and_example() else {
        return;
    };
    let run = |fold_guard: bool| {
        let params = normalnet_net::DenoiseParams {
            iterations: 4,
            auto_stop_deg: 0.0,
            switch: false,
            fold_guard,
            ..normalnet_net::DenoiseParams::default()
        };
        let (out, _) = normalnet_net::denoise(&noisy, &bundle, &params, &NoProgress).unwrap();
        normalnet_mesh::metrics::compare(&clean, &out).unwrap()
    };
    let (plain, guarded) = (run(false), run(true));
    println!(
        "fold guard off: E_a {:.3}°, {} flipped; on: E_a {:.3}°, {} flipped",
        plain.e_a_deg, plain.flipped_faces, guarded.e_a_deg, guarded.flipped_faces
    );
    assert!(guarded.flipped_faces <= plain.flipped_faces);
    assert!(guarded.e_a_deg <= plain.e_a_deg + 0.1);
}

/// The shipped bundle carries a learned switch, and on the shipped example
/// (a fandisk-like part, noise 0.3 l_e) it beats the paper's form
/// (measured 2026-12-01: 7.33° vs 8.79°; the paper form with its auto stop).
#[test]
fn the_shipped_switch_beats_the_paper_form_on_the_example() {
    let Some((bundle, noisy, clean)) = shipped_and_example() else {
        return;
    };
    assert!(
        bundle.manifest.switch.is_some(),
        "models/lite has a [switch]"
    );
    let e_a = |switch: bool| {
        let params = normalnet_net::DenoiseParams {
            switch,
            ..normalnet_net::DenoiseParams::default()
        };
        let (out, _) = normalnet_net::denoise(&noisy, &bundle, &params, &NoProgress).unwrap();
        normalnet_mesh::metrics::compare(&clean, &out)
            .unwrap()
            .e_a_deg
    };
    let (switched, paper) = (e_a(true), e_a(false));
    println!("E_a: switch {switched:.3}°, paper form {paper:.3}°");
    assert!(switched < paper - 0.5, "switch {switched} vs paper {paper}");
}

/// The shipped bundle and the shipped example (noisy, clean); `None` (with a
/// SKIP line) when the bundle folder is absent.
fn shipped_and_example() -> Option<(Bundle, normalnet_mesh::Mesh, normalnet_mesh::Mesh)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let path = root.join("models/lite");
    if !path.join("manifest.toml").is_file() {
        println!("SKIP: no shipped bundle at {}", path.display());
        return None;
    }
    let bundle = Bundle::load(&path).unwrap();
    let noisy = normalnet_mesh::read_mesh(root.join("examples/noisy-part.obj")).unwrap();
    let clean = normalnet_mesh::read_mesh(root.join("examples/clean-part.obj")).unwrap();
    Some((bundle, noisy, clean))
}
