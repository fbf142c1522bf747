//! Issue 14, end to end: a stray vertex is reported by `info` (text and
//! JSON) and warned about by every command that reads the mesh; the
//! classical methods and NormalNet keep it in place; `--remove-outliers`
//! drops it and its faces; `metrics --json` reports flipped faces.

mod common;

use common::{bumpy_sphere, normalnet, s};
use normalnet_mesh::{Mesh, read_mesh, write_mesh};

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A bumpy UV sphere (10 × 20) with vertex `stray` moved to 1e30.
fn sphere_with_stray(stray: Option<usize>) -> Mesh {
    let mut m = bumpy_sphere(10, 20, 0.03);
    if let Some(v) = stray {
        m.positions[v] = [1e30, 0.0, 0.0];
    }
    m
}

#[test]
fn issue_14_info_and_every_reader_warn_about_a_stray_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let stray = dir.path().join("stray.obj");
    let clean = dir.path().join("clean.obj");
    write_mesh(&stray, &sphere_with_stray(Some(57))).unwrap();
    write_mesh(&clean, &sphere_with_stray(None)).unwrap();

    let o = normalnet(&["info", "--json", s(&stray)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["outlier_vertices"], 1, "{v}");
    let o = normalnet(&["info", s(&stray)]);
    assert!(text(&o.stdout).contains("outlier vertices       1"));
    assert!(text(&o.stderr).contains("vertex 57"), "{}", text(&o.stderr));
    let o = normalnet(&["info", "--json", s(&clean)]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["outlier_vertices"], 0);
    assert!(!text(&o.stderr).contains("outlier"), "{}", text(&o.stderr));

    let out = dir.path().join("out.obj");
    let noisy = dir.path().join("noisy.obj");
    let png = dir.path().join("r.png");
    for args in [
        vec!["denoise", "-q", "-m", "bnf", s(&stray), s(&out)],
        vec!["metrics", s(&clean), s(&stray)],
        vec!["noise", "--seed", "1", s(&stray), s(&noisy)],
        vec!["render", "--size", "64x64", s(&stray), "--out", s(&png)],
    ] {
        let o = normalnet(&args);
        let err = text(&o.stderr);
        assert!(
            err.contains("warning:") && err.contains("1 outlier vertex"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn issue_14_denoise_keeps_or_removes_the_stray_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let stray = dir.path().join("stray.obj");
    let clean = dir.path().join("clean.obj");
    let mesh = sphere_with_stray(Some(57));
    write_mesh(&stray, &mesh).unwrap();
    write_mesh(&clean, &sphere_with_stray(None)).unwrap();
    let out = dir.path().join("out.obj");
    for method in ["gnf", "sun07", "l0"] {
        let o = normalnet(&["denoise", "-q", "-m", method, s(&stray), s(&out)]);
        assert!(o.status.success(), "{method}: {}", text(&o.stderr));
        let r = read_mesh(&out).unwrap();
        assert_eq!(r.positions[57], [1e30, 0.0, 0.0], "{method}");
        let far = r
            .positions
            .iter()
            .enumerate()
            .filter(|(i, p)| *i != 57 && p.iter().any(|c| c.abs() > 2.0))
            .count();
        assert_eq!(far, 0, "{method}: vertices dragged away");
    }
    let o = normalnet(&[
        "denoise",
        "-q",
        "-m",
        "gnf",
        "--remove-outliers",
        "--json",
        "--gt",
        s(&clean),
        s(&stray),
        s(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["removed_outliers"]["vertices"], 1, "{v}");
    let faces_of_57 = mesh.faces.iter().filter(|t| t.contains(&57)).count();
    assert_eq!(v["removed_outliers"]["faces"], faces_of_57);
    let r = read_mesh(&out).unwrap();
    assert_eq!(r.num_vertices(), mesh.num_vertices() - 1);
    assert_eq!(r.num_faces(), mesh.num_faces() - faces_of_57);
    assert!(v["metrics"]["flipped_faces"].is_u64(), "{v}");
    assert!(v["metrics"]["e_v_over_le"].as_f64().unwrap() < 1.0, "{v}");
}

#[test]
fn issue_14_metrics_json_counts_flipped_faces() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean.obj");
    let flipped = dir.path().join("flipped.obj");
    let mesh = sphere_with_stray(None);
    write_mesh(&clean, &mesh).unwrap();
    let mut f = mesh.faces.clone();
    for t in f.iter_mut().take(3) {
        t.swap(1, 2);
    }
    write_mesh(&flipped, &Mesh::new(mesh.positions.clone(), f).unwrap()).unwrap();
    let o = normalnet(&["metrics", "--json", s(&clean), s(&flipped)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["flipped_faces"], 3, "{v}");
}

#[test]
fn issue_14_no_fold_guard_switches_the_guard_off() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    let out = dir.path().join("out.obj");
    write_mesh(&input, &sphere_with_stray(None)).unwrap();
    for (flag, expected) in [(None, true), (Some("--no-fold-guard"), false)] {
        let mut args = vec!["denoise", "-q", "-m", "gnf", "--json", s(&input), s(&out)];
        args.extend(flag);
        let o = normalnet(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["parameters"]["fold_guard"], expected, "{v}");
    }
    let o = normalnet(&["denoise", "-m", "l0", "--no-fold-guard", s(&input), s(&out)]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("--no-fold-guard does not apply to --method l0"));
}
