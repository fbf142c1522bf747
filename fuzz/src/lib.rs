//! The property every reader target checks: parsing arbitrary bytes returns
//! `Ok` or `Err` without panicking, and a mesh it accepts survives a write →
//! read round trip in the same format (bit-exact coordinates for OBJ, OFF and
//! PLY; STL and glTF store f32, so there only the triangle count and the f32
//! values).

use normalnet_mesh::io::{Format, WriteOptions, encode_mesh, parse_mesh};
use std::path::Path;

/// Parses `bytes` as `format`; on success re-encodes and re-reads the mesh
/// and panics (a fuzz failure) if the round trip changes it.
pub fn check_reader(bytes: &[u8], format: Format) {
    let path = Path::new("fuzz-input");
    let Ok(mesh) = parse_mesh(bytes, format, path) else {
        return;
    };
    assert!(mesh.num_faces() > 0 && !mesh.positions.is_empty());
    assert!(mesh.positions.iter().flatten().all(|x| x.is_finite()));
    let encoded = encode_mesh(&mesh, format, &WriteOptions::default())
        .unwrap_or_else(|e| panic!("a mesh the reader accepted cannot be written: {e}"));
    let again = parse_mesh(&encoded, format, path)
        .unwrap_or_else(|e| panic!("a mesh the reader accepted does not read back: {e}"));
    match format {
        Format::Stl | Format::Gltf | Format::Glb => {
            assert_eq!(again.num_faces(), mesh.num_faces());
            for f in 0..mesh.num_faces() {
                let a = mesh.corners(f).map(|p| p.map(|x| x as f32));
                let b = again.corners(f).map(|p| p.map(|x| x as f32));
                assert_eq!(a, b, "f32 round trip changed face {f}");
            }
        }
        _ => {
            assert_eq!(again.faces, mesh.faces, "faces changed in the round trip");
            let bits = |m: &normalnet_mesh::Mesh| -> Vec<u64> {
                m.positions.iter().flatten().map(|x| x.to_bits()).collect()
            };
            assert_eq!(bits(&again), bits(&mesh), "coordinates changed in the round trip");
        }
    }
}

/// Parses `bytes` with the attribute-keeping reader (`parse_mesh_file`) and
/// panics (a fuzz failure) unless: its mesh is the one `parse_mesh` reads;
/// a mesh it accepts encodes with its attributes (`encode_mesh_file`), that
/// encoding reads back with the same mesh (bit-exact positions, same faces
/// and polygons), and encoding it again gives the same bytes (nothing the
/// reader keeps is lost or changed by a second round).
pub fn check_file_reader(bytes: &[u8], format: Format) {
    use normalnet_mesh::io::{FileWriteOptions, encode_mesh_file, parse_mesh_file};
    let path = Path::new("fuzz-input");
    let plain = parse_mesh(bytes, format, path);
    let Ok(file) = parse_mesh_file(bytes, format, path) else {
        // the attribute reader is stricter (vt / vn must be numbers and
        // their indices in range), never more lenient
        return;
    };
    assert_eq!(
        plain.as_ref().ok(),
        Some(&file.mesh),
        "parse_mesh_file read another mesh than parse_mesh"
    );
    let options = FileWriteOptions::default();
    let encoded = encode_mesh_file(&file.mesh, &file.attributes, &options)
        .unwrap_or_else(|e| panic!("a file the reader accepted cannot be written: {e}"));
    let again = parse_mesh_file(&encoded, format, path)
        .unwrap_or_else(|e| panic!("a file the reader accepted does not read back: {e}"));
    assert_eq!(again.mesh.faces, file.mesh.faces, "faces changed");
    assert_eq!(
        again.attributes.polygon_sizes, file.attributes.polygon_sizes,
        "polygons changed"
    );
    if format != Format::Stl {
        let bits = |m: &normalnet_mesh::Mesh| -> Vec<u64> {
            m.positions.iter().flatten().map(|x| x.to_bits()).collect()
        };
        assert_eq!(bits(&again.mesh), bits(&file.mesh), "coordinates changed");
    }
    let twice = encode_mesh_file(&again.mesh, &again.attributes, &options)
        .unwrap_or_else(|e| panic!("the written file cannot be written again: {e}"));
    assert!(twice == encoded, "a second write → read → write changed the file");
}

/// glTF: every per-corner attribute the reader gives (`TEXCOORD_0`,
/// `COLOR_0`) written back unchanged with `set_corner_values` reads back
/// as the same values; the setter refuses only non-finite ones.
pub fn check_gltf_corner_values(bytes: &[u8]) {
    use normalnet_mesh::io::attributes::FormatAttributes;
    use normalnet_mesh::io::parse_mesh_file;
    let Ok(file) = parse_mesh_file(bytes, Format::Glb, Path::new("fuzz-input")) else {
        return;
    };
    let FormatAttributes::Gltf(gltf) = &file.attributes.content else {
        return;
    };
    for attribute in ["TEXCOORD_0", "COLOR_0"] {
        let Ok(Some(read)) = gltf.corner_values(attribute) else {
            continue;
        };
        let mut edited = gltf.clone();
        let set = edited.set_corner_values(attribute, &read.values);
        if read.values.iter().flatten().any(|v| !v.is_finite()) {
            assert!(set.is_err(), "{attribute}: a non-finite value was stored");
            continue;
        }
        set.unwrap_or_else(|e| panic!("{attribute}: the values read cannot be written back: {e}"));
        let again = edited.corner_values(attribute).expect("readable").expect("present");
        assert_eq!(again, read, "{attribute}: written back, read otherwise");
    }
}
