//! Issue 14, end to end on generated meshes: bad output paths are refused
//! before any work, `--vertex-iterations 0` is refused for NormalNet, OS
//! errors are printed once, an interruption leaves no temporary file, and
//! `info` reports bow-tie vertices and inconsistently oriented faces.

mod common;

use common::{interrupt_and_wait, normalnet, s, spawn_long_denoise, sphere, stderr};
use normalnet_mesh::{Mesh, write_mesh};
use std::process::Command;
use std::time::Duration;

/// A closed octahedron (consistently oriented, manifold).
fn octahedron() -> Mesh {
    let p = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let f = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    Mesh::new(p, f).unwrap()
}

#[test]
fn issue_14_bad_output_paths_fail_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = d.join("in.obj");
    write_mesh(&input, &octahedron()).unwrap();
    let missing_dir = d.join("no/such/out.obj");
    // NormalNet with a bundle that does not exist: the output is checked
    // first, so the error is about the output, not the bundle.
    for (out, want) in [
        (d.join("no/such/out.obj"), "no/such"),
        (d.join("out.xyz"), "cannot write a .xyz output mesh"),
        (d.join("out"), "no extension"),
    ] {
        let o = normalnet(&[
            "denoise",
            s(&input),
            s(&out),
            "--model",
            "/nonexistent/bundle",
        ]);
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(e.contains(want) && !e.contains("bundle"), "{e}");
    }
    let o = normalnet(&["noise", s(&input), s(&missing_dir), "--seed", "1"]);
    assert!(stderr(&o).contains("no/such"), "{}", stderr(&o));

    // render writes PNG only: a .jpg name is refused, nothing is written.
    let jpg = d.join("r.jpg");
    let o = normalnet(&["render", s(&input), "--out", s(&jpg)]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("cannot write a .jpg picture; the extension must be .png"),
        "{}",
        stderr(&o)
    );
    assert!(!jpg.exists());
    let o = normalnet(&["render", s(&input), "--out", s(&d.join("gone/r.png"))]);
    assert!(stderr(&o).contains("gone"), "{}", stderr(&o));
    let o = normalnet(&[
        "voxelize",
        s(&input),
        "--face",
        "0",
        "--out",
        s(&d.join("g.jpg")),
    ]);
    assert!(stderr(&o).contains(".npy, .png"), "{}", stderr(&o));

    // shapes: the contact sheet is checked before the shapes are made.
    let shapes = d.join("shapes");
    let o = normalnet(&[
        "shapes",
        s(&shapes),
        "--count",
        "1",
        "--preview",
        s(&d.join("sheet.gif")),
    ]);
    assert!(stderr(&o).contains("cannot write a .gif"), "{}", stderr(&o));
    assert!(!shapes.exists());
    // An output folder blocked by a file.
    std::fs::write(d.join("file"), b"x").unwrap();
    let o = normalnet(&["shapes", s(&d.join("file")), "--count", "1"]);
    assert!(stderr(&o).contains("not a folder"), "{}", stderr(&o));

    // A good path still works, and only the output is left.
    let ok = d.join("ok.OFF");
    let o = normalnet(&["denoise", "-q", "-m", "gnf", s(&input), s(&ok)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["file", "in.obj", "ok.OFF"]);
}

#[test]
fn issue_14_zero_vertex_iterations_is_refused_for_normalnet() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    write_mesh(&input, &octahedron()).unwrap();
    let out = dir.path().join("out.obj");
    let o = normalnet(&["denoise", s(&input), s(&out), "--vertex-iterations", "0"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("normalnet: vertex_iterations = 0 would run the whole network"),
        "{}",
        stderr(&o)
    );
    // The other ranges are checked before the bundle is loaded too.
    let o = normalnet(&[
        "denoise",
        s(&input),
        s(&out),
        "--iterations",
        "0",
        "--model",
        "/nonexistent/bundle",
    ]);
    assert!(stderr(&o).contains("iterations"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("bundle"), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn issue_14_os_errors_are_printed_once() {
    let o = normalnet(&["info", "/nonexistent/x.obj"]);
    let e = stderr(&o);
    assert_eq!(e.matches("os error 2").count(), 1, "{e}");
    assert!(e.contains("/nonexistent/x.obj"), "{e}");
}

#[test]
fn issue_14_info_reports_bow_ties_and_orientation() {
    let dir = tempfile::tempdir().unwrap();
    // Two octahedra sharing one vertex (a bow tie), one face of the second
    // flipped (three edges traversed twice in the same direction).
    let a = octahedron();
    let mut p = a.positions.clone();
    let mut f = a.faces.clone();
    // second octahedron: vertex 0 of the first is its vertex 1 (-x tip)
    let map = |v: u32| if v == 1 { 0 } else { 6 + v };
    for q in &a.positions {
        p.push([q[0] + 2.0, q[1], q[2]]);
    }
    for (k, t) in a.faces.iter().enumerate() {
        let t = t.map(map);
        f.push(if k == 0 { [t[0], t[2], t[1]] } else { t });
    }
    let mesh = Mesh::new(p, f).unwrap();
    let path = dir.path().join("bowtie.obj");
    write_mesh(&path, &mesh).unwrap();
    let o = normalnet(&["info", s(&path), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["non_manifold_vertices"], 1);
    assert_eq!(v["report"]["misoriented_edges"], 3);
    assert_eq!(v["report"]["misoriented_faces"], 4);
    let o = normalnet(&["info", s(&path)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("non-manifold vertices  1"), "{text}");
    assert!(text.contains("misoriented edges      3"), "{text}");
    assert!(
        text.contains("warning: 1 non-manifold (bow-tie) vertices"),
        "{text}"
    );
    // A clean closed mesh has none.
    let clean = dir.path().join("clean.obj");
    write_mesh(&clean, &octahedron()).unwrap();
    let o = normalnet(&["info", s(&clean), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["non_manifold_vertices"], 0);
    assert_eq!(v["report"]["misoriented_edges"], 0);
}

#[cfg(unix)]
#[test]
fn issue_14_interrupt_removes_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let (mut child, out) = spawn_long_denoise(dir.path());
    // What an interrupted write leaves: a temporary file of this child.
    let leftover = dir
        .path()
        .join(format!(".normalnet-{}-abcdef.tmp", child.id()));
    std::fs::write(&leftover, b"half a mesh").unwrap();
    std::thread::sleep(Duration::from_millis(2000));
    let status = interrupt_and_wait(&mut child, "");
    assert_eq!(status.code(), Some(130));
    assert!(!leftover.exists(), "the temporary file was left behind");
    assert!(!out.exists());
}

#[test]
fn issue_14_progress_is_printed_as_lines_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sphere.obj");
    write_mesh(&input, &sphere(12, 16)).unwrap();
    let out = dir.path().join("out.obj");
    // a quick run prints no progress lines at the default rate (one per 10 s)
    let o = normalnet(&["denoise", s(&input), s(&out), "-m", "gnf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains("ETA") && !err.contains("done in"), "{err}");
    // stderr is a pipe here: plain lines with position and ETA, then "done"
    let o = Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .env("NORMALNET_PROGRESS_SECONDS", "0")
        .args(["denoise", s(&input), s(&out), "-m", "gnf"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("ETA"), "{err}");
    assert!(err.contains("done in"), "{err}");
    // --quiet silences them
    let o = Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .env("NORMALNET_PROGRESS_SECONDS", "0")
        .args(["denoise", s(&input), s(&out), "-m", "gnf", "--quiet"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(!err.contains("ETA") && !err.contains("done in"), "{err}");
}
