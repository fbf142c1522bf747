//! Property tests of the readers and writers: round trips through every
//! format (bit-exact where the format allows) and parsers fed random or
//! mutated bytes (they must return `Ok` or `Err`, never panic).

use normalnet_mesh::Mesh;
use normalnet_mesh::io::{Format, WriteOptions, encode_mesh, parse_mesh};
use proptest::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Random meshes: finite coordinates of any magnitude, random faces
/// (degenerate and repeated-index faces included), every vertex used.
fn mesh_strategy(f32_only: bool) -> impl Strategy<Value = Mesh> {
    let coord = if f32_only {
        any::<f32>()
            .prop_filter("finite", |x| x.is_finite())
            .prop_map(|x| x as f64)
            .boxed()
    } else {
        prop_oneof![
            any::<f64>().prop_filter("finite", |x| x.is_finite()),
            -10.0f64..10.0,
            Just(0.0),
            Just(-0.0),
        ]
        .boxed()
    };
    (3usize..40).prop_flat_map(move |nv| {
        (
            proptest::collection::vec([coord.clone(), coord.clone(), coord.clone()], nv),
            proptest::collection::vec([0..nv as u32, 0..nv as u32, 0..nv as u32], 1..60),
        )
            .prop_map(|(p, mut f)| {
                // Make every vertex referenced so that order is observable.
                let nv = p.len() as u32;
                for v in 0..nv {
                    f.push([v, (v + 1) % nv, (v + 2) % nv]);
                }
                Mesh::new(p, f).unwrap()
            })
    })
}

fn bit_equal(a: &Mesh, b: &Mesh) -> bool {
    a.faces == b.faces
        && a.positions.len() == b.positions.len()
        && a.positions
            .iter()
            .zip(&b.positions)
            .all(|(p, q)| (0..3).all(|k| p[k].to_bits() == q[k].to_bits()))
}

/// Geometry of the triangles, as bit patterns (order-independent of indices).
fn triangles(m: &Mesh) -> Vec<[[u64; 3]; 3]> {
    (0..m.num_faces())
        .map(|f| m.corners(f).map(|p| p.map(f64::to_bits)))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn text_and_binary_round_trips_are_bit_exact(m in mesh_strategy(false)) {
        for (f, ascii) in [(Format::Obj, false), (Format::Off, false), (Format::Ply, false), (Format::Ply, true)] {
            let bytes = encode_mesh(&m, f, &WriteOptions { ply_ascii: ascii }).unwrap();
            let back = parse_mesh(&bytes, f, Path::new("p")).unwrap();
            prop_assert!(bit_equal(&back, &m), "{:?} ascii={}", f, ascii);
        }
    }

    #[test]
    fn stl_round_trip_keeps_geometry(m in mesh_strategy(true)) {
        let bytes = encode_mesh(&m, Format::Stl, &WriteOptions::default()).unwrap();
        let back = parse_mesh(&bytes, Format::Stl, Path::new("p.stl")).unwrap();
        prop_assert_eq!(triangles(&back), triangles(&m));
        // Merging is by bit pattern: as many vertices as distinct used positions.
        let mut distinct = HashMap::new();
        for t in &m.faces { for &v in t { distinct.insert(m.positions[v as usize].map(f64::to_bits), ()); } }
        prop_assert_eq!(back.num_vertices(), distinct.len());
    }

    #[test]
    fn parsers_never_panic_on_random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        for f in [Format::Obj, Format::Off, Format::Ply, Format::Stl] {
            let _ = parse_mesh(&bytes, f, Path::new("r"));
        }
    }

    #[test]
    fn parsers_never_panic_on_mutated_files(
        m in mesh_strategy(false),
        which in 0usize..5,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8),
    ) {
        let (f, ascii) = [(Format::Obj, false), (Format::Off, false), (Format::Ply, false), (Format::Ply, true), (Format::Stl, false)][which];
        // STL refuses coordinates beyond f32 (tested in io::tests)
        let Ok(mut bytes) = encode_mesh(&m, f, &WriteOptions { ply_ascii: ascii }) else {
            prop_assert!(f == Format::Stl);
            return Ok(());
        };
        for (at, b, op) in edits {
            if bytes.is_empty() { break; }
            let i = at.index(bytes.len());
            match op {
                0 => bytes[i] = b,
                1 => bytes.truncate(i),
                _ => { bytes.remove(i); }
            }
        }
        if let Ok(back) = parse_mesh(&bytes, f, Path::new("m")) {
            // Whatever parses is a valid mesh.
            prop_assert!(Mesh::new(back.positions.clone(), back.faces.clone()).is_ok());
        }
    }
}
