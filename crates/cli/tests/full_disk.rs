//! Issue 39: writing onto a full disk. Each test mounts a small tmpfs
//! (needs root; skipped with a message where mounting fails) and unmounts
//! it when done, also when an assertion fails ([`SmallDisk`]'s `Drop`).
//! A mesh that does not fit is an error naming the file, with exit status
//! 1 and nothing left on the disk; a batch reports each file that does not
//! fit and goes on, or stops cleanly when even its summary cannot be
//! written, and a rerun once there is room finishes what is missing.
#![cfg(target_os = "linux")]

mod common;

use common::{normalnet, s, sphere, stderr};
use normalnet_mesh::{read_mesh, write_mesh};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A tmpfs of a given size mounted on a fresh folder; unmounted on drop.
struct SmallDisk {
    dir: PathBuf,
    // removed after the unmount (fields drop after `Drop::drop`)
    _parent: tempfile::TempDir,
}

impl SmallDisk {
    /// Mounts a tmpfs of `size` (`mount`'s syntax: "1m"), `None` (with a
    /// message) where that is not allowed.
    fn mount(size: &str) -> Option<SmallDisk> {
        let parent = tempfile::tempdir().unwrap();
        let dir = parent.path().join("disk");
        std::fs::create_dir(&dir).unwrap();
        let status = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&dir)
            .output();
        match status {
            Ok(o) if o.status.success() => Some(SmallDisk {
                dir,
                _parent: parent,
            }),
            Ok(o) => {
                println!("skipped: cannot mount a tmpfs: {}", stderr(&o).trim());
                None
            }
            Err(e) => {
                println!("skipped: cannot run mount: {e}");
                None
            }
        }
    }

    /// Grows (or shrinks) the disk to `size`: space freed without
    /// touching its files.
    fn resize(&self, size: &str) {
        let status = Command::new("mount")
            .args(["-o", &format!("remount,size={size}")])
            .arg(&self.dir)
            .status()
            .unwrap();
        assert!(status.success(), "remount to {size}");
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.dir).status();
    }
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Names of temporary files left in `dir`.
fn temp_files(dir: &Path) -> Vec<String> {
    names(dir)
        .into_iter()
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// A quick GNF run (one pass of each kind).
const QUICK: [&str; 6] = ["-m", "gnf", "--iterations", "1", "--vertex-iterations", "1"];

/// Writes a bumpy sphere (`rings` × 2·`rings`) to `path`; returns its size
/// in bytes.
fn write_sphere(path: &Path, rings: usize) -> u64 {
    write_mesh(path, &sphere(rings, 2 * rings)).unwrap();
    std::fs::metadata(path).unwrap().len()
}

#[test]
fn issue_39_denoise_onto_a_full_disk_names_the_file_and_leaves_nothing() {
    let Some(disk) = SmallDisk::mount("256k") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.obj");
    let size = write_sphere(&input, 40);
    assert!(size > 256 * 1024, "the output must not fit: {size} bytes");
    let out = disk.dir.join("out.obj");
    let mut args = vec!["denoise", "-q", s(&input), s(&out)];
    args.extend_from_slice(&QUICK);
    let o = normalnet(&args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains(&format!("writing {}", out.display())) && e.contains("No space left on device"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(names(&disk.dir), Vec::<String>::new());
}

#[test]
fn issue_39_batch_onto_a_full_disk_reports_goes_on_and_resumes() {
    let Some(disk) = SmallDisk::mount("1m") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    std::fs::create_dir(&inputs).unwrap();
    let small = write_sphere(&inputs.join("a.obj"), 8);
    let big = write_sphere(&inputs.join("b.obj"), 60);
    write_sphere(&inputs.join("c.obj"), 60);
    write_sphere(&inputs.join("d.obj"), 8);
    // a, b and d fit in 1 MiB, c does not fit beside them
    assert!(2 * small + big + 64 * 1024 < 1 << 20 && 2 * big > 1 << 20);
    // not quiet: each failure is reported on stderr as it happens
    let mut args = vec!["batch", s(&inputs), "--out", s(&disk.dir)];
    args.extend_from_slice(&QUICK);

    let o = normalnet(&args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("c.obj") && e.contains("No space left on device"),
        "{e}"
    );
    assert!(e.contains("1 of 4 inputs failed"), "{e}");
    assert_eq!(
        names(&disk.dir),
        [
            "a.obj",
            "b.obj",
            "batch_summary.csv",
            "batch_summary.json",
            "d.obj"
        ]
    );
    let summary = std::fs::read_to_string(disk.dir.join("batch_summary.csv")).unwrap();
    let c_row = summary.lines().find(|l| l.contains("c.obj")).unwrap();
    assert!(
        c_row.contains(",failed,") && c_row.contains("No space left on device"),
        "{c_row}"
    );

    // room made: the rerun writes c only
    disk.resize("4m");
    let o = normalnet(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(
        report.contains("4 files: 1 done, 3 skipped, 0 failed"),
        "{report}"
    );
    assert!(read_mesh(disk.dir.join("c.obj")).unwrap().num_faces() > 0);
    assert_eq!(temp_files(&disk.dir), Vec::<String>::new());
}

#[test]
fn issue_39_a_batch_that_cannot_write_its_summary_stops_and_resumes() {
    let Some(disk) = SmallDisk::mount("512k") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    std::fs::create_dir(&inputs).unwrap();
    for name in ["a.obj", "b.obj", "c.obj"] {
        write_sphere(&inputs.join(name), 8);
    }
    // fill the disk to the last byte
    let filler = disk.dir.join("filler");
    {
        use std::io::Write;
        let mut f = std::fs::File::create(&filler).unwrap();
        let block = vec![0u8; 4096];
        while f.write_all(&block).is_ok() {}
        while f.write_all(&[0]).is_ok() {}
    }
    let mut args = vec!["batch", "-q", s(&inputs), "--out", s(&disk.dir)];
    args.extend_from_slice(&QUICK);
    let o = normalnet(&args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("batch_summary") && e.contains("No space left on device"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(names(&disk.dir), ["filler"]);

    std::fs::remove_file(&filler).unwrap();
    let o = normalnet(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(
        report.contains("3 files: 3 done, 0 skipped, 0 failed"),
        "{report}"
    );
    assert_eq!(temp_files(&disk.dir), Vec::<String>::new());
}
