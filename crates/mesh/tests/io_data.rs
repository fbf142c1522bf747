//! Reads the real meshes of `shared/data/gd` (skipped when absent): every
//! OBJ pair and the binary PLY scan `RealData/iron/iron.ply`.

use normalnet_mesh::io::{Format, WriteOptions, encode_mesh, parse_mesh, read_mesh};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn data() -> Option<PathBuf> {
    let d = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gd"
    ));
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("SKIP: {} not found", d.display());
        None
    }
}

/// `# N vertices, M faces` from the first line, if present.
fn announced(path: &Path) -> Option<(usize, usize)> {
    let text = std::fs::read_to_string(path).ok()?;
    let first = text.lines().next()?;
    let w: Vec<&str> = first.split_whitespace().collect();
    if w.len() >= 5 && w[0] == "#" {
        Some((w[1].parse().ok()?, w[3].parse().ok()?))
    } else {
        None
    }
}

#[test]
fn gd_pairs_load_with_announced_counts() {
    let Some(d) = data() else { return };
    for name in [
        "Block0.4",
        "Bunny0.2",
        "Fandisk0.3",
        "Fandisk0.7",
        "Julius0.2",
        "Nicolo0.2",
        "SharpSphere0.3",
        "Twelve0.5Impulsive",
    ] {
        let o = read_mesh(d.join(name).join("Original.obj")).unwrap();
        let n = read_mesh(d.join(name).join("Noisy.obj")).unwrap();
        assert_eq!(o.faces, n.faces, "{name}: same connectivity");
        if let Some((nv, nf)) = announced(&d.join(name).join("Noisy.obj")) {
            assert_eq!((n.num_vertices(), n.num_faces()), (nv, nf), "{name}");
        }
    }
}

#[test]
fn bunny_loads_fast_and_round_trips_through_every_format() {
    let Some(d) = data() else { return };
    let path = d.join("Bunny0.2/Noisy.obj");
    let t = Instant::now();
    let m = read_mesh(&path).unwrap();
    eprintln!(
        "Bunny0.2 Noisy.obj: {} faces read in {:?}",
        m.num_faces(),
        t.elapsed()
    );
    for (f, ascii) in [
        (Format::Obj, false),
        (Format::Off, false),
        (Format::Ply, false),
        (Format::Ply, true),
    ] {
        let bytes = encode_mesh(&m, f, &WriteOptions { ply_ascii: ascii }).unwrap();
        let back = parse_mesh(&bytes, f, Path::new("mem")).unwrap();
        assert!(back == m, "{f:?} ascii={ascii} is not bit-exact");
    }
}

#[test]
fn iron_binary_ply_with_extra_properties() {
    let Some(d) = data() else { return };
    let m = read_mesh(d.join("RealData/iron/iron.ply")).unwrap();
    assert!(m.num_faces() > 1000, "{}", m.num_faces());
    let (lo, hi) = m.bounding_box();
    assert!((0..3).all(|k| hi[k] > lo[k]));
    eprintln!(
        "iron.ply: {} vertices, {} faces",
        m.num_vertices(),
        m.num_faces()
    );
}
