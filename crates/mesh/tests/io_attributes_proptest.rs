//! Property tests of the attribute-keeping readers and writers (issue 38):
//! random OBJ and PLY files with polygons, texture coordinates, normals,
//! colours, groups and extra properties; after moving every vertex, writing
//! and reading back, every attribute is as read and the positions are the
//! moved ones (bit-exact), whatever the polygons and the encoding.

use normalnet_mesh::io::attributes::{FormatAttributes, PlyColumn, PlyEncoding};
use normalnet_mesh::io::{FileWriteOptions, Format, encode_mesh_file, parse_mesh_file};
use proptest::prelude::*;
use std::fmt::Write;
use std::path::Path;

/// A random OBJ file: `nv` vertices (some with a colour), texture
/// coordinates, normals, polygons of 3 to 6 corners (each corner with or
/// without a texture / normal index) and group / material lines between them.
fn obj_strategy() -> impl Strategy<Value = String> {
    (3usize..12, 1usize..6, 1usize..4).prop_flat_map(|(nv, nt, nn)| {
        let corner = (
            0..nv,
            proptest::option::of(0..nt),
            proptest::option::of(0..nn),
        );
        let polygon = (
            proptest::collection::vec(corner, 3..7),
            proptest::option::of(0u8..3),
        );
        (
            proptest::collection::vec(
                (
                    [-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0],
                    any::<bool>(),
                ),
                nv,
            ),
            proptest::collection::vec([0.0f64..1.0, 0.0f64..1.0], nt),
            proptest::collection::vec(polygon, 1..10),
            Just(nn),
        )
            .prop_map(|(vertices, texture, polygons, nn)| {
                let mut s = String::from("# random\nmtllib lib.mtl\n");
                for (p, colour) in &vertices {
                    write!(s, "v {} {} {}", p[0], p[1], p[2]).unwrap();
                    if *colour {
                        s += " 0.25 0.5 1";
                    }
                    s += "\n";
                }
                for t in &texture {
                    writeln!(s, "vt {} {}", t[0], t[1]).unwrap();
                }
                for _ in 0..nn {
                    s += "vn 0 0 1\n";
                }
                for (corners, group) in &polygons {
                    match group {
                        Some(0) => s += "g part\n",
                        Some(1) => s += "usemtl shiny\n",
                        Some(_) => s += "s 1\n",
                        None => {}
                    }
                    s += "f";
                    for (v, t, n) in corners {
                        write!(s, " {}", v + 1).unwrap();
                        match (t, n) {
                            (None, None) => {}
                            (Some(t), None) => write!(s, "/{}", t + 1).unwrap(),
                            (None, Some(n)) => write!(s, "//{}", n + 1).unwrap(),
                            (Some(t), Some(n)) => write!(s, "/{}/{}", t + 1, n + 1).unwrap(),
                        }
                    }
                    s += "\n";
                }
                s
            })
    })
}

/// A random PLY file: float positions, a uchar colour, a custom double and
/// an int list per vertex; polygons with a per-face short; in any encoding
/// (built as ASCII, re-encoded by the writer).
fn ply_strategy() -> impl Strategy<Value = (String, PlyEncoding)> {
    (3usize..12).prop_flat_map(|nv| {
        (
            proptest::collection::vec(
                (
                    [-100i32..100, -100i32..100, -100i32..100],
                    0u8..=255,
                    any::<f64>().prop_filter("finite", |x| x.is_finite()),
                    proptest::collection::vec(any::<i32>(), 0..4),
                ),
                nv,
            ),
            proptest::collection::vec(
                (proptest::collection::vec(0..nv, 3..7), any::<i16>()),
                1..8,
            ),
            prop_oneof![
                Just(PlyEncoding::Ascii),
                Just(PlyEncoding::BinaryLittleEndian),
                Just(PlyEncoding::BinaryBigEndian)
            ],
        )
            .prop_map(|(vertices, faces, encoding)| {
                let mut s = format!(
                    "ply\nformat ascii 1.0\ncomment random\nelement vertex {}\nproperty float x\n\
                     property float y\nproperty float z\nproperty uchar red\nproperty double quality\n\
                     property list uchar int tags\nelement face {}\n\
                     property list uchar int vertex_indices\nproperty short label\nend_header\n",
                    vertices.len(),
                    faces.len()
                );
                for (p, red, quality, tags) in &vertices {
                    write!(s, "{} {} {} {red} {quality:e} {}", p[0] as f32 / 8.0, p[1], p[2], tags.len())
                        .unwrap();
                    for t in tags {
                        write!(s, " {t}").unwrap();
                    }
                    s += "\n";
                }
                for (corners, label) in &faces {
                    write!(s, "{}", corners.len()).unwrap();
                    for c in corners {
                        write!(s, " {c}").unwrap();
                    }
                    writeln!(s, " {label}").unwrap();
                }
                (s, encoding)
            })
    })
}

/// Every position moved by `delta` times a vertex-dependent factor, kept
/// f32-exact (so a `float` PLY holds them bit for bit).
fn moved(mesh: &normalnet_mesh::Mesh, delta: f32) -> normalnet_mesh::Mesh {
    let mut m = mesh.clone();
    for (v, p) in m.positions.iter_mut().enumerate() {
        for (k, x) in p.iter_mut().enumerate() {
            *x = (*x as f32 + delta * ((v + k) % 4) as f32) as f64;
        }
    }
    m
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn obj_attributes_survive_moved_positions(
        text in obj_strategy(),
        delta in -1.0f32..1.0,
        triangulate in any::<bool>(),
    ) {
        let path = Path::new("random.obj");
        let file = parse_mesh_file(text.as_bytes(), Format::Obj, path).unwrap();
        let denoised = moved(&file.mesh, delta);
        let options = FileWriteOptions { triangulate, ply_ascii: false };
        let out = encode_mesh_file(&denoised, &file.attributes, &options).unwrap();
        let again = parse_mesh_file(&out, Format::Obj, path).unwrap();
        prop_assert_eq!(&again.mesh, &denoised);
        let (FormatAttributes::Obj(a), FormatAttributes::Obj(b)) =
            (&file.attributes.content, &again.attributes.content) else { unreachable!() };
        prop_assert_eq!(&b.vertex_tails, &a.vertex_tails);
        prop_assert_eq!(&b.texture_coords, &a.texture_coords);
        prop_assert_eq!(b.normals.len(), a.normals.len());
        for n in &b.normals {
            let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
            prop_assert!(len2 == 0.0 || (len2 - 1.0).abs() < 1e-9, "normal {:?}", n);
        }
        if triangulate {
            prop_assert!(again.attributes.polygon_sizes.iter().all(|&n| n == 3));
            // each triangle's corners carry the indices of its polygon's corners
            let fan = |corners: &[u32]| -> Vec<u32> {
                let mut out = Vec::new();
                let mut at = 0;
                for &n in &file.attributes.polygon_sizes {
                    let c = &corners[at..at + n as usize];
                    for i in 1..c.len() - 1 {
                        out.extend([c[0], c[i], c[i + 1]]);
                    }
                    at += n as usize;
                }
                out
            };
            if !a.corner_texture_coords.is_empty() {
                prop_assert_eq!(&b.corner_texture_coords, &fan(&a.corner_texture_coords));
            }
            if !a.corner_normals.is_empty() {
                prop_assert_eq!(&b.corner_normals, &fan(&a.corner_normals));
            }
        } else {
            prop_assert_eq!(&again.attributes.polygon_sizes, &file.attributes.polygon_sizes);
            prop_assert_eq!(&b.statements, &a.statements);
            prop_assert_eq!(&b.corner_texture_coords, &a.corner_texture_coords);
            prop_assert_eq!(&b.corner_normals, &a.corner_normals);
        }
    }

    #[test]
    fn ply_properties_survive_moved_positions_in_every_encoding(
        (text, encoding) in ply_strategy(),
        delta in -1.0f32..1.0,
    ) {
        let path = Path::new("random.ply");
        let ascii = parse_mesh_file(text.as_bytes(), Format::Ply, path).unwrap();
        let mut attributes = ascii.attributes.clone();
        let FormatAttributes::Ply(p) = &mut attributes.content else { unreachable!() };
        p.encoding = encoding;
        let bytes = encode_mesh_file(&ascii.mesh, &attributes, &FileWriteOptions::default()).unwrap();
        let file = parse_mesh_file(&bytes, Format::Ply, path).unwrap();
        prop_assert_eq!(&file.attributes.content, &attributes.content);
        let denoised = moved(&file.mesh, delta);
        let out = encode_mesh_file(&denoised, &file.attributes, &FileWriteOptions::default()).unwrap();
        let again = parse_mesh_file(&out, Format::Ply, path).unwrap();
        // `float` x y z: binary holds the f32 bits; ASCII prints the f32's
        // shortest decimal, which the reader takes as an f64 near it
        let f32s = |m: &normalnet_mesh::Mesh| -> Vec<[f32; 3]> {
            m.positions.iter().map(|p| p.map(|x| x as f32)).collect()
        };
        prop_assert_eq!(f32s(&again.mesh), f32s(&denoised));
        prop_assert_eq!(&again.mesh.faces, &denoised.faces);
        prop_assert_eq!(&again.attributes, &file.attributes);
        let FormatAttributes::Ply(p) = &again.attributes.content else { unreachable!() };
        prop_assert!(matches!(p.elements[0].properties[4].column, PlyColumn::Scalars(_)));
    }
}
