//! End-to-end: `normalnet shapes`, `normalnet voxelize`, `normalnet dataset`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn normalnet(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .args(args)
        .output()
        .expect("run normalnet")
}

fn npy_header(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    String::from_utf8(bytes[10..10 + len].to_vec()).unwrap()
}

/// `normalnet ARGS…`, which must succeed (the failure shows its stderr).
fn succeeds(args: &[&str]) {
    let out = normalnet(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `normalnet shapes` of two shapes of about 800 faces into `dir/shapes`:
/// their files, sorted.
fn two_shapes(dir: &Path) -> Vec<PathBuf> {
    let shapes = dir.join("shapes");
    let out = shapes.to_str().unwrap();
    succeeds(&[
        "shapes", out, "--count", "2", "--seed", "4", "--faces", "800", "-q",
    ]);
    let mut files: Vec<_> = std::fs::read_dir(&shapes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
}

#[test]
fn shapes_writes_the_asked_count_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let files = two_shapes(dir.path());
    assert_eq!(files.len(), 2);
    let mesh = normalnet_mesh::io::read_mesh(&files[0]).unwrap();
    assert!(
        mesh.num_faces() > 400 && mesh.num_faces() < 1300,
        "{}",
        mesh.num_faces()
    );
}

#[test]
fn voxelize_writes_a_grid_or_a_picture_and_names_bad_faces_and_presets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let files = two_shapes(d);
    let shape = files[0].to_str().unwrap();
    let npy = d.join("g.npy");
    let npy_out = npy.to_str().unwrap();
    succeeds(&[
        "voxelize", shape, "--face", "5", "--preset", "tiny", "--out", npy_out, "-q",
    ]);
    assert!(npy_header(&npy).contains("'shape': (3, 15, 15, 15)"));
    assert_eq!(
        std::fs::metadata(&npy).unwrap().len() as usize,
        128 + 4 * 3 * 15 * 15 * 15
    );
    let png = d.join("g.png");
    succeeds(&[
        "voxelize",
        shape,
        "--face",
        "5",
        "--out",
        png.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");

    let bad = normalnet(&["voxelize", shape, "--face", "999999", "--out", npy_out]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("face 999999 out of range"));
    let bad = normalnet(&[
        "voxelize", shape, "--face", "1", "--preset", "huge", "--out", npy_out,
    ]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("preset"));
}

#[test]
fn dataset_writes_balanced_categories() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let files = two_shapes(d);
    let ds = d.join("ds");
    let (a, b) = (files[0].to_str().unwrap(), files[1].to_str().unwrap());
    succeeds(&[
        "dataset",
        a,
        b,
        "--out",
        ds.to_str().unwrap(),
        "--count",
        "40",
        "--preset",
        "tiny",
        "--seed",
        "1",
        "--yaw",
        "--pictures",
        "1",
        "-q",
    ]);
    assert!(npy_header(&ds.join("grids.npy")).contains("'shape': (40, 3, 15, 15, 15)"));
    assert!(npy_header(&ds.join("targets.npy")).contains("'shape': (40, 6, 3)"));
    assert!(npy_header(&ds.join("categories.npy")).contains("'shape': (40,)"));
    assert!(ds.join("grid_0000.png").exists());
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ds.join("manifest.json")).unwrap()).unwrap();
    let per_cat: Vec<u64> = manifest["samples_per_category"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    let nonzero: Vec<u64> = per_cat.iter().copied().filter(|&c| c > 0).collect();
    assert_eq!(per_cat.iter().sum::<u64>(), 40);
    assert!(
        nonzero.iter().max().unwrap() - nonzero.iter().min().unwrap() <= 1,
        "{per_cat:?}"
    );
}
