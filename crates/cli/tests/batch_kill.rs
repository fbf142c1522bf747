//! Issue 39: a batch killed with SIGKILL (no handler runs, unlike SIGINT)
//! and run again finishes with the outputs of a run never interrupted,
//! byte for byte, and no temporary file left: outputs appear whole or not
//! at all (written to a temporary file, then renamed), the rerun skips the
//! finished ones, and it removes the temporary file of the killed process.
#![cfg(unix)]

mod common;

use common::{bumpy_sphere, normalnet, s, stderr};
use normalnet_mesh::write_mesh;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// The number of inputs.
const FILES: usize = 20;

/// `FILES` small bumpy spheres, each a little different, in `dir`.
fn write_inputs(dir: &Path) {
    std::fs::create_dir(dir).unwrap();
    for i in 0..FILES {
        let mesh = bumpy_sphere(24 + i % 4, 48, 0.01 + 0.002 * i as f64);
        write_mesh(dir.join(format!("m{i:02}.obj")), &mesh).unwrap();
    }
}

/// The mesh files in `dir` (temporary files and summaries left out), sorted.
fn outputs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".obj") && !n.starts_with('.'))
        .collect();
    names.sort();
    names
}

/// Names of temporary files in `dir`.
fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[test]
fn issue_39_a_batch_killed_mid_run_resumes_to_the_same_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    write_inputs(&inputs);
    let batch = |out: &Path| -> Vec<String> {
        ["batch", "-q", s(&inputs), "--out", s(out), "-m", "gnf"]
            .map(String::from)
            .to_vec()
    };

    let reference = dir.path().join("reference");
    let o = normalnet(
        &batch(&reference)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(outputs(&reference).len(), FILES);

    let killed = dir.path().join("killed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .args(batch(&killed))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // killed as soon as the first output is there
    loop {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the batch ended before it could be killed"
        );
        if killed.is_dir() && !outputs(&killed).is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(9), "{status:?}");
    }
    let done = outputs(&killed).len();
    assert!(done < FILES, "{done} outputs: the kill came after the end");
    // what a kill in the middle of a write leaves: the killed process's
    // temporary file (it may or may not have left one itself)
    let stale = killed.join(format!(".normalnet-{}-killed.tmp", child.id()));
    std::fs::write(&stale, b"v 0 0").unwrap();

    let o = normalnet(
        &batch(&killed)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(
        report.contains(&format!("{} done, {done} skipped, 0 failed", FILES - done)),
        "{report}"
    );
    assert!(
        stderr(&o).contains("temporary file(s) of an interrupted run"),
        "{}",
        stderr(&o)
    );
    assert_eq!(temp_files(&killed), Vec::<String>::new());
    assert_eq!(outputs(&killed), outputs(&reference));
    for name in outputs(&reference) {
        let a = std::fs::read(reference.join(&name)).unwrap();
        let b = std::fs::read(killed.join(&name)).unwrap();
        assert!(a == b, "{name} differs from the uninterrupted run's");
    }
}
