//! Issue 39: a closed stderr during work. `eprintln!` panics when its write
//! fails, and a pipe whose reader has gone (`normalnet batch … 2>&1 | head`)
//! fails every write: a progress line or a warning then aborted the command
//! (status 101) with its output unwritten. Each command here runs with
//! stderr on such a pipe, its reader dropped before the child starts, so
//! that every write to stderr fails, and with progress lines due at every
//! step (`NORMALNET_PROGRESS_SECONDS=0`); the input has a stray vertex, so
//! the outlier warning is written too.

mod common;

use common::{bumpy_sphere, s};
use normalnet_mesh::{Mesh, read_mesh, write_mesh};
use std::process::{Command, Output};

/// The write end of a pipe whose read end is already closed: every write
/// to it fails with "broken pipe" (Rust programs ignore SIGPIPE).
fn closed_pipe() -> std::io::PipeWriter {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    writer
}

/// `normalnet ARGS…` with stderr on a [`closed_pipe`] and a progress line
/// due at every step.
fn run_with_closed_stderr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .env_remove("NORMALNET_MODEL")
        .env("NORMALNET_PROGRESS_SECONDS", "0")
        .args(args)
        .stderr(closed_pipe())
        .output()
        .expect("normalnet runs")
}

/// A bumpy sphere (8 × 12, 192 faces) with vertex 20 moved far out: the
/// readers warn about it.
fn sphere_with_stray() -> Mesh {
    let mut m = bumpy_sphere(8, 12, 0.03);
    m.positions[20] = [1e6, 0.0, 0.0];
    m
}

#[test]
fn issue_39_denoise_with_a_closed_stderr_writes_its_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    write_mesh(&input, &sphere_with_stray()).unwrap();
    for (name, flags) in [
        ("gnf.obj", &["-m", "gnf", "--remove-outliers"][..]),
        ("normalnet.obj", &["--iterations", "2"][..]),
    ] {
        let out = dir.path().join(name);
        let mut args = vec!["denoise", s(&input), s(&out)];
        args.extend_from_slice(flags);
        let o = run_with_closed_stderr(&args);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{flags:?}: {}",
            String::from_utf8_lossy(&o.stdout)
        );
        let result = read_mesh(&out).unwrap();
        assert!(result.num_faces() > 0, "{flags:?}");
    }
}

#[test]
fn issue_39_batch_with_a_closed_stderr_reports_in_its_summary() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    std::fs::create_dir(&inputs).unwrap();
    write_mesh(inputs.join("good.obj"), &sphere_with_stray()).unwrap();
    // a failure is reported on stderr too
    std::fs::write(inputs.join("bad.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let out = dir.path().join("out");
    let o = run_with_closed_stderr(&["batch", s(&inputs), "--out", s(&out), "-m", "gnf"]);
    // one input failed: status 1, not a panic's 101
    assert_eq!(o.status.code(), Some(1));
    assert!(read_mesh(out.join("good.obj")).unwrap().num_faces() > 0);
    let summary = std::fs::read_to_string(out.join("batch_summary.csv")).unwrap();
    assert!(
        summary.contains("bad.obj") && summary.contains("failed"),
        "{summary}"
    );
}
