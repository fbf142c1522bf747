//! The fuzzing seeds (fuzz/seeds/<format>/) are valid files that every reader
//! must read — the cube seeds as the same 12 triangles whatever the encoding —
//! and every input the fuzzer ever found wrong (fuzz/regressions/<format>/,
//! kept forever) must now be read or refused without a panic.

use normalnet_mesh::io::{Format, parse_mesh};
use normalnet_mesh::vec3;
use std::path::{Path, PathBuf};

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    out.sort();
    out
}

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

/// glTF: one folder for both containers (the reader tells GLB from JSON
/// by the content).
const FORMATS: [(&str, Format); 5] = [
    ("obj", Format::Obj),
    ("off", Format::Off),
    ("ply", Format::Ply),
    ("stl", Format::Stl),
    ("gltf", Format::Glb),
];

#[test]
fn every_seed_reads_and_cubes_are_the_same_cube() {
    let mut cubes = 0;
    for (name, format) in FORMATS {
        let seeds = files(&fuzz_dir().join("seeds").join(name));
        assert!(!seeds.is_empty(), "no seeds for {name}");
        for path in seeds {
            let bytes = std::fs::read(&path).unwrap();
            let mesh = parse_mesh(&bytes, format, &path)
                .unwrap_or_else(|e| panic!("seed {} does not read: {e}", path.display()));
            if path
                .file_name()
                .unwrap()
                .to_str()
                .unwrap()
                .starts_with("cube")
            {
                cubes += 1;
                assert_eq!(mesh.num_faces(), 12, "{}", path.display());
                assert_eq!(mesh.num_vertices(), 8, "{}", path.display());
                let area: f64 = (0..12)
                    .map(|f| {
                        let [a, b, c] = mesh.corners(f);
                        0.5 * vec3::norm(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
                    })
                    .sum();
                assert!(
                    (area - 6.0).abs() < 1e-12,
                    "{}: area {area}",
                    path.display()
                );
            }
        }
    }
    assert!(cubes >= 12, "only {cubes} cube seeds");
}

#[test]
fn fuzz_regressions_never_panic() {
    for (name, format) in FORMATS {
        for path in files(&fuzz_dir().join("regressions").join(name)) {
            let bytes = std::fs::read(&path).unwrap();
            // Ok or a clear error naming the file; a panic fails the test.
            if let Err(e) = parse_mesh(&bytes, format, &path) {
                assert!(
                    e.to_string()
                        .contains(path.file_name().unwrap().to_str().unwrap())
                );
            }
        }
    }
}

/// The property of the fuzz targets `read_{obj,ply}_file`
/// (`fuzz/src/lib.rs`, `check_file_reader`), on every seed and regression of
/// every format: the attribute reader reads the mesh `parse_mesh` reads (or
/// refuses with an error naming the file), and write → read → write gives
/// the same bytes.
#[test]
fn seeds_and_regressions_round_trip_with_their_attributes() {
    use normalnet_mesh::io::{FileWriteOptions, encode_mesh_file, parse_mesh_file};
    let options = FileWriteOptions::default();
    for (name, format) in FORMATS {
        let seeds = files(&fuzz_dir().join("seeds").join(name));
        let regressions = files(&fuzz_dir().join("regressions").join(name));
        for path in seeds.iter().chain(&regressions) {
            let bytes = std::fs::read(path).unwrap();
            let file = match parse_mesh_file(&bytes, format, path) {
                Ok(file) => file,
                Err(e) => {
                    assert!(!seeds.contains(path), "seed {}: {e}", path.display());
                    assert!(
                        e.to_string()
                            .contains(path.file_name().unwrap().to_str().unwrap())
                    );
                    continue;
                }
            };
            assert_eq!(file.mesh, parse_mesh(&bytes, format, path).unwrap());
            let encoded = encode_mesh_file(&file.mesh, &file.attributes, &options).unwrap();
            let again = parse_mesh_file(&encoded, format, path)
                .unwrap_or_else(|e| panic!("{}: written file does not read: {e}", path.display()));
            assert_eq!(again.mesh.faces, file.mesh.faces, "{}", path.display());
            let twice = encode_mesh_file(&again.mesh, &again.attributes, &options).unwrap();
            assert!(
                twice == encoded,
                "{}: second round changed the file",
                path.display()
            );
        }
    }
}
