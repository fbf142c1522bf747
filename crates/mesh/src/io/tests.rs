//! Unit tests of the readers and writers (round trips, bad input).

use super::*;

fn p() -> &'static Path {
    Path::new("test.obj")
}

fn parse_obj(s: &str) -> Result<Mesh, MeshError> {
    parse_mesh(s.as_bytes(), Format::Obj, p())
}

#[test]
fn obj_forms_negative_indices_and_polygons() {
    let s = "# c\nv 0 0 0\nv 1 0 0\r\nv 1 1 0 1.0\nv 0 1 0\nvt 0 0\nvn 0 0 1\ng x\n\
             f 1/1/1 2//1 3/1\nf -4 -2 -1\nf 1 2 3 4\nusemtl m\n";
    let m = parse_obj(s).unwrap();
    assert_eq!(m.num_vertices(), 4);
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.positions[2], [1.0, 1.0, 0.0]);
}

#[test]
fn obj_bad_inputs_name_the_problem() {
    let cases: &[(&str, &str)] = &[
        ("", "no mesh"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "0 faces"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "test.obj:4: face 0 refers to vertex 4",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n",
            ":4: face 0: vertex index 0",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n",
            ":4: face 0: relative index -4",
        ),
        (
            "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n",
            ":2: vertex 1: non-finite",
        ),
        ("v 0 0 0\nv 1 0\n", ":2: vertex 1 has 2 coordinates"),
        ("v 0 0 0\nv 1 x 0\n", ":2: vertex 1: bad coordinate \"x\""),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            ":4: face 0 has 2 vertices",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n",
            ":4: face 0: bad vertex index \"a\"",
        ),
    ];
    for (s, want) in cases {
        let e = parse_obj(s).unwrap_err().to_string();
        assert!(e.contains(want), "{s:?}: got {e:?}, want {want:?}");
        assert!(e.contains("test.obj"), "{e}");
    }
}

#[test]
fn obj_forward_references_are_allowed() {
    let m = parse_obj("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2]]);
}

#[test]
fn obj_round_trip_is_bit_exact_and_atomic() {
    let m = Mesh::new(
        vec![
            [0.1, -0.0, 1e-300],
            [1.0 / 3.0, 2.5e17, -7.0],
            [f64::MIN_POSITIVE, 1.0, f64::MAX],
        ],
        vec![[0, 1, 2], [2, 1, 0]],
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.OBJ");
    write_mesh(&path, &m).unwrap();
    let back = read_mesh(&path).unwrap();
    assert_eq!(back.faces, m.faces);
    for (a, b) in back.positions.iter().zip(&m.positions) {
        for k in 0..3 {
            assert_eq!(a[k].to_bits(), b[k].to_bits());
        }
    }
    // Only the target is left in the directory (no temporary files).
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("a.OBJ")]);
}

#[test]
fn unknown_extension_and_missing_file() {
    let e = read_mesh("x.xyz").unwrap_err().to_string();
    assert!(e.contains("unknown mesh format"), "{e}");
    let e = read_mesh("/nonexistent/x.obj").unwrap_err().to_string();
    assert!(e.contains("/nonexistent/x.obj"), "{e}");
}
