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
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644, "{mode:o}");
    }
}

#[test]
fn unknown_extension_and_missing_file() {
    let e = read_mesh("x.xyz").unwrap_err().to_string();
    assert!(e.contains("unknown mesh format"), "{e}");
    let e = read_mesh("/nonexistent/x.obj").unwrap_err().to_string();
    assert!(e.contains("/nonexistent/x.obj"), "{e}");
}

/// The unit square with one corner raised (two faces, not coplanar).
fn tri_mesh() -> Mesh {
    let mut m = Mesh::unit_square();
    m.positions[3][2] = 0.5;
    m
}

#[test]
fn every_format_round_trips_in_memory() {
    let m = tri_mesh();
    for (format, ascii) in [
        (Format::Obj, false),
        (Format::Off, false),
        (Format::Ply, false),
        (Format::Ply, true),
        (Format::Stl, false),
    ] {
        let bytes = encode_mesh(&m, format, &WriteOptions { ply_ascii: ascii }).unwrap();
        let back = parse_mesh(&bytes, format, Path::new("m")).unwrap();
        assert_eq!(back, m, "{format:?} ascii={ascii}");
    }
}

#[test]
fn off_variants_and_errors() {
    let ok =
        "OFF\n# comment\n4 2 0\n0 0 0\n1 0 0 255 0 0\n1 1 0\n0 1 0.5\n4 0 1 2 3\n3 0 2 3 1 1 1\n";
    let m = parse_mesh(ok.as_bytes(), Format::Off, p()).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
    let m = parse_mesh(
        b"OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        Format::Off,
        p(),
    )
    .unwrap();
    assert_eq!(m.num_faces(), 1);
    let cases: &[(&str, &str)] = &[
        ("", "empty OFF"),
        ("PLY\n", ":1: expected an OFF header"),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n",
            ":4: file ends after 2 of 3 vertices",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
            ":6: face 0 refers to vertex 3",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n",
            ":4: vertex 1: non-finite",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n",
            ":6: face 0 lists 2 of its 3",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
            ":7: data after the 3 vertices and 1 faces",
        ),
        (
            "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            ":6: file ends after 1 of 2 faces",
        ),
    ];
    for (s, want) in cases {
        let e = parse_mesh(s.as_bytes(), Format::Off, p())
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{s:?}: got {e:?}, want {want:?}");
    }
}

/// A binary PLY with a few extra properties and an extra element.
fn ply_binary(be: bool, nv_header: usize) -> Vec<u8> {
    let mut b = format!(
        "ply\nformat binary_{}_endian 1.0\ncomment x\nelement vertex {nv_header}\nproperty float x\n\
         property uchar red\nproperty double y\nproperty int z\nproperty list uchar short junk\n\
         element face 1\nproperty int flags\nproperty list int uint vertex_indices\n\
         element edge 1\nproperty list uchar int vertex_indices\nend_header\n",
        if be { "big" } else { "little" }
    )
    .into_bytes();
    macro_rules! put {
        ($v:expr) => {
            if be {
                b.extend_from_slice(&$v.to_be_bytes())
            } else {
                b.extend_from_slice(&$v.to_le_bytes())
            }
        };
    }
    for (x, y, z) in [
        (0.5f32, 0.25f64, 1i32),
        (1.0, 0.0, 2),
        (0.0, 1.0, 3),
        (2.0, 2.0, 4),
    ] {
        put!(x);
        put!(7u8);
        put!(y);
        put!(z);
        put!(2u8);
        put!(-1i16);
        put!(5i16);
    }
    put!(9i32);
    put!(4i32);
    for i in [0u32, 1, 2, 3] {
        put!(i);
    }
    put!(2u8);
    put!(0i32);
    put!(1i32);
    b
}

#[test]
fn ply_binary_both_endians_with_extra_properties() {
    for be in [false, true] {
        let m = parse_mesh(&ply_binary(be, 4), Format::Ply, Path::new("x.ply")).unwrap();
        assert_eq!(m.positions[0], [0.5, 0.25, 1.0]);
        assert_eq!(m.positions[3], [2.0, 2.0, 4.0]);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }
}

#[test]
fn ply_errors_name_the_problem() {
    let path = Path::new("x.ply");
    // Header claims 3 vertices: the face element is read from vertex data.
    let e = parse_mesh(&ply_binary(false, 3), Format::Ply, path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.ply") && e.contains("byte offset"), "{e}");
    // Header claims 5 vertices: the data runs out.
    let e = parse_mesh(&ply_binary(false, 5), Format::Ply, path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("byte offset") && e.contains("refers to vertex"),
        "{e}"
    );
    // Truncated binary.
    let full = ply_binary(false, 4);
    let e = parse_mesh(&full[..full.len() - 5], Format::Ply, path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("element edge") && e.contains("data ends early"),
        "{e}"
    );
    let ascii_head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                      property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let cases: &[(&str, &str)] = &[
        ("", "empty PLY"),
        ("ply\nformat ascii 1.0\n", "without end_header"),
        ("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "__ok__"),
        (
            "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
            "x.ply:13: element face 0: refers to vertex 3",
        ),
        (
            "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
            ":11: element vertex 1: non-finite coordinate y",
        ),
        ("0 0 0\n1 0 0\n", "data ends early"),
        (
            "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
            ":11: element vertex 1: property z: line ends early",
        ),
        (
            "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
            "do not match the data",
        ),
        ("0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7\n", "extra value \"7\""),
    ];
    for (data, want) in cases {
        let s = if data.is_empty() || data.starts_with("ply") {
            data.to_string()
        } else {
            format!("{ascii_head}{data}")
        };
        let r = parse_mesh(s.as_bytes(), Format::Ply, path);
        if *want == "__ok__" {
            assert_eq!(r.unwrap().faces, vec![[0, 1, 2]]);
            continue;
        }
        let e = r.unwrap_err().to_string();
        assert!(e.contains(want), "{data:?}: got {e:?}, want {want:?}");
    }
}

#[test]
fn stl_ascii_binary_merge_and_errors() {
    let s = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\n\
             facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 1 0\n  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
    let m = parse_mesh(s.as_bytes(), Format::Stl, Path::new("a.stl")).unwrap();
    assert_eq!(m.num_vertices(), 4);
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    let bin = encode_mesh(&m, Format::Stl, &WriteOptions::default()).unwrap();
    assert_eq!(bin.len(), 84 + 100);
    assert_eq!(parse_mesh(&bin, Format::Stl, p()).unwrap(), m);
    let e = parse_mesh(&bin[..150], Format::Stl, Path::new("a.stl"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a.stl") && e.contains("announces 2 triangles"),
        "{e}"
    );
    let cut = s.find("endloop").unwrap();
    let e = parse_mesh(&s.as_bytes()[..cut], Format::Stl, p())
        .unwrap_err()
        .to_string();
    assert!(e.contains("truncated"), "{e}");
    let e = parse_mesh(b"", Format::Stl, p()).unwrap_err().to_string();
    assert!(e.contains("empty STL"), "{e}");
    let bad = s.replace("vertex 1 0 0", "vertex 1 NaN 0");
    let e = parse_mesh(bad.as_bytes(), Format::Stl, p())
        .unwrap_err()
        .to_string();
    assert!(e.contains(":5: non-finite"), "{e}");
}

// Issue 14: readers take what editors and exporters write, and refuse
// anything else with the file and the line. The inputs are written to
// temporary files and read back with `read_mesh`, as a user would.

/// Writes `bytes` as `name` in a fresh temporary folder and reads it.
fn read_temp(name: &str, bytes: &[u8]) -> (tempfile::TempDir, Result<Mesh, MeshError>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let r = read_mesh(&path);
    (dir, r)
}

const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";

#[test]
fn issue_14_obj_with_byte_order_mark_keeps_its_first_vertex() {
    let plain = parse_obj(QUAD_OBJ).unwrap();
    let mut bytes = BOM.to_vec();
    bytes.extend_from_slice(QUAD_OBJ.as_bytes());
    let (_dir, r) = read_temp("bom.obj", &bytes);
    assert_eq!(r.unwrap(), plain);
    // The same for the other text formats.
    for (format, ascii) in [
        (Format::Off, false),
        (Format::Ply, true),
        (Format::Ply, false),
    ] {
        let mut bytes = BOM.to_vec();
        bytes.extend(encode_mesh(&plain, format, &WriteOptions { ply_ascii: ascii }).unwrap());
        let back = parse_mesh(&bytes, format, p()).unwrap();
        assert_eq!(back, plain, "{format:?} ascii={ascii}");
    }
}

#[test]
fn issue_14_crlf_and_cr_line_ends_read_like_lf() {
    let plain = parse_obj(QUAD_OBJ).unwrap();
    for sep in ["\r\n", "\r"] {
        let text = QUAD_OBJ.replace('\n', sep);
        let (_dir, r) = read_temp("crlf.obj", text.as_bytes());
        assert_eq!(r.unwrap(), plain, "{sep:?}");
    }
    for (format, name) in [(Format::Off, "crlf.off"), (Format::Stl, "crlf.stl")] {
        let text = match format {
            Format::Off => {
                String::from_utf8(encode_mesh(&plain, format, &WriteOptions::default()).unwrap())
                    .unwrap()
            }
            _ => ascii_stl(&plain, "solid", "facet"),
        };
        let (_dir, r) = read_temp(name, text.replace('\n', "\r\n").as_bytes());
        assert_eq!(r.unwrap(), plain, "{name}");
    }
    let ply = encode_mesh(&plain, Format::Ply, &WriteOptions { ply_ascii: true }).unwrap();
    let ply = String::from_utf8(ply).unwrap().replace('\n', "\r\n");
    let (_dir, r) = read_temp("crlf.ply", ply.as_bytes());
    assert_eq!(r.unwrap(), plain);
}

/// An ASCII STL of `m` with the given spelling of `solid` and `facet`.
fn ascii_stl(m: &Mesh, solid: &str, facet: &str) -> String {
    let mut s = format!("{solid} test\n");
    for f in 0..m.num_faces() {
        s += &format!("  {facet} normal 0 0 1\n    outer loop\n");
        for c in m.corners(f) {
            s += &format!("      vertex {} {} {}\n", c[0], c[1], c[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid test\n"
}

#[test]
fn issue_14_uppercase_keywords() {
    let plain = parse_obj(QUAD_OBJ).unwrap();
    // Uppercase ASCII STL (read as binary and refused before).
    let upper = ascii_stl(&plain, "solid", "facet").to_ascii_uppercase();
    assert!(upper.starts_with("SOLID"));
    let (_dir, r) = read_temp("upper.stl", upper.as_bytes());
    assert_eq!(r.unwrap(), plain);
    // Mixed case, with a byte-order mark.
    let mut mixed = BOM.to_vec();
    mixed.extend(ascii_stl(&plain, "Solid", "Facet").into_bytes());
    let (_dir, r) = read_temp("mixed.stl", &mixed);
    assert_eq!(r.unwrap(), plain);
    // OBJ V / F, OFF header in lower case and with prefixes.
    let (_dir, r) = read_temp("upper.obj", QUAD_OBJ.to_ascii_uppercase().as_bytes());
    assert_eq!(r.unwrap(), plain);
    let off =
        String::from_utf8(encode_mesh(&plain, Format::Off, &WriteOptions::default()).unwrap())
            .unwrap();
    for head in ["off", "Off", "COFF", "NOFF", "STCNOFF", "stcoff"] {
        let (_dir, r) = read_temp("h.off", off.replacen("OFF", head, 1).as_bytes());
        assert_eq!(r.unwrap(), plain, "{head}");
    }
    for (head, want) in [
        ("nOFF", "only 3D OFF"),
        ("4OFF", "only 3D OFF"),
        ("XOFF", "expected an OFF header"),
        ("OFFX", "expected an OFF header"),
    ] {
        let (_dir, r) = read_temp("h.off", off.replacen("OFF", head, 1).as_bytes());
        let e = r.unwrap_err().to_string();
        assert!(e.contains("h.off:1:") && e.contains(want), "{head}: {e}");
    }
}

#[test]
fn issue_14_binary_stl_size_rule() {
    let m = parse_obj(QUAD_OBJ).unwrap();
    let bin = encode_mesh(&m, Format::Stl, &WriteOptions::default()).unwrap();
    // A binary header that starts with "solid" and even mentions facets is
    // still binary when the size matches 84 + 50·n.
    let mut solid_head = bin.clone();
    solid_head[..20].copy_from_slice(b"solid facet endsolid");
    let (_dir, r) = read_temp("solid.stl", &solid_head);
    assert_eq!(r.unwrap(), m);
    // A few trailing bytes: read, ignored.
    for extra in [1usize, 2, 49] {
        let mut padded = bin.clone();
        padded.extend(std::iter::repeat_n(0xAB, extra));
        let (_dir, r) = read_temp("pad.stl", &padded);
        assert_eq!(r.unwrap(), m, "{extra} trailing bytes");
    }
    // A whole record or more beyond the count: the count is wrong.
    let mut long = bin.clone();
    long.extend([0u8; 50]);
    let (_dir, r) = read_temp("long.stl", &long);
    let e = r.unwrap_err().to_string();
    assert!(
        e.contains("long.stl") && e.contains("wrong triangle count"),
        "{e}"
    );
    // Truncated: refused with the file name.
    for cut in [bin.len() - 1, bin.len() - 50, 90, 84] {
        let (_dir, r) = read_temp("cut.stl", &bin[..cut]);
        let e = r.unwrap_err().to_string();
        assert!(
            e.contains("cut.stl") && e.contains("announces 2 triangles") && e.contains("truncated"),
            "{cut}: {e}"
        );
    }
    let (_dir, r) = read_temp("tiny.stl", &bin[..40]);
    let e = r.unwrap_err().to_string();
    assert!(e.contains("tiny.stl") && e.contains("truncated"), "{e}");
}

#[test]
fn issue_14_malformed_text_is_refused_with_file_and_line() {
    let m = parse_obj(QUAD_OBJ).unwrap();
    let stl = ascii_stl(&m, "solid", "facet");
    let stl_lines: Vec<&str> = stl.lines().collect();
    let cut_after = |n: usize| stl_lines[..n].join("\n") + "\n";
    let cases: Vec<(&str, String, &str)> = vec![
        // OBJ: a line that is no statement; binary junk.
        ("a.obj", format!("{QUAD_OBJ}1 2 3\n"), "a.obj:7: unexpected \"1\""),
        ("a.obj", format!("v 0 0 0\n\u{1}v 1 0 0\n{QUAD_OBJ}"), "a.obj:2: unexpected"),
        // OFF: trailing junk, fewer elements than the header.
        ("a.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\njunk\n".into(), "a.off:7: data after"),
        ("a.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n".into(), "a.off:5: file ends after 3 of 4 vertices"),
        // ASCII STL: cut at a line boundary, junk, statements out of order.
        ("a.stl", cut_after(stl_lines.len() - 1), "a.stl:15: file ends without endsolid"),
        ("a.stl", cut_after(9), "a.stl:9: file ends inside a facet"),
        ("a.stl", stl.replace("endloop", "endlop"), "a.stl:7: unexpected \"endlop\", expected vertex or endloop"),
        ("a.stl", stl.replacen("outer loop", "vertex 0 0 0", 1), "a.stl:3: unexpected \"vertex 0 0 0\", expected outer loop"),
        ("a.stl", format!("{stl}garbage\n"), "a.stl:17: unexpected \"garbage\", expected solid"),
        // ASCII PLY: fewer elements than the header, junk after the data.
        (
            "a.ply",
            "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\n\
             property float z\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n\
             end_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n"
                .into(),
            "a.ply",
        ),
    ];
    for (name, text, want) in cases {
        let (_dir, r) = read_temp(name, text.as_bytes());
        let e = r.unwrap_err().to_string();
        assert!(
            e.contains(want),
            "{name} {text:?}: got {e:?}, want {want:?}"
        );
    }
}

#[test]
fn issue_14_check_writable_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("out.obj");
    check_writable(&ok).unwrap();
    // The probe leaves nothing behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    let missing = dir.path().join("no/such/folder/out.obj");
    let e = check_writable(&missing).unwrap_err().to_string();
    assert!(
        e.contains("no/such/folder") && e.contains("cannot be used"),
        "{e}"
    );
    let e = check_writable(dir.path()).unwrap_err().to_string();
    assert!(e.contains("is a folder"), "{e}");
    let file = dir.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    let e = check_writable(&file.join("out.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a folder"), "{e}");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.path().join("ro");
        std::fs::create_dir(&ro).unwrap();
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
        // root may write anyway: only check when the folder really is read-only
        if tempfile::tempfile_in(&ro).is_err() {
            let e = check_writable(&ro.join("out.obj")).unwrap_err().to_string();
            assert!(e.contains("not writable"), "{e}");
        }
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    // write_atomically's temporary files carry this process's id.
    assert!(temp_prefix().starts_with(".normalnet-") && temp_prefix().ends_with('-'));
}

/// Found by fuzzing (fuzz/regressions/stl/ascii-coordinate-beyond-f32.stl):
/// an ASCII STL value beyond f32's range was read (f64) and then written as
/// an infinity that no reader accepts.
#[test]
fn stl_coordinates_beyond_f32_are_refused_when_read_and_when_written() {
    let tri = |x: &str| {
        format!(
            "solid s\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex {x} 0 0\n\
             vertex 0 1 0\nendloop\nendfacet\nendsolid s\n"
        )
    };
    let e = parse_mesh(tri("1e39").as_bytes(), Format::Stl, Path::new("big.stl")).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("big.stl:5") && text.contains("32-bit"),
        "{text}"
    );
    // the largest f32 itself is fine and round-trips
    let m = parse_mesh(tri("3.4e38").as_bytes(), Format::Stl, p()).unwrap();
    let bytes = encode_mesh(&m, Format::Stl, &WriteOptions::default()).unwrap();
    assert_eq!(parse_mesh(&bytes, Format::Stl, p()).unwrap().num_faces(), 1);
    // a mesh from another format with such a coordinate is not written as STL
    let big = Mesh::new(
        vec![[0.0; 3], [1e39, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let e = encode_mesh(&big, Format::Stl, &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("vertex 1"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.stl");
    let e = write_mesh(&out, &big).unwrap_err().to_string();
    assert!(e.contains("big.stl") && e.contains("32-bit"), "{e}");
    assert!(!out.exists(), "no partial output");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "temp file left"
    );
    // the other formats hold it exactly
    let obj = encode_mesh(&big, Format::Obj, &WriteOptions::default()).unwrap();
    assert_eq!(parse_mesh(&obj, Format::Obj, p()).unwrap(), big);
}

/// Audit: an OBJ face index beyond i64 wrapped to a bogus index (and
/// `-9223372036854775808` overflowed on negation): now checked, and reported
/// as out of range with the file and line.
#[test]
fn obj_huge_face_indices_are_out_of_range_not_wrapped() {
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (index, want) in [
        ("-9999999999999999999", "vertex index out of range"),
        ("9999999999999999999", "vertex index out of range"),
        ("99999999999999999999999", "vertex index out of range"),
        ("4294967297", "vertex index out of range"),
        (
            "-9223372036854775808",
            "relative index -9223372036854775808",
        ),
    ] {
        let e = parse_obj(&format!("{head}f 1 2 {index}\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("test.obj:4: face 0: ") && e.contains(want),
            "{index}: {e}"
        );
    }
    assert_eq!(parse_i64(b"-9223372036854775808"), Some(i64::MIN));
    assert_eq!(parse_i64(b"9223372036854775808"), None);
    assert_eq!(parse_i64(b"+12"), Some(12));
}

/// Audit: a PLY with old-Mac `\r` line ends was refused as "not a PLY file"
/// although every text format accepts them (module docs).
#[test]
fn ply_with_cr_line_ends_reads_like_lf() {
    let plain = parse_obj(QUAD_OBJ).unwrap();
    let ascii = encode_mesh(&plain, Format::Ply, &WriteOptions { ply_ascii: true }).unwrap();
    let ascii = String::from_utf8(ascii).unwrap().replace('\n', "\r");
    let (_dir, r) = read_temp("cr.ply", ascii.as_bytes());
    assert_eq!(r.unwrap(), plain);
    // binary data after a `\r` header (its bytes may contain 13 and 10)
    let binary = encode_mesh(&plain, Format::Ply, &WriteOptions::default()).unwrap();
    let end = b"end_header\n";
    let split = binary.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let mut cr = binary[..split].to_vec();
    cr.iter_mut().for_each(|b| {
        if *b == b'\n' {
            *b = b'\r';
        }
    });
    cr.extend_from_slice(&binary[split..]);
    assert_eq!(parse_mesh(&cr, Format::Ply, p()).unwrap(), plain);
    // errors still name the line
    let bad = ascii.replacen("1 1 0", "1 x 0", 1);
    let e = parse_mesh(bad.as_bytes(), Format::Ply, Path::new("x.ply"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.ply:13: element vertex 2"), "{e}");
}

/// Audit: a read-only output file was replaced by the atomic rename, and a
/// symbolic link output was replaced by a regular file.
#[cfg(unix)]
#[test]
fn read_only_outputs_are_refused_and_links_written_through() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let m = parse_obj(QUAD_OBJ).unwrap();
    let ro = dir.path().join("ro.obj");
    std::fs::write(&ro, b"keep").unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
    for e in [
        check_writable(&ro).unwrap_err(),
        write_mesh(&ro, &m).unwrap_err(),
    ] {
        let e = e.to_string();
        assert!(
            e.contains("ro.obj") && e.contains("output not writable"),
            "{e}"
        );
    }
    assert_eq!(std::fs::read(&ro).unwrap(), b"keep");
    // a link, relative to its folder, to a file that does not exist yet
    let link = dir.path().join("link.obj");
    std::os::unix::fs::symlink("target.obj", &link).unwrap();
    check_writable(&link).unwrap();
    write_mesh(&link, &m).unwrap();
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(read_mesh(dir.path().join("target.obj")).unwrap(), m);
    // a link to a read-only file is refused like the file
    let ro_link = dir.path().join("ro_link.obj");
    std::os::unix::fs::symlink(&ro, &ro_link).unwrap();
    assert!(check_writable(&ro_link).is_err() && write_mesh(&ro_link, &m).is_err());
    assert_eq!(write_target(&ro_link), ro);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(names.is_empty(), "{names:?}");
}

/// Audit: writing `.stl` from a mesh beyond f32's range failed only after
/// the work; `check_encodable` says so before.
#[test]
fn check_encodable_refuses_stl_beyond_f32_only() {
    let big = Mesh::new(
        vec![[0.0; 3], [1e39, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let out = Path::new("out.stl");
    let e = check_encodable(out, &big, Format::Stl)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("out.stl") && e.contains("vertex 1") && e.contains("32-bit"),
        "{e}"
    );
    for format in [Format::Obj, Format::Off, Format::Ply] {
        check_encodable(out, &big, format).unwrap();
    }
    check_encodable(out, &parse_obj(QUAD_OBJ).unwrap(), Format::Stl).unwrap();
}

#[test]
fn gltf_formats_by_extension_and_name() {
    assert_eq!(Format::from_path(Path::new("a.GLTF")), Some(Format::Gltf));
    assert_eq!(Format::from_path(Path::new("a.glb")), Some(Format::Glb));
    assert_eq!(Format::from_name("glb"), Some(Format::Glb));
    assert_eq!(Format::Gltf.name(), "glTF");
    assert!(Format::Glb.is_gltf() && !Format::Stl.is_gltf());
    let far = Mesh::new(
        vec![[0.0; 3], [1e39, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    for format in [Format::Gltf, Format::Glb] {
        let e = check_encodable(Path::new("o.glb"), &far, format).unwrap_err();
        assert!(e.to_string().contains("vertex 1"), "{e}");
        assert!(encode_mesh(&far, format, &WriteOptions::default()).is_err());
    }
}

/// Found by fuzzing (fuzz/regressions/ply/read_ply_file-timeout-huge-element-count.ply):
/// a header declaring ~4 billion instances with no data behind it is refused
/// at once, not after looping over the count; an element without
/// properties carries no data, whatever its count.
#[test]
fn ply_counts_the_data_cannot_hold_are_refused_before_reading() {
    let path = Path::new("big.ply");
    for format in ["ascii", "binary_little_endian"] {
        let head = format!(
            "ply\nformat {format} 1.0\nelement vertex 4294967295\nproperty float x\n\
             property float y\nproperty float z\nend_header\n"
        );
        let e = parse_mesh(head.as_bytes(), Format::Ply, path)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("big.ply") && e.contains("element vertex") && e.contains("data ends early"),
            "{e}"
        );
    }
    let empty_element = "ply\nformat ascii 1.0\nelement nothing 4294967295\n\
        element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let mesh = parse_mesh(empty_element.as_bytes(), Format::Ply, path).unwrap();
    assert_eq!((mesh.num_vertices(), mesh.num_faces()), (3, 1));
}

/// Found by fuzzing (fuzz/regressions/obj/read_obj_file-roundtrip-not-idempotent.obj):
/// a kept line ending in `\r\r\n` lost one `\r` per write → read round.
#[test]
fn lines_drop_every_carriage_return_at_their_end() {
    let text = b"# a\r\r\nv 0 0 0\r\n# b\r \r\n";
    let got: Vec<&[u8]> = lines(text).map(|(_, l)| l).collect();
    assert_eq!(got, [&b"# a"[..], b"v 0 0 0", b"# b\r "]);
}

/// Found by fuzzing (fuzz/regressions/ply/read_ply_file-header-comment-crs.ply):
/// a PLY header comment ending in `\r\r\n` lost one `\r` per write → read
/// round, as OBJ lines did; every `\r` before a header line's end goes.
#[test]
fn ply_header_lines_drop_every_carriage_return_at_their_end() {
    use crate::io::{FileWriteOptions, encode_mesh_file, parse_mesh_file};
    let path = Path::new("t.ply");
    let text = "ply\r\nformat ascii 1.0\r\ncomment a\r\r\r\nelement vertex 3\r\n\
                property float x\r\nproperty float y\r\nproperty float z\r\n\
                element face 1\r\nproperty list uchar int vertex_indices\r\r\n\
                end_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n";
    let file = parse_mesh_file(text.as_bytes(), Format::Ply, path).unwrap();
    let written =
        encode_mesh_file(&file.mesh, &file.attributes, &FileWriteOptions::default()).unwrap();
    let written = String::from_utf8(written).unwrap();
    assert!(written.contains("\ncomment a\n"), "{written}");
    assert!(!written.contains('\r'), "{written}");
}

/// Found by fuzzing (fuzz/regressions/ply/read_ply_file-ascii-float-beyond-f32.ply):
/// an ASCII value out of its property's type (1.5e119 in a `float`, 300 in
/// a `uchar`) is refused, not written back as infinity or wrapped; a
/// `float` written with more digits than an f32 keeps them through a write.
#[test]
fn ply_ascii_values_fit_their_types() {
    use crate::io::{FileWriteOptions, encode_mesh_file, parse_mesh_file};
    let path = Path::new("t.ply");
    let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nproperty uchar red\nelement face 1\n\
                property list uchar int vertex_indices\nend_header\n";
    let file = |first: &str| format!("{head}{first}\n1 0 0 0\n0 1 0 0\n3 0 1 2\n");
    for (first, want) in [
        ("0 1.5e119 0 0", "does not fit the property's type float"),
        ("0 0 0 300", "does not fit the property's type uchar"),
        ("0 0 0 -1", "does not fit the property's type uchar"),
    ] {
        let e = parse_mesh(file(first).as_bytes(), Format::Ply, path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.ply:11") && e.contains(want), "{e}");
    }
    // more digits than an f32 has; an f32 (55555552) whose shortest f32
    // digits (55555550) read as another double (fuzz/regressions/ply/
    // read_ply_file-f32-short-digits.ply); an f32 with short digits
    for (first, x) in [
        ("0.123456789012 0 0 255", 0.123456789012),
        ("55555552 0 0 255", 55555552.0),
        ("0.5 0 0 255", 0.5),
    ] {
        let read = parse_mesh_file(file(first).as_bytes(), Format::Ply, path).unwrap();
        assert_eq!(read.mesh.positions[0][0], x);
        let written =
            encode_mesh_file(&read.mesh, &read.attributes, &FileWriteOptions::default()).unwrap();
        let again = parse_mesh_file(&written, Format::Ply, path).unwrap();
        assert_eq!(again.mesh.positions, read.mesh.positions, "{first}");
        let text = String::from_utf8(written).unwrap();
        assert!(text.contains(&format!("\n{x} 0 0 255\n")), "{text}");
    }
}
