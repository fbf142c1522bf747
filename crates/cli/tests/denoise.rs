//! End-to-end tests of `normalnet denoise` with the classical methods on a
//! generated noisy sphere (no shared data needed).

mod common;

use common::{normalnet, s};
use normalnet_mesh::{Mesh, read_mesh, write_mesh};

/// UV sphere with a deterministic radial perturbation of every vertex
/// (`noise` = 0 gives the clean sphere).
fn sphere(rings: usize, segs: usize, noise: f64) -> Mesh {
    let mut m = Mesh::uv_sphere(rings, segs);
    for (k, x) in m.positions.iter_mut().enumerate() {
        let r = 1.0 + noise * (((k * 7919) % 13) as f64 / 6.0 - 1.0);
        *x = x.map(|c| c * r);
    }
    m
}

#[test]
fn every_classical_method_denoises_and_reports_json() {
    let dir = tempfile::tempdir().unwrap();
    let noisy_path = dir.path().join("noisy.obj");
    let clean_path = dir.path().join("clean.obj");
    let noisy = sphere(16, 32, 0.02);
    write_mesh(&noisy_path, &noisy).unwrap();
    write_mesh(&clean_path, &sphere(16, 32, 0.0)).unwrap();
    for method in ["gnf", "bnf", "sun07", "l0", "bi", "vt", "gt-gnf"] {
        let out = dir.path().join(format!("{method}.off"));
        let o = normalnet(&[
            "denoise",
            s(&noisy_path),
            s(&out),
            "--method",
            method,
            "--json",
            "--gt",
            s(&clean_path),
        ]);
        assert!(
            o.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
        // the JSON names the registered method (gt-gnf is the oracle's alias)
        let registered = if method == "gt-gnf" { "oracle" } else { method };
        assert_eq!(v["method"], registered);
        assert!(v["denoise_seconds"].as_f64().unwrap() >= 0.0);
        assert!(v["total_seconds"].as_f64().unwrap() >= v["denoise_seconds"].as_f64().unwrap());
        assert!(v["parameters"].is_object(), "{method}: {}", v["parameters"]);
        let result = read_mesh(&out).unwrap();
        assert_eq!(result.faces, noisy.faces, "{method} keeps the face order");
        assert_ne!(
            result.positions, noisy.positions,
            "{method} moved something"
        );
        let e_a = v["metrics"]["e_a_deg"].as_f64().unwrap();
        assert!(e_a.is_finite() && e_a < 90.0, "{method}: E_a {e_a}");
    }
}

#[test]
fn flags_are_passed_to_the_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let noisy_path = dir.path().join("noisy.obj");
    write_mesh(&noisy_path, &sphere(8, 16, 0.02)).unwrap();
    let out = dir.path().join("out.obj");
    let o = normalnet(&[
        "denoise",
        s(&noisy_path),
        s(&out),
        "-m",
        "gnf",
        "--iterations",
        "3",
        "--vertex-iterations",
        "4",
        "--mu-g",
        "0.25",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["parameters"]["normal_iterations"], 3);
    assert_eq!(v["parameters"]["vertex_iterations"], 4);
    assert_eq!(v["parameters"]["mu_g"], 0.25);
    assert_eq!(
        v["parameters"]["sigma_s_over_ds"], 1.0,
        "unset flags keep the defaults"
    );
    // --param sets any field by its name, over the flags' fields too
    let o = normalnet(&[
        "denoise",
        s(&noisy_path),
        s(&out),
        "-m",
        "gnf",
        "--iterations",
        "3",
        "-p",
        "radius_over_ds=1.5",
        "--param",
        "fold_guard=false",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["parameters"]["radius_over_ds"], 1.5);
    assert_eq!(v["parameters"]["fold_guard"], false);
    assert_eq!(v["parameters"]["normal_iterations"], 3);
    // an unknown field is named, with the known ones, before any work
    let o = normalnet(&[
        "denoise",
        s(&noisy_path),
        s(&out),
        "-m",
        "bnf",
        "-p",
        "radius=2",
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("unknown parameter `radius`") && e.contains("sigma_r"),
        "{e}"
    );
}

#[test]
fn bi_and_vt_flags_are_passed_to_the_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let noisy_path = dir.path().join("noisy.obj");
    write_mesh(&noisy_path, &sphere(8, 16, 0.02)).unwrap();
    let out = dir.path().join("out.obj");
    let run = |args: &[&str]| {
        let mut all = vec!["denoise", s(&noisy_path), s(&out), "--json"];
        all.extend_from_slice(args);
        let o = normalnet(&all);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["parameters"].clone()
    };
    let p = run(&[
        "-m",
        "bi",
        "--sigma-n",
        "0.2",
        "--sigma-r",
        "0.3",
        "--iterations",
        "2",
    ]);
    assert_eq!(p["sigma_n"], 0.2);
    assert_eq!(p["sigma_r"], 0.3);
    assert_eq!(p["normal_iterations"], 2);
    let p = run(&[
        "-m", "vt", "--rho", "0.8", "--tau", "0.4", "--radius", "1.5",
    ]);
    assert_eq!(p["rho"], 0.8);
    assert_eq!(p["tau"], 0.4);
    assert_eq!(p["radius_over_le"], 1.5);
    assert_eq!(p["normal_iterations"], 5, "unset flags keep the defaults");
}

#[test]
fn bad_flags_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let noisy_path = dir.path().join("noisy.obj");
    write_mesh(&noisy_path, &sphere(8, 16, 0.02)).unwrap();
    let out = dir.path().join("out.obj");
    let err = |args: &[&str]| {
        let mut all = vec!["denoise", s(&noisy_path), s(&out)];
        all.extend_from_slice(args);
        let o = normalnet(&all);
        assert!(!o.status.success(), "{args:?} should fail");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    assert!(err(&["-m", "bnf", "--threshold", "0.3"]).contains("--threshold does not apply"));
    assert!(err(&["-m", "gt-gnf"]).contains("--gt"));
    assert!(err(&["-m", "gnf", "--mu-g", "-1"]).contains("mu_g"));
    assert!(err(&["-m", "l0", "--kappa", "1"]).contains("kappa"));
    assert!(err(&["-m", "vt", "--sigma-n", "0.3"]).contains("--sigma-n does not apply"));
    assert!(err(&["-m", "bi", "--rho", "0.3"]).contains("--rho does not apply"));
    assert!(err(&["-m", "vt", "--tau", "0"]).contains("tau"));
    assert!(err(&["-m", "bi", "--sigma-n", "-1"]).contains("sigma_n"));
    assert!(!out.exists(), "no output on error");
    let missing = dir.path().join("missing.obj");
    let o = normalnet(&["denoise", s(&missing), s(&out), "-m", "gnf"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.obj"));
}

#[test]
fn threads_flag_sets_the_pool_and_does_not_change_the_result() {
    let dir = tempfile::tempdir().unwrap();
    let noisy_path = dir.path().join("noisy.obj");
    write_mesh(&noisy_path, &sphere(16, 32, 0.02)).unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = dir.path().join(format!("t{threads}.obj"));
        let o = normalnet(&[
            "--threads",
            threads,
            "denoise",
            "-q",
            "--json",
            "-m",
            "gnf",
            s(&noisy_path),
            s(&out),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            report["threads"].as_u64(),
            Some(threads.parse().unwrap()),
            "{report}"
        );
        outputs.push(std::fs::read(&out).unwrap());
    }
    assert!(
        outputs.windows(2).all(|w| w[0] == w[1]),
        "output depends on --threads"
    );
    let o = normalnet(&["--threads", "0", "info", s(&noisy_path)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--threads"));
}
