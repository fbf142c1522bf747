//! The audit's extreme scales: a valid mesh with every coordinate times
//! 1e-80 (or 1e80) read every face as degenerate (face normals ~L⁴
//! underflow), so GNF returned its input, NormalNet moved vertices by 42 %
//! of the extent and L0's Cholesky failed, all silently or with an internal
//! error. `Denoiser::run` now denoises such a mesh in another unit (an
//! exact power of two) and scales the result back; meshes in the safe range
//! are denoised as before, bit for bit. NormalNet is left out (slow in
//! debug builds); it goes through the same `Denoiser::run`.

use normalnet_denoise::{DenoiseError, Denoiser};
use normalnet_filters::{GnfParams, Sun07Params};
use normalnet_mesh::scale::{bounding_box_diagonal, exponent, mul_pow2};
use normalnet_mesh::{Mesh, NoProgress};

/// A small noisy CAD-like shape (and its clean form), scaled by a power of
/// two so that its bounding-box diagonal lies in `[1, 2)`.
fn meshes() -> (Mesh, Mesh) {
    let (clean, noisy) = normalnet_voxel::shapes::noisy_pair(5, 300, 0.3, 5).unwrap();
    let k = -exponent(bounding_box_diagonal(&noisy));
    (scaled_pow2(&clean, k), scaled_pow2(&noisy, k))
}

fn scaled_pow2(mesh: &Mesh, k: i32) -> Mesh {
    mesh.with_positions(
        mesh.positions
            .iter()
            .map(|p| p.map(|c| mul_pow2(c, k)))
            .collect(),
    )
}

fn scaled(mesh: &Mesh, s: f64) -> Mesh {
    mesh.with_positions(mesh.positions.iter().map(|p| p.map(|c| c * s)).collect())
}

/// The largest coordinate difference between `a` and `b`, relative to the
/// bounding-box diagonal of `b`.
fn relative_gap(a: &Mesh, b: &Mesh) -> f64 {
    let gap = a
        .positions
        .iter()
        .flatten()
        .zip(b.positions.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    gap / bounding_box_diagonal(b)
}

/// `mesh` denoised as it is (no change of unit): the method, then the fold
/// repair `Denoiser::run` applies (issue 39).
fn as_it_is<P: normalnet_filters::ClassicalMethod>(params: &P, mesh: &Mesh) -> Vec<[f64; 3]> {
    let mut out = normalnet_filters::denoise(params, mesh, &NoProgress)
        .unwrap()
        .positions;
    normalnet_filters::repair_mesh_folds(mesh, &mut out);
    out
}

fn run(name: &str, mesh: &Mesh, gt: Option<&Mesh>) -> Mesh {
    Denoiser::with_defaults(name)
        .unwrap()
        .denoise(mesh, gt, &NoProgress)
        .unwrap()
}

#[test]
fn extreme_scales_give_the_unscaled_result_scaled() {
    let (clean, noisy) = meshes();
    for name in ["gnf", "sun07", "l0", "oracle"] {
        let gt = (name == "oracle").then_some(&clean);
        let base = run(name, &noisy, gt);
        // the method did something: the test would pass on the identity
        assert!(relative_gap(&base, &noisy) > 1e-4, "{name}");
        // powers of two: the scaled input is exact, and so is the change of
        // unit, which the methods are invariant under: the bits of `base`
        for k in [-266, 266, -900, 900] {
            // (no coordinate goes subnormal: the scaled input is exact)
            assert_eq!(
                scaled_pow2(&scaled_pow2(&noisy, k), -k).positions,
                noisy.positions
            );
            let out = run(
                name,
                &scaled_pow2(&noisy, k),
                gt.map(|g| scaled_pow2(g, k)).as_ref(),
            );
            assert_eq!(out.faces, noisy.faces);
            assert_eq!(
                out.positions,
                scaled_pow2(&base, k).positions,
                "{name} 2^{k}"
            );
        }
        // decimal scales: the input itself is rounded, then exact
        for s in [1e-80, 1e80, 1e-200, 1e200] {
            let out = run(name, &scaled(&noisy, s), gt.map(|g| scaled(g, s)).as_ref());
            let gap = relative_gap(&out, &scaled(&base, s));
            assert!(gap < 1e-12, "{name} at {s:e}: {gap:e}");
        }
    }
}

#[test]
fn meshes_in_the_safe_range_are_denoised_as_before() {
    let (_, noisy) = meshes();
    for s in [1e-12, 1.0, 1e6, 5e11] {
        let m = scaled(&noisy, s);
        assert_eq!(
            run("gnf", &m, None).positions,
            as_it_is(&GnfParams::default(), &m),
            "{s:e}"
        );
        assert_eq!(
            run("sun07", &m, None).positions,
            as_it_is(&Sun07Params::default(), &m),
            "{s:e}"
        );
    }
}

/// A stray vertex at 1e300 widens the box past the safe range, but the rest
/// of the mesh keeps its unit (the unit comes from a robust radius that
/// ignores 1 % of the vertices): the result is the one of the mesh as it is.
#[test]
fn a_stray_vertex_does_not_rescale_the_rest_of_the_mesh() {
    let (_, mut noisy) = meshes();
    noisy.positions[7] = [1e300, 0.0, 0.0];
    let out = run("gnf", &noisy, None);
    assert_eq!(out.positions[7], [1e300, 0.0, 0.0]);
    assert_eq!(out.positions, as_it_is(&GnfParams::default(), &noisy));
    // and a unit-sized mesh with a stray vertex, all at 1e-80
    let small = scaled(&noisy, 1e-80);
    let out_small = run("gnf", &small, None);
    assert!(relative_gap(&out_small, &scaled(&out, 1e-80)) < 1e-12);
}

#[test]
fn an_extent_beyond_f64_is_refused_with_a_clear_error() {
    let (_, mut noisy) = meshes();
    noisy.positions[0] = [-1e308, 0.0, 0.0];
    noisy.positions[1] = [1e308, 0.0, 0.0];
    let e = Denoiser::with_defaults("gnf")
        .unwrap()
        .denoise(&noisy, None, &NoProgress)
        .unwrap_err();
    assert!(matches!(e, DenoiseError::ExtentOverflow { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("overflows f64") && text.contains("1e308"),
        "{text}"
    );
}

/// Issue 39: a body of extent ~1e-80 with one stray vertex near 1 kept the
/// bounding box in range, so it was denoised as it was and every face of
/// the body read as degenerate. Its robust radius (the stray vertex left
/// out) now sets the unit: the result is, bit for bit, the one of the same
/// mesh at unit size (scaled by 2^266, its stray vertex at 2^266) scaled
/// back. A body of extent 1e-6 with a stray vertex near 1 is in the safe
/// range and is denoised as it is.
#[test]
fn issue_39_a_tiny_body_with_a_stray_vertex_near_1_is_rescaled() {
    let (_, mut noisy) = meshes();
    noisy.positions[7] = [mul_pow2(1.0, 266), 0.0, 0.0];
    let base = run("gnf", &noisy, None);
    // the body (diagonal ~1) was denoised: the test would pass on the identity
    let moved = base
        .positions
        .iter()
        .zip(&noisy.positions)
        .map(|(a, b)| (0..3).fold(0.0f64, |m, k| m.max((a[k] - b[k]).abs())))
        .fold(0.0f64, f64::max);
    assert!(moved > 1e-4 && moved < 1.0, "{moved}");
    let tiny = scaled_pow2(&noisy, -266);
    assert_eq!(tiny.positions[7], [1.0, 0.0, 0.0]);
    let out = run("gnf", &tiny, None);
    assert_eq!(out.positions, scaled_pow2(&base, -266).positions);

    let mut micro = scaled(&noisy, 1e-6);
    micro.positions[7] = [1.0, 0.0, 0.0];
    assert_eq!(
        run("gnf", &micro, None).positions,
        as_it_is(&GnfParams::default(), &micro)
    );
}
