//! Mesh validation report: counts, bounding box, `l_e` and `d_s` (SPEC §1)
//! and the defects that matter to normal filtering.
//!
//! Policy (the whole toolkit follows it): nothing here is fatal. Degenerate
//! faces are kept (their normal is zero, they count 90° in `E_a`);
//! duplicate faces, non-manifold edges, boundaries and unreferenced
//! vertices are reported so the user can decide, never silently repaired,
//! because the metrics compare meshes face by face and vertex by vertex.

use crate::geometry::{FaceGeometry, mean_centre_distance, mean_edge_length};
use crate::mesh::Mesh;
use crate::topology::Topology;
use crate::vec3::{self, Vec3};

/// Everything `normalnet info` prints about a mesh.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MeshReport {
    /// #V
    pub vertices: usize,
    /// #F
    pub faces: usize,
    /// unique edges
    pub edges: usize,
    /// bounding box minimum
    pub bbox_min: Vec3,
    /// bounding box maximum
    pub bbox_max: Vec3,
    /// bounding box diagonal length
    pub bbox_diagonal: f64,
    /// `l_e`: mean unique-edge length
    pub mean_edge_length: f64,
    /// `d_s`: mean distance between centres of edge-adjacent faces
    pub mean_centre_distance: f64,
    /// total surface area
    pub area: f64,
    /// edges with exactly one face
    pub boundary_edges: usize,
    /// edges with more than two faces
    pub non_manifold_edges: usize,
    /// faces with zero normal (zero area or repeated vertex)
    pub degenerate_faces: usize,
    /// faces with a repeated vertex index (a subset of the degenerate ones)
    pub faces_with_repeated_vertex: usize,
    /// faces whose vertex set already appeared on an earlier face
    pub duplicate_faces: usize,
    /// vertices used by no face
    pub unreferenced_vertices: usize,
    /// connected components (faces joined through shared vertices)
    pub components: usize,
    /// `V − E + F` over referenced vertices
    pub euler_characteristic: i64,
}

impl MeshReport {
    /// Human-readable warnings for the defects found (empty for a clean,
    /// closed, manifold mesh).
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let mut add = |n: usize, what: &str, note: &str| {
            if n > 0 {
                w.push(format!("{n} {what}{note}"));
            }
        };
        add(
            self.degenerate_faces,
            "degenerate faces",
            " (kept; zero normal, count 90° in E_a)",
        );
        add(self.duplicate_faces, "duplicate faces", " (kept)");
        add(self.non_manifold_edges, "non-manifold edges", " (kept)");
        add(
            self.unreferenced_vertices,
            "unreferenced vertices",
            " (kept, never moved)",
        );
        w
    }
}

/// Builds the report (topology built here; O(#F log #F)).
pub fn validate(mesh: &Mesh) -> MeshReport {
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    validate_with(mesh, &topo)
}

/// Builds the report from an existing topology of `mesh`.
pub fn validate_with(mesh: &Mesh, topo: &Topology) -> MeshReport {
    let geo = FaceGeometry::new(mesh);
    let (lo, hi) = mesh.bounding_box();
    let mut used = vec![false; mesh.num_vertices()];
    for t in &mesh.faces {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let referenced = used.iter().filter(|u| **u).count();
    let mut keys: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .map(|t| {
            let mut k = *t;
            k.sort_unstable();
            k
        })
        .collect();
    keys.sort_unstable();
    let duplicate_faces = keys.windows(2).filter(|w| w[0] == w[1]).count();

    // Union-find over vertices through face corners.
    let mut parent: Vec<u32> = (0..mesh.num_vertices() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for t in &mesh.faces {
        let a = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = find(&mut parent, v);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let components = (0..mesh.num_vertices() as u32)
        .filter(|&v| used[v as usize] && find(&mut parent, v) == v)
        .count();

    MeshReport {
        vertices: mesh.num_vertices(),
        faces: mesh.num_faces(),
        edges: topo.edges.len(),
        bbox_min: lo,
        bbox_max: hi,
        bbox_diagonal: vec3::norm(vec3::sub(hi, lo)),
        mean_edge_length: mean_edge_length(mesh, topo),
        mean_centre_distance: mean_centre_distance(topo, &geo.centres),
        area: geo.areas.iter().sum(),
        boundary_edges: topo.edge_face_count.iter().filter(|&&c| c == 1).count(),
        non_manifold_edges: topo.edge_face_count.iter().filter(|&&c| c > 2).count(),
        degenerate_faces: geo
            .normals
            .iter()
            .filter(|n| vec3::norm2(**n) == 0.0)
            .count(),
        faces_with_repeated_vertex: mesh
            .faces
            .iter()
            .filter(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            .count(),
        duplicate_faces,
        unreferenced_vertices: mesh.num_vertices() - referenced,
        components,
        euler_characteristic: referenced as i64 - topo.edges.len() as i64 + mesh.num_faces() as i64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tetrahedron_is_clean_and_closed() {
        let m = Mesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .unwrap();
        let r = validate(&m);
        assert_eq!((r.vertices, r.faces, r.edges), (4, 4, 6));
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(
            r.boundary_edges + r.non_manifold_edges + r.degenerate_faces + r.duplicate_faces,
            0
        );
        assert_eq!(r.components, 1);
        assert!(r.warnings().is_empty());
    }

    #[test]
    fn defects_are_counted() {
        // Two triangles sharing an edge, a duplicate of the first (reversed),
        // a third face on the shared edge (non-manifold), a degenerate face,
        // a separate triangle and an unreferenced vertex.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.5, 0.5, 1.0],
            [5.0, 5.0, 5.0],
            [6.0, 5.0, 5.0],
            [5.0, 6.0, 5.0],
            [9.0, 9.0, 9.0],
        ];
        let f = vec![
            [0, 1, 2],
            [1, 3, 2],
            [2, 1, 0],
            [1, 2, 4],
            [0, 0, 3],
            [5, 6, 7],
        ];
        let r = validate(&Mesh::new(p, f).unwrap());
        assert_eq!(r.duplicate_faces, 1);
        assert_eq!(r.non_manifold_edges, 1); // edge (1,2): faces 0, 1, 2, 3
        assert_eq!(r.degenerate_faces, 1);
        assert_eq!(r.faces_with_repeated_vertex, 1);
        assert_eq!(r.unreferenced_vertices, 1);
        assert_eq!(r.components, 2);
        assert_eq!(r.warnings().len(), 4);
    }
}
