//! The property every reader target checks: parsing arbitrary bytes returns
//! `Ok` or `Err` without panicking, and a mesh it accepts survives a write →
//! read round trip in the same format (bit-exact coordinates for OBJ, OFF and
//! PLY; STL stores f32, so there only the triangle count and the f32 values).

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
        Format::Stl => {
            assert_eq!(again.num_faces(), mesh.num_faces());
            for f in 0..mesh.num_faces() {
                let a = mesh.corners(f).map(|p| p.map(|x| x as f32));
                let b = again.corners(f).map(|p| p.map(|x| x as f32));
                assert_eq!(a, b, "STL round trip changed face {f}");
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
