//! Issue 38: a file read with `read_mesh_file` and written back with
//! `write_mesh_file` keeps everything it carries. Per format: unchanged
//! positions give the same file (modulo float formatting); moved positions
//! leave every attribute array as read; normals are recomputed.

use normalnet_mesh::io::attributes::{
    FormatAttributes, ObjAttributes, OffAttributes, PlyAttributes, PlyEncoding, StlAttributes,
    StlEncoding,
};
use normalnet_mesh::io::{
    Attributes, FileWriteOptions, Format, MeshFile, encode_mesh_file, parse_mesh_file,
    read_mesh_file, write_mesh_file,
};
use normalnet_mesh::{Mesh, read_mesh};
use std::path::{Path, PathBuf};

fn parse(text: &[u8], format: Format) -> MeshFile {
    parse_mesh_file(text, format, Path::new("test")).unwrap()
}

fn encode(file: &MeshFile, mesh: &Mesh, options: FileWriteOptions) -> Vec<u8> {
    encode_mesh_file(mesh, &file.attributes, &options).unwrap()
}

/// `mesh` with every vertex moved by a small, vertex-dependent offset in z
/// (a flat mesh stays flat enough that its normals keep pointing up).
fn moved(mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    for (v, p) in m.positions.iter_mut().enumerate() {
        p[2] += 0.01 * (v % 3) as f64;
        p[0] += 0.001 * v as f64;
    }
    m
}

fn obj(attributes: &Attributes) -> &ObjAttributes {
    match &attributes.content {
        FormatAttributes::Obj(o) => o,
        other => panic!("not OBJ: {other:?}"),
    }
}

fn ply(attributes: &Attributes) -> &PlyAttributes {
    match &attributes.content {
        FormatAttributes::Ply(p) => p,
        other => panic!("not PLY: {other:?}"),
    }
}

/// Two unit quads in z = 0 and a triangle, with colours, texture
/// coordinates, normals, a material library, objects, groups, smoothing
/// groups and comments, written the way our writer formats numbers: the
/// normals are what the writer recomputes (0 0 1 on a flat surface), so the
/// file comes back byte for byte.
const OBJ_FULL: &str = "\
# exported by hand
mtllib scene.mtl
o plate
v 0 0 0 1 0 0
v 1 0 0 0 1 0
v 2 0 0 0 0 1
v 0 1 0 0.5 0.5 0.5
v 1 1 0 1 1 1
v 2 1 0 0 0 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
g left
usemtl red
s 1
f 1/1/1 2/2/1 5/3/1 4/4/1
g right
usemtl blue
s off
f 2/1/1 3/2/1 6/3/1 5/4/1
f 1//1 2//1 5//1
f 4/1 5/2 6/3
l 1 2
";

#[test]
fn obj_unchanged_positions_give_the_same_file() {
    let file = parse(OBJ_FULL.as_bytes(), Format::Obj);
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    assert_eq!(file.attributes.polygon_sizes, vec![4, 4, 3, 3]);
    assert_eq!(file.mesh.num_faces(), 6);
    let out = encode(&file, &file.mesh, FileWriteOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), OBJ_FULL);
    // the mesh is what read_mesh reads
    let plain = normalnet_mesh::io::parse_mesh(OBJ_FULL.as_bytes(), Format::Obj, Path::new("t"));
    assert_eq!(plain.unwrap(), file.mesh);
}

#[test]
fn obj_moved_positions_keep_every_attribute() {
    let file = parse(OBJ_FULL.as_bytes(), Format::Obj);
    let denoised = moved(&file.mesh);
    let out = encode(&file, &denoised, FileWriteOptions::default());
    let again = parse(&out, Format::Obj);
    assert_eq!(again.mesh, denoised);
    assert_eq!(
        again.attributes.polygon_sizes,
        file.attributes.polygon_sizes
    );
    let (a, b) = (obj(&file.attributes), obj(&again.attributes));
    assert_eq!(b.statements, a.statements);
    assert_eq!(b.vertex_tails, a.vertex_tails);
    assert_eq!(b.texture_coords, a.texture_coords);
    assert_eq!(b.corner_texture_coords, a.corner_texture_coords);
    assert_eq!(b.corner_normals, a.corner_normals);
    assert_eq!(b.vertex_colors().unwrap()[0], [1.0, 0.0, 0.0]);
    assert_eq!(b.material_libraries(), vec!["scene.mtl"]);
    // the one normal, recomputed: unit, pointing up, no longer exactly z
    let n = b.normals[0];
    assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1.0).abs() < 1e-12);
    assert!(n[2] > 0.9 && n != [0.0, 0.0, 1.0], "{n:?}");
}

#[test]
fn obj_normals_are_area_weighted_per_vn_slot() {
    // two triangles folded along the x axis, one vn per vertex: the shared
    // vertices' normals are the area-weighted mean of both faces
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -2 1\nvn 9 9 9\nvn 9 9 9\nvn 9 9 9\nvn 9 9 9\n\
                f 1//1 2//2 3//3\nf 2//2 1//1 4//4\n";
    let file = parse(text.as_bytes(), Format::Obj);
    let out = encode(&file, &file.mesh, FileWriteOptions::default());
    let again = parse(&out, Format::Obj);
    let normals = &obj(&again.attributes).normals;
    let want = normalnet_mesh::geometry::area_weighted_vertex_normals(&file.mesh);
    for (v, (n, w)) in normals.iter().zip(&want).enumerate() {
        for k in 0..3 {
            assert!((n[k] - w[k]).abs() < 1e-12, "vertex {v}: {n:?} vs {w:?}");
        }
    }
    // vertex 2 (only on the flat face) points along +z
    assert!((normals[2][2] - 1.0).abs() < 1e-12);
}

#[test]
fn obj_quads_come_back_as_quads_or_triangles() {
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nvt 0 0\nvt 1 1\n\
                f 1/1 2/2 3/1 4/2\nf 2 5 3\n";
    let file = parse(text.as_bytes(), Format::Obj);
    let out = String::from_utf8(encode(&file, &file.mesh, FileWriteOptions::default())).unwrap();
    assert!(out.contains("f 1/1 2/2 3/1 4/2\nf 2 5 3\n"), "{out}");
    let tri = FileWriteOptions {
        triangulate: true,
        ..FileWriteOptions::default()
    };
    let out = String::from_utf8(encode(&file, &file.mesh, tri)).unwrap();
    assert!(
        out.contains("f 1/1 2/2 3/1\nf 1/1 3/1 4/2\nf 2 5 3\n"),
        "{out}"
    );
    let again = parse(out.as_bytes(), Format::Obj);
    assert_eq!(again.mesh, file.mesh);
    assert_eq!(again.attributes.polygon_sizes, vec![3, 3, 3]);
}

#[test]
fn obj_relative_and_forward_indices_are_resolved() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n";
    let file = parse(text.as_bytes(), Format::Obj);
    assert_eq!(obj(&file.attributes).corner_texture_coords, vec![0, 1, 2]);
    let out = String::from_utf8(encode(&file, &file.mesh, FileWriteOptions::default())).unwrap();
    assert!(out.ends_with("f 1/1 2/2 3/3\n"), "{out}");
}

#[test]
fn obj_bad_attribute_indices_name_the_line() {
    let cases: &[(&str, &str)] = &[
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n",
            "test:5: refers to texture coordinate 2 but the file has 1",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//0\n",
            "test:5: face 0: bad normal index \"0\"",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 x\nf 1 2 3\n",
            "test:4: texture coordinate: bad number \"x\"",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 1\nf 1 2 3\n",
            "test:4: normal has 2 values",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-2 2/1 3/1\n",
            "test:5: face 0: texture coordinate index -2 out of range",
        ),
    ];
    for (text, want) in cases {
        let e = parse_mesh_file(text.as_bytes(), Format::Obj, Path::new("test")).unwrap_err();
        assert!(e.to_string().contains(want), "{text:?}: {e}");
        // read_mesh ignores these statements and still reads the mesh
        assert!(
            normalnet_mesh::io::parse_mesh(text.as_bytes(), Format::Obj, Path::new("t")).is_ok()
        );
    }
}

/// A fresh folder under the system's temporary folder.
fn temp_dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

#[test]
fn obj_material_library_is_rewritten_relative_to_the_output() {
    let root = temp_dir();
    let input_dir = root.path().join("scans");
    let output_dir = root.path().join("out/denoised");
    std::fs::create_dir_all(&input_dir).unwrap();
    std::fs::create_dir_all(&output_dir).unwrap();
    std::fs::write(input_dir.join("scene.mtl"), "newmtl red\nmap_Kd red.png\n").unwrap();
    let input = input_dir.join("plate.obj");
    std::fs::write(&input, OBJ_FULL).unwrap();
    let file = read_mesh_file(&input).unwrap();
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    // another folder: the name now reaches the library from there
    let output = output_dir.join("plate.obj");
    let warnings = write_mesh_file(
        &output,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let text = std::fs::read_to_string(&output).unwrap();
    assert!(text.contains("\nmtllib ../../scans/scene.mtl\n"), "{text}");
    let again = read_mesh_file(&output).unwrap();
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
    // the same folder: the name as written
    let beside = input_dir.join("plate-denoised.obj");
    write_mesh_file(
        &beside,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(std::fs::read_to_string(&beside).unwrap(), OBJ_FULL);
}

#[test]
fn obj_missing_material_library_is_a_warning() {
    let root = temp_dir();
    let input = root.path().join("plate.obj");
    std::fs::write(&input, OBJ_FULL).unwrap();
    let file = read_mesh_file(&input).unwrap();
    assert_eq!(file.warnings.len(), 1, "{:?}", file.warnings);
    assert!(
        file.warnings[0].contains("\"scene.mtl\" not found"),
        "{:?}",
        file.warnings
    );
}

#[test]
fn writing_another_format_keeps_the_mesh_and_warns() {
    let root = temp_dir();
    let file = parse(OBJ_FULL.as_bytes(), Format::Obj);
    let output = root.path().join("plate.ply");
    let warnings = write_mesh_file(
        &output,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].contains("texture coordinates"), "{warnings:?}");
    assert_eq!(read_mesh(&output).unwrap(), file.mesh);
}

#[test]
fn a_mesh_of_other_counts_is_refused() {
    let file = parse(OBJ_FULL.as_bytes(), Format::Obj);
    let other = Mesh::height_grid(2, |_, _| 0.0);
    let e = encode_mesh_file(&other, &file.attributes, &FileWriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("9 vertices and 8 faces"), "{e}");
    let mut broken = file.attributes.clone();
    broken.polygon_sizes[0] = 2;
    let e = encode_mesh_file(&file.mesh, &broken, &FileWriteOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("polygon 0 of the attributes has 2 corners"),
        "{e}"
    );
}

/// A PLY file with vertex colours, normals, a custom quality, a vertex
/// list, face colours, an extra element and comments; numbers formatted as
/// our writer formats them.
const PLY_FULL: &str = "\
ply
format ascii 1.0
comment made by hand
element vertex 4
property float x
property float y
property float z
property float nx
property float ny
property float nz
property uchar red
property uchar green
property uchar blue
property double quality
property list uchar short neighbours
element face 2
property list uchar int vertex_indices
property uchar red
property int label
obj_info origin test
element edge 1
property int vertex1
property int vertex2
end_header
0 0 0 0 0 1 255 0 0 0.25 2 1 3
1 0 0 0 0 1 0 255 0 -1.5 0
1 1 0 0 0 1 0 0 255 0.001 1 -4
0 1 0 0 0 1 10 20 30 3 3 0 1 2
4 0 1 2 3 200 -7
3 1 2 3 100 8
0 2
";

#[test]
fn ply_ascii_unchanged_positions_give_the_same_file() {
    let file = parse(PLY_FULL.as_bytes(), Format::Ply);
    assert_eq!(file.attributes.polygon_sizes, vec![4, 3]);
    let out = encode(&file, &file.mesh, FileWriteOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), PLY_FULL);
    let p = ply(&file.attributes);
    assert_eq!(
        p.scalars("vertex", "red").unwrap(),
        &[255.0, 0.0, 0.0, 10.0]
    );
    assert_eq!(p.scalars("face", "label").unwrap(), &[-7.0, 8.0]);
}

#[test]
fn ply_binary_both_endians_keep_every_property() {
    let ascii = parse(PLY_FULL.as_bytes(), Format::Ply);
    for encoding in [
        PlyEncoding::BinaryLittleEndian,
        PlyEncoding::BinaryBigEndian,
    ] {
        let mut attributes = ascii.attributes.clone();
        let FormatAttributes::Ply(p) = &mut attributes.content else {
            unreachable!()
        };
        p.encoding = encoding;
        let binary =
            encode_mesh_file(&ascii.mesh, &attributes, &FileWriteOptions::default()).unwrap();
        let file = parse(&binary, Format::Ply);
        assert_eq!(file.mesh, ascii.mesh);
        assert_eq!(
            &file.attributes.content, &attributes.content,
            "{encoding:?}"
        );
        // read → write gives the same bytes
        assert_eq!(
            encode(&file, &file.mesh, FileWriteOptions::default()),
            binary
        );
        // moved positions: every other property as read, normals recomputed
        let denoised = moved(&file.mesh);
        let out = encode(&file, &denoised, FileWriteOptions::default());
        let again = parse(&out, Format::Ply);
        let f32_positions: Vec<[f64; 3]> = denoised
            .positions
            .iter()
            .map(|p| p.map(|x| x as f32 as f64))
            .collect();
        assert_eq!(
            again.mesh.positions, f32_positions,
            "float x y z stay float"
        );
        assert_eq!(again.mesh.faces, denoised.faces);
        for (a, b) in ply(&again.attributes)
            .elements
            .iter()
            .zip(&p_elements(&file))
        {
            assert_eq!(a, b);
        }
        // and ASCII on request
        let text = encode(
            &file,
            &file.mesh,
            FileWriteOptions {
                ply_ascii: true,
                ..FileWriteOptions::default()
            },
        );
        assert_eq!(String::from_utf8(text).unwrap(), PLY_FULL);
    }
}

fn p_elements(file: &MeshFile) -> Vec<normalnet_mesh::io::attributes::PlyElement> {
    ply(&file.attributes).elements.clone()
}

#[test]
fn ply_normals_are_recomputed_and_triangulation_repeats_face_properties() {
    let file = parse(PLY_FULL.as_bytes(), Format::Ply);
    let mut tilted = file.mesh.clone();
    tilted.positions[2][2] = 1.0;
    tilted.positions[3][2] = 1.0;
    let out = encode(
        &file,
        &tilted,
        FileWriteOptions {
            triangulate: true,
            ply_ascii: true,
        },
    );
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("element face 3\n"), "{text}");
    assert!(
        text.contains("\n3 0 1 2 200 -7\n3 0 2 3 200 -7\n3 1 2 3 100 8\n"),
        "{text}"
    );
    let again = parse(text.as_bytes(), Format::Ply);
    let p = ply(&again.attributes);
    let nz = p.elements[0].properties[5].clone();
    assert_eq!(nz.name, "nz");
    // the plane tilted by 45°: nz = cos 45° at the vertices of the quad
    let line = text.lines().find(|l| l.starts_with("0 0 0 ")).unwrap();
    let n: Vec<f32> = line
        .split(' ')
        .skip(3)
        .take(3)
        .map(|t| t.parse().unwrap())
        .collect();
    assert!(
        (n[2] - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-5,
        "{line}"
    );
    assert!(
        (n[1] + std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-5,
        "{line}"
    );
}

/// The shared data folder (`../shared/data` beside the workspace), if present.
fn data() -> Option<PathBuf> {
    let d = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"));
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("SKIP: {} not found", d.display());
        None
    }
}

#[test]
fn iron_ply_keeps_its_value_property_byte_for_byte() {
    let Some(d) = data() else { return };
    let path = d.join("gd/RealData/iron/iron.ply");
    if !path.is_file() {
        eprintln!("SKIP: {} not found", path.display());
        return;
    }
    let bytes = std::fs::read(&path).unwrap();
    let file = read_mesh_file(&path).unwrap();
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    assert_eq!(file.mesh, read_mesh(&path).unwrap());
    let values = ply(&file.attributes)
        .scalars("vertex", "value")
        .unwrap()
        .to_vec();
    assert_eq!(values.len(), file.mesh.num_vertices());
    assert_eq!(
        encode(&file, &file.mesh, FileWriteOptions::default()),
        bytes
    );
    let out = encode(&file, &moved(&file.mesh), FileWriteOptions::default());
    let again = parse(&out, Format::Ply);
    assert_eq!(
        ply(&again.attributes).scalars("vertex", "value").unwrap(),
        values
    );
    assert_eq!(
        ply(&again.attributes).encoding,
        PlyEncoding::BinaryLittleEndian
    );
}

/// A binary STL of two triangles with attribute bytes 0x1234 and 0xBEEF.
fn binary_stl() -> Vec<u8> {
    let mut b = vec![b'x'; 80];
    b[..12].copy_from_slice(b"COLOR=\x10\x20\x30\x40 x");
    b.extend_from_slice(&2u32.to_le_bytes());
    let tris: [[[f32; 3]; 3]; 2] = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    ];
    for (t, attribute) in tris.iter().zip([0x1234u16, 0xBEEF]) {
        let [p, q, r] = t.map(|p| p.map(f64::from));
        // the normal the writer computes (its signs of zero included)
        for x in normalnet_mesh::geometry::triangle_normal(p, q, r).map(|x| x as f32) {
            b.extend_from_slice(&x.to_le_bytes());
        }
        for p in t {
            for x in p {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        b.extend_from_slice(&attribute.to_le_bytes());
    }
    b
}

fn stl(attributes: &Attributes) -> &StlAttributes {
    match &attributes.content {
        FormatAttributes::Stl(s) => s,
        other => panic!("not STL: {other:?}"),
    }
}

#[test]
fn stl_binary_keeps_header_and_attribute_bytes() {
    let bytes = binary_stl();
    let file = parse(&bytes, Format::Stl);
    assert_eq!(stl(&file.attributes).facet_attributes, vec![0x1234, 0xBEEF]);
    assert_eq!(
        encode(&file, &file.mesh, FileWriteOptions::default()),
        bytes
    );
    let out = encode(&file, &moved(&file.mesh), FileWriteOptions::default());
    let again = parse(&out, Format::Stl);
    assert_eq!(stl(&again.attributes), stl(&file.attributes));
    assert_eq!(&out[..80], &bytes[..80]);
}

#[test]
fn stl_padding_dropped_is_a_warning() {
    let mut bytes = binary_stl();
    bytes.extend_from_slice(&[0; 7]);
    let file = parse(&bytes, Format::Stl);
    assert_eq!(file.warnings.len(), 1, "{:?}", file.warnings);
    assert!(
        file.warnings[0].contains("7 bytes of padding"),
        "{:?}",
        file.warnings
    );
    assert_eq!(
        encode(&file, &file.mesh, FileWriteOptions::default()),
        binary_stl()
    );
}

#[test]
fn stl_ascii_keeps_its_solid_name_and_polygon_facets() {
    let text = "solid part 7\nfacet normal 0 0 1\n  outer loop\n    vertex 0 0 0\n    vertex 1 0 0\n    \
                vertex 1 1 0\n    vertex 0 1 0\n  endloop\nendfacet\nendsolid part 7\n";
    let file = parse(text.as_bytes(), Format::Stl);
    assert_eq!(
        stl(&file.attributes).encoding,
        StlEncoding::Ascii {
            name: "part 7".into()
        }
    );
    let out = encode(&file, &file.mesh, FileWriteOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), text);
}

#[test]
fn off_keeps_keyword_polygons_and_colours() {
    let text = "COFF\n4 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n0 1 0 9 9 9 255\n\
                4 0 1 2 3 0.5 0.5 0.5\n";
    let file = parse(text.as_bytes(), Format::Off);
    assert!(file.warnings.is_empty());
    let out = encode(&file, &file.mesh, FileWriteOptions::default());
    assert_eq!(String::from_utf8(out).unwrap(), text);
    let out = encode(&file, &moved(&file.mesh), FileWriteOptions::default());
    let again = parse(&out, Format::Off);
    let off = |f: &MeshFile| -> OffAttributes {
        match &f.attributes.content {
            FormatAttributes::Off(o) => o.clone(),
            _ => unreachable!(),
        }
    };
    assert_eq!(off(&again), off(&file));
}

#[test]
fn off_comments_dropped_are_a_warning() {
    let text = "OFF # header\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let file = parse(text.as_bytes(), Format::Off);
    assert_eq!(file.warnings.len(), 1);
    assert!(
        file.warnings[0].contains("1 comment lines dropped"),
        "{:?}",
        file.warnings
    );
}

/// Written in another format, a file warns with what it actually held,
/// and a file that held nothing beyond positions and triangles does not warn.
#[test]
fn a_format_change_names_what_the_input_held_and_only_that() {
    let dir = temp_dir();
    let full = parse(OBJ_FULL.as_bytes(), Format::Obj);
    let warnings = write_mesh_file(
        dir.path().join("full.ply"),
        &full.mesh,
        &full.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    for held in [
        "polygons",
        "texture coordinates",
        "normals",
        "materials",
        "groups and objects",
        "smoothing groups",
        "vertex colours",
    ] {
        assert!(warnings[0].contains(held), "{held}: {}", warnings[0]);
    }
    let plain = parse(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# a comment\nf 1 2 3\n",
        Format::Obj,
    );
    let warnings = write_mesh_file(
        dir.path().join("plain.ply"),
        &plain.mesh,
        &plain.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let quad = parse(
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
        Format::Obj,
    );
    let warnings = write_mesh_file(
        dir.path().join("quad.stl"),
        &quad.mesh,
        &quad.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0].ends_with("the input's polygons dropped"),
        "{}",
        warnings[0]
    );
}
