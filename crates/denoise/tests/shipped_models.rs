//! The shipped learned models on a generated noisy CAD-like shape (not a
//! test model): each must clearly improve the noisy input and keep the face
//! order. Sanity bounds, not reference figures.

use normalnet_denoise::{Denoiser, Params};
use normalnet_mesh::NoProgress;
use normalnet_mesh::metrics::compare;

fn shape() -> (normalnet_mesh::Mesh, normalnet_mesh::Mesh) {
    let (clean, noisy) = normalnet_voxel::shapes::noisy_pair(77, 1500, 0.3, 77).unwrap();
    (clean, noisy)
}

#[test]
fn cnr_and_normalnet_improve_a_noisy_shape() {
    let (clean, noisy) = shape();
    let before = compare(&clean, &noisy).unwrap().e_a_deg;
    for (name, bound) in [("cnr", 0.5), ("normalnet", 0.5)] {
        let mut p = Params::new();
        if name == "normalnet" {
            p.insert("iterations".into(), 3.into());
        }
        let out = Denoiser::new(name, &p)
            .unwrap()
            .denoise(&noisy, None, &NoProgress)
            .unwrap();
        assert_eq!(out.faces, noisy.faces);
        let after = compare(&clean, &out).unwrap().e_a_deg;
        eprintln!("{name}: E_a {before:.2} -> {after:.2}");
        assert!(
            after < bound * before,
            "{name}: E_a {before:.2} -> {after:.2}"
        );
    }
}

#[test]
fn cnr_stages_and_a_broken_model_file() {
    let (_, noisy) = shape();
    let one = {
        let mut p = Params::new();
        p.insert("stages".into(), 1.into());
        Denoiser::new("cnr", &p)
            .unwrap()
            .denoise(&noisy, None, &NoProgress)
            .unwrap()
    };
    let all = Denoiser::with_defaults("cnr")
        .unwrap()
        .denoise(&noisy, None, &NoProgress)
        .unwrap();
    assert_ne!(one.positions, all.positions);
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("cnr.json");
    std::fs::write(&bad, "{\"format\": \"normalnet-cnr-1\", \"stages\": [{}]}").unwrap();
    let mut p = Params::new();
    p.insert("model".into(), bad.display().to_string().into());
    let e = Denoiser::new("cnr", &p).unwrap_err().to_string();
    assert!(
        e.contains("cnr.json") && e.contains("not a CNR model"),
        "{e}"
    );
}

#[test]
fn gnf_after_is_gnf_run_on_normalnets_result() {
    let (_, noisy) = shape();
    let mut p = Params::new();
    p.insert("iterations".into(), 2.into());
    // the methods' own results: without the fold repair that
    // `Denoiser::run` applies after each (issue 39)
    let plain = Denoiser::new("normalnet", &p)
        .unwrap()
        .with_fold_repair(false)
        .denoise(&noisy, None, &NoProgress)
        .unwrap();
    p.insert("gnf_after".into(), 3.into());
    let hybrid = Denoiser::new("normalnet", &p)
        .unwrap()
        .with_fold_repair(false)
        .denoise(&noisy, None, &NoProgress)
        .unwrap();
    let mut g = Params::new();
    g.insert("normal_iterations".into(), 3.into());
    g.insert("mu_g".into(), 0.35.into());
    let expected = Denoiser::new("gnf", &g)
        .unwrap()
        .with_fold_repair(false)
        .denoise(&plain, None, &NoProgress)
        .unwrap();
    assert_ne!(hybrid.positions, plain.positions);
    assert_eq!(hybrid.positions, expected.positions);
}

#[test]
fn cnr_before_is_normalnet_run_on_cnrs_result() {
    let (_, noisy) = shape();
    let mut p = Params::new();
    p.insert("iterations".into(), 2.into());
    let run = |method: &str, p: &Params, mesh| {
        Denoiser::new(method, p)
            .unwrap()
            .with_fold_repair(false)
            .denoise(mesh, None, &NoProgress)
            .unwrap()
    };
    let plain = run("normalnet", &p, &noisy);
    let mut c = Params::new();
    c.insert("stages".into(), 2.into());
    let cnr = run("cnr", &c, &noisy);
    let expected = run("normalnet", &p, &cnr);
    p.insert("cnr_before".into(), 2.into());
    let hybrid = run("normalnet", &p, &noisy);
    assert_ne!(hybrid.positions, plain.positions);
    assert_eq!(hybrid.positions, expected.positions);
}

/// int8 residual blocks (the default where the CPU has AVX2 or AVX-512 VNNI) give
/// nearly the f32 result, and `parameters` says which arithmetic ran.
#[test]
fn int8_is_the_default_and_close_to_f32() {
    let (clean, noisy) = shape();
    let run = |int8: Option<bool>| {
        let mut p = Params::new();
        p.insert("iterations".into(), 4.into());
        if let Some(v) = int8 {
            p.insert("int8".into(), v.into());
        }
        // the networks' arithmetic alone: the fold repair after the method
        // (issue 39) can tip a face at the margin one way or the other
        let d = Denoiser::new("normalnet", &p)
            .unwrap()
            .with_fold_repair(false);
        let ran_int8 = d.parameters()["int8"].as_bool().unwrap();
        let out = d.denoise(&noisy, None, &NoProgress).unwrap();
        let repaired = Denoiser::new("normalnet", &p)
            .unwrap()
            .denoise(&noisy, None, &NoProgress)
            .unwrap();
        eprintln!(
            "int8 {int8:?}: E_a {:.4}°, with the fold repair {:.4}°",
            compare(&clean, &out).unwrap().e_a_deg,
            compare(&clean, &repaired).unwrap().e_a_deg
        );
        (ran_int8, compare(&clean, &out).unwrap().e_a_deg, out)
    };
    let (f32_ran, f32_e_a, f32_out) = run(Some(false));
    assert!(!f32_ran);
    let (default_ran, default_e_a, default_out) = run(None);
    let int8_path = normalnet_denoise::isa::active().has_avx2();
    assert_eq!(
        default_ran, int8_path,
        "int8 runs exactly where the path has AVX2"
    );
    eprintln!("E_a f32 {f32_e_a:.4}°, default {default_e_a:.4}° (int8: {default_ran})");
    if default_ran {
        assert_ne!(default_out.positions, f32_out.positions);
        assert!((default_e_a - f32_e_a).abs() < 0.1);
    } else {
        assert_eq!(default_out.positions, f32_out.positions);
    }
}
