//! The robustness audit, end to end on generated meshes: a closed stdout or
//! stderr, outputs that are inputs, read-only or symbolic links, batch
//! failures, bad ground truth, an output format too small for the input,
//! out-of-range parameters and a mesh collapsed to a point are refused (or
//! handled) before any work, with a message naming the problem.

mod common;

use common::{interrupt_and_wait, normalnet, s, spawn_long_denoise, sphere, stderr};
use normalnet_mesh::{Mesh, read_mesh, write_mesh};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// Fails unless `o` failed with a message containing every one of `want`.
fn assert_refused(o: &Output, want: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    for w in want {
        assert!(e.contains(w), "want {w:?} in {e}");
    }
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

/// `mesh` with every vertex at one point (the faces kept).
fn collapsed(mesh: &Mesh) -> Mesh {
    mesh.with_positions(vec![[1.0, 1.0, 1.0]; mesh.num_vertices()])
}

/// Audit 1: `info x | true` and `denoise --json | true` panicked ("failed
/// printing to stdout: Broken pipe", status 101).
#[test]
fn a_closed_stdout_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    write_mesh(&input, &sphere(8, 12)).unwrap();
    let out = dir.path().join("out.obj");
    for args in [
        vec!["info", s(&input)],
        vec!["denoise", "-q", "-m", "gnf", "--json", s(&input), s(&out)],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_normalnet"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // the reader goes away before the command prints
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(141), "{args:?}: {e}");
        assert!(e.is_empty(), "{args:?}: {e}");
    }
    assert_eq!(names(dir.path()), ["in.obj", "out.obj"]);
}

/// Audit 2: the SIGINT handler panicked writing its message to a closed
/// stderr, and the process ran on.
#[cfg(unix)]
#[test]
fn an_interrupt_with_a_closed_stderr_still_exits() {
    let dir = tempfile::tempdir().unwrap();
    let (mut child, out) = spawn_long_denoise(dir.path());
    drop(child.stderr.take());
    std::thread::sleep(Duration::from_millis(1500));
    let status = interrupt_and_wait(&mut child, " with a closed stderr");
    assert_eq!(status.code(), Some(130));
    assert!(!out.exists());
}

/// Audit 3: `denoise io.obj io.obj` and `noise x.obj x.obj` overwrote
/// their input.
#[test]
fn an_output_that_is_an_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = d.join("io.obj");
    let gt = d.join("gt.obj");
    write_mesh(&input, &sphere(8, 12)).unwrap();
    write_mesh(&gt, &sphere(8, 12)).unwrap();
    let before = std::fs::read(&input).unwrap();
    let same = d.join("sub/../io.obj");
    std::fs::create_dir(d.join("sub")).unwrap();
    for args in [
        vec!["denoise", "-m", "gnf", s(&input), s(&input)],
        vec!["denoise", "-m", "gnf", s(&input), s(&same)],
        vec!["denoise", "-m", "gnf", s(&input), s(&gt), "--gt", s(&gt)],
        vec!["noise", "--seed", "1", s(&input), s(&input)],
    ] {
        assert_refused(&normalnet(&args), &["would overwrite the input"]);
    }
    assert_eq!(std::fs::read(&input).unwrap(), before);
}

/// Audit 4: `batch` exited 0 with failed inputs, and wrote into the input
/// folder.
#[test]
fn batch_fails_when_an_input_fails_and_refuses_the_input_folder() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    write_mesh(input.join("a.obj"), &sphere(8, 12)).unwrap();
    std::fs::write(input.join("bad.obj"), b"not a mesh\n").unwrap();
    write_mesh(input.join("c.obj"), &sphere(8, 12)).unwrap();
    let out = dir.path().join("out");
    let o = normalnet(&["batch", "-q", "-m", "gnf", s(&input), "--out", s(&out)]);
    assert_refused(&o, &["1 of 3 inputs failed", "batch_summary.csv"]);
    // the others were done all the same
    assert!(out.join("a.obj").exists() && out.join("c.obj").exists());
    for extra in [None, Some("--overwrite")] {
        let mut args = vec!["batch", "-q", "-m", "gnf", s(&input), "--out"];
        let same = dir.path().join("in/../in");
        args.push(s(&same));
        args.extend(extra);
        assert_refused(&normalnet(&args), &["is the folder of the input"]);
    }
    assert_eq!(names(&input), ["a.obj", "bad.obj", "c.obj"]);
}

/// Audit 5: a read-only output was replaced, and a symbolic link output
/// became a regular file.
#[cfg(unix)]
#[test]
fn read_only_outputs_are_refused_and_links_are_written_through() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = d.join("in.obj");
    write_mesh(&input, &sphere(8, 12)).unwrap();
    let ro = d.join("ro.obj");
    std::fs::write(&ro, b"keep").unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
    let o = normalnet(&["denoise", "-q", "-m", "gnf", s(&input), s(&ro)]);
    assert_refused(&o, &["ro.obj", "output not writable"]);
    assert_eq!(std::fs::read(&ro).unwrap(), b"keep");
    let link = d.join("link.obj");
    std::os::unix::fs::symlink("target.obj", &link).unwrap();
    let o = normalnet(&["denoise", "-q", "-m", "gnf", s(&input), s(&link)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(read_mesh(d.join("target.obj")).unwrap().num_faces(), 168);
}

/// Audit 6: a degenerate ground truth, or one with other faces, failed only
/// after denoising and writing the output; so did an input beyond STL's
/// f32 range written as `.stl`.
#[test]
fn ground_truth_and_output_format_are_checked_before_denoising() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mesh = sphere(8, 12);
    let input = d.join("in.obj");
    write_mesh(&input, &mesh).unwrap();
    let point = d.join("point.obj");
    write_mesh(&point, &collapsed(&mesh)).unwrap();
    let mut faces = mesh.faces.clone();
    faces[5] = [faces[5][1], faces[5][2], faces[5][0]];
    let rotated = d.join("rotated.obj");
    write_mesh(&rotated, &Mesh::new(mesh.positions.clone(), faces).unwrap()).unwrap();
    let out = d.join("out.obj");
    for method in ["gnf", "gt-gnf"] {
        let args = [
            "denoise",
            "-m",
            method,
            s(&input),
            s(&out),
            "--gt",
            s(&point),
        ];
        assert_refused(&normalnet(&args), &["point.obj", "degenerate ground truth"]);
    }
    assert!(!out.exists());
    let o = normalnet(&["metrics", s(&point), s(&input)]);
    assert_refused(&o, &["point.obj", "degenerate ground truth"]);
    // other face index lists: warned about before the work, as by metrics
    let warning = "rotated.obj: face 5 has vertices";
    let o = normalnet(&[
        "denoise",
        "-m",
        "gnf",
        s(&input),
        s(&out),
        "--gt",
        s(&rotated),
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.starts_with("warning: ") && e.contains(warning), "{e}");
    let o = normalnet(&["metrics", s(&rotated), s(&input)]);
    assert!(
        o.status.success() && stderr(&o).contains(warning),
        "{}",
        stderr(&o)
    );

    let big = d.join("big.obj");
    let mut p = mesh.positions.clone();
    p[3][0] = 1e39;
    write_mesh(&big, &mesh.with_positions(p)).unwrap();
    let stl = d.join("big.stl");
    for args in [
        vec!["denoise", "-m", "gnf", s(&big), s(&stl)],
        vec!["noise", "--seed", "1", s(&big), s(&stl)],
    ] {
        assert_refused(&normalnet(&args), &["big.stl", "vertex 3", "32-bit"]);
    }
    assert!(!stl.exists());
}

/// Audit 7: a zero radius did nothing, a huge iteration count ran forever,
/// `--beta-max 1e300` failed mid-run, NaN and infinity came out as
/// "invalid type: null", and a negative `--level` gave a clap puzzle.
#[test]
fn parameters_out_of_range_are_refused_with_their_name() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    write_mesh(&input, &sphere(8, 12)).unwrap();
    let out = dir.path().join("out.obj");
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["-m", "gnf", "--radius", "0"],
            &["radius_over_ds", "greater than 0"],
        ),
        (
            &["-m", "vt", "--radius", "0"],
            &["radius_over_le", "greater than 0"],
        ),
        (
            &["-m", "gnf", "--vertex-iterations", "18446744073709551615"],
            &["vertex_iterations", "at most 100000"],
        ),
        (
            &["-m", "bnf", "--iterations", "100001"],
            &["normal_iterations", "at most 100000"],
        ),
        (
            &["-m", "l0", "--beta-max", "1e300"],
            &["beta_max", "1e300 must be at most"],
        ),
        (
            &["-m", "gnf", "--mu-g", "nan"],
            &["--mu-g", "must be a finite number"],
        ),
        (
            &["--auto-stop", "inf"],
            &["--auto-stop", "must be a finite number"],
        ),
        (
            &["-p", "mu_g=nan"],
            &["`mu_g` = nan", "not a finite number"],
        ),
        (
            &["--no-switch", "-p", "gnf_after=100000000"],
            &["gnf_after", "at most 100000"],
        ),
    ];
    for (flags, want) in cases {
        let mut args = vec!["denoise", s(&input), s(&out)];
        args.extend_from_slice(flags);
        let o = normalnet(&args);
        assert!(!o.status.success(), "{flags:?}");
        let e = stderr(&o);
        assert!(want.iter().all(|w| e.contains(w)), "{flags:?}: {e}");
    }
    assert!(!out.exists());
    let o = normalnet(&[
        "noise",
        "--seed",
        "1",
        "--level",
        "-0.3",
        s(&input),
        s(&out),
    ]);
    assert_refused(&o, &["level", "must be a finite number >= 0, got -0.3"]);
    let o = normalnet(&[
        "noise",
        "--seed",
        "1",
        "--impulsive",
        "-1",
        s(&input),
        s(&out),
    ]);
    assert_refused(&o, &["impulsive_fraction"]);
}

/// Audit 9: `noise` on a mesh collapsed to a point reported "81 of 81
/// vertices moved" with sigma 0.
#[test]
fn noise_refuses_a_mesh_collapsed_to_a_point() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("point.obj");
    write_mesh(&input, &collapsed(&sphere(8, 12))).unwrap();
    let out = dir.path().join("out.obj");
    let o = normalnet(&["noise", "--seed", "1", s(&input), s(&out)]);
    assert_refused(&o, &["point.obj", "mean edge length"]);
    assert!(!out.exists());
}

/// Issue 39: `denoise --json` reports the final fold repair (folded faces of
/// the input, of the method's result and after the repair; vertices moved),
/// `null` when it is off; the text output names the counts when the method
/// folded any face.
#[test]
fn denoise_reports_the_fold_repair() {
    let tmp = tempfile::tempdir().unwrap();
    let input =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/noisy-part.obj");
    let out = tmp.path().join("out.obj");
    let run = |extra: &[&str]| {
        let mut args = vec!["-q", "denoise", s(&input), s(&out), "-m", "bi"];
        args.extend_from_slice(extra);
        let o = normalnet(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let v: serde_json::Value = serde_json::from_str(&run(&["--json"])).unwrap();
    let folds = &v["folds"];
    let count = |k: &str| folds[k].as_u64().unwrap_or_else(|| panic!("{k}: {folds}"));
    assert!(
        count("before") > 0,
        "bi folds faces of the shipped part: {folds}"
    );
    assert!(
        count("after") <= count("input").min(count("before")),
        "{folds}"
    );
    assert!(count("moved") > 0, "{folds}");
    let text = run(&[]);
    assert!(
        text.contains(&format!(
            "method {}, after the repair {}",
            count("before"),
            count("after")
        )),
        "{text}"
    );
    let v: serde_json::Value = serde_json::from_str(&run(&["--json", "--no-fold-guard"])).unwrap();
    assert!(v["folds"].is_null(), "{}", v["folds"]);
}
