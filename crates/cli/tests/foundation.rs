//! End-to-end tests of `normalnet info`, `normalnet noise` and
//! `normalnet metrics` on generated meshes (no shared data needed).

mod common;

use common::{normalnet, s};
use normalnet_mesh::{Mesh, write_mesh};

#[test]
fn info_noise_metrics_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean.obj");
    write_mesh(&clean, &Mesh::uv_sphere(20, 40)).unwrap();

    let o = normalnet(&["info", s(&clean), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["faces"], 2 * 40 * 19);
    assert_eq!(v["report"]["boundary_edges"], 0);
    assert_eq!(v["folded_faces"], 0, "a clean sphere has no folds");
    let o = normalnet(&["info", s(&clean)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("mean edge length l_e"));
    assert!(text.contains("folded faces           0 (0.00 %)"), "{text}");

    let (a, b, c) = (
        dir.path().join("a.ply"),
        dir.path().join("b.ply"),
        dir.path().join("c.off"),
    );
    for out in [&a, &b] {
        let o = normalnet(&["noise", s(&clean), s(out), "--level", "0.3", "--seed", "7"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "same seed, same bytes"
    );
    let o = normalnet(&[
        "noise",
        s(&clean),
        s(&c),
        "--level",
        "0.5",
        "--impulsive",
        "0.25",
        "--direction",
        "random",
        "--seed",
        "7",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("impulsive"));
    // noise in random directions folds faces, and info counts them
    let o = normalnet(&["info", s(&c), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (count, share) = (&v["folded_faces"], v["folded_share"].as_f64().unwrap());
    assert!(count.as_u64().unwrap() > 0, "{v}");
    assert_eq!(count, (share * (2 * 40 * 19) as f64).round() as u64);

    let o = normalnet(&["metrics", s(&clean), s(&a), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in [
        "e_a_deg",
        "e_v",
        "e_v_over_le",
        "hausdorff",
        "mean_dist",
        "max_dist_result_to_gt",
    ] {
        assert!(m[key].as_f64().unwrap() > 0.0, "{key}: {m}");
    }
    // Level 0.3 noise: E_v / l_e is of the order of 0.3 (a fraction of σ).
    let r = m["e_v_over_le"].as_f64().unwrap();
    assert!(r > 0.05 && r < 0.5, "{r}");
    let o = normalnet(&["metrics", s(&clean), s(&clean)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("E_a (mean normal angle)      0.0000 deg"),
        "{text}"
    );
}

#[test]
fn errors_name_the_file_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let o = normalnet(&["info", s(&bad)]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("bad.obj:4") && e.contains("vertex 9"), "{e}");

    let big = dir.path().join("big.obj");
    let small = dir.path().join("small.obj");
    write_mesh(&big, &Mesh::uv_sphere(6, 8)).unwrap();
    write_mesh(&small, &Mesh::uv_sphere(5, 8)).unwrap();
    let o = normalnet(&["metrics", s(&big), s(&small)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("face counts differ"));

    let o = normalnet(&[
        "noise",
        s(&big),
        s(&dir.path().join("x.obj")),
        "--level=-1",
        "--seed",
        "1",
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("invalid parameter level: must be a finite number >= 0, got -1"),
        "{e}"
    );
    assert!(!dir.path().join("x.obj").exists());
}
