//! Property tests of the metrics: a mesh against itself has zero distances
//! and only its degenerate faces contribute (90° each) to `E_a`; the BVH
//! distance equals brute force over all triangles.

use normalnet_mesh::Mesh;
use normalnet_mesh::bvh::{TriangleBvh, closest_point_on_triangle};
use normalnet_mesh::geometry::count_degenerate_faces;
use normalnet_mesh::metrics::compare;
use normalnet_mesh::vec3;
use proptest::prelude::*;

fn mesh_strategy() -> impl Strategy<Value = Mesh> {
    (3usize..30).prop_flat_map(|nv| {
        (
            proptest::collection::vec([-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0], nv),
            proptest::collection::vec([0..nv as u32, 0..nv as u32, 0..nv as u32], 1..50),
        )
            .prop_map(|(p, f)| Mesh::new(p, f).unwrap())
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn mesh_against_itself(m in mesh_strategy()) {
        let r = match compare(&m, &m) {
            Ok(r) => r,
            Err(e) => {
                // Only a ground truth with nothing to measure against is refused.
                let le = normalnet_mesh::geometry::mean_edge_length(&m, &normalnet_mesh::Topology::new(m.num_vertices(), &m.faces));
                prop_assert_eq!(le, 0.0, "{}", e);
                return Ok(());
            }
        };
        let expected = 90.0 * count_degenerate_faces(&m) as f64 / m.num_faces() as f64;
        prop_assert!((r.e_a_deg - expected).abs() < 1e-9, "{} vs {}", r.e_a_deg, expected);
        prop_assert_eq!(r.e_v, 0.0);
        prop_assert_eq!(r.hausdorff, 0.0);
        prop_assert!(r.faces_identical);
    }

    #[test]
    fn bvh_equals_brute_force(m in mesh_strategy(), pts in proptest::collection::vec([-8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0], 1..20)) {
        let bvh = TriangleBvh::new(&m);
        for p in pts {
            let brute = (0..m.num_faces())
                .map(|f| {
                    let [a, b, c] = m.corners(f);
                    vec3::dist2(closest_point_on_triangle(p, a, b, c), p)
                })
                .fold(f64::INFINITY, f64::min);
            prop_assert_eq!(bvh.closest(p).unwrap().dist2, brute);
        }
    }
}
