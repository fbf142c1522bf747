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
use crate::scale::{diagonal_length, mul_pow2, normalising_exponent, pow2_scaled};
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
    /// bounding box diagonal length (infinite only when an extent overflows
    /// f64, coordinates of both signs near ±1.8e308)
    pub bbox_diagonal: f64,
    /// `l_e`: mean unique-edge length
    pub mean_edge_length: f64,
    /// `d_s`: mean distance between centres of edge-adjacent faces
    pub mean_centre_distance: f64,
    /// total surface area (infinite when it exceeds f64's 1.8e308, i.e.
    /// coordinates beyond ~1e154)
    pub area: f64,
    /// edges with exactly one face
    pub boundary_edges: usize,
    /// edges with more than two faces
    pub non_manifold_edges: usize,
    /// vertices whose incident faces form more than one fan around them
    /// (joined through edges at the vertex): "bow-tie" vertices, where two
    /// sheets touch at a single point
    pub non_manifold_vertices: usize,
    /// edges with exactly two faces that traverse them in the same direction
    /// (`a → b` twice): the two faces are oriented inconsistently
    pub misoriented_edges: usize,
    /// faces with at least one misoriented edge
    pub misoriented_faces: usize,
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
    /// vertices far outside the robust extent or isolated spikes
    /// ([`crate::outliers`], default thresholds)
    pub outlier_vertices: usize,
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
            self.non_manifold_vertices,
            "non-manifold (bow-tie) vertices",
            " (kept)",
        );
        add(
            self.misoriented_edges,
            "edges traversed twice in the same direction",
            &format!(
                " ({} faces oriented inconsistently with a neighbour; kept, not flipped)",
                self.misoriented_faces
            ),
        );
        add(
            self.unreferenced_vertices,
            "unreferenced vertices",
            " (kept, never moved)",
        );
        add(
            self.outlier_vertices,
            "outlier vertices far outside the mesh or isolated spikes",
            " (kept in place with their faces by the classical methods; \
             `denoise --remove-outliers` drops them)",
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
///
/// A mesh whose bounding-box diagonal lies outside
/// [`crate::scale::SAFE_DIAGONAL_MIN`] ..= [`crate::scale::SAFE_DIAGONAL_MAX`]
/// is measured in a copy scaled by an exact power of two (diagonal ~1) and
/// its lengths and area are scaled back, so that a valid mesh at 1e-80 or
/// 1e80 reports its true `l_e`, `d_s`, area and no degenerate faces.
pub fn validate_with(mesh: &Mesh, topo: &Topology) -> MeshReport {
    let (lo, hi) = mesh.bounding_box();
    let bbox_diagonal = diagonal_length(lo, hi);
    // A mesh at an extreme scale is measured in a frame scaled by 2^k, its
    // diagonal ~1 (exact: `crate::scale`), and its lengths scaled back; a
    // mesh in the safe range is measured as it is.
    let k = normalising_exponent(bbox_diagonal);
    let scaled;
    let frame = match k {
        Some(k) => {
            scaled = mesh.with_positions(pow2_scaled(&mesh.positions, k));
            &scaled
        }
        None => mesh,
    };
    let k = k.unwrap_or(0);
    let geo = FaceGeometry::new(frame);
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
    for t in &mesh.faces {
        join(&mut parent, t[0], t[1]);
        join(&mut parent, t[0], t[2]);
    }
    let components = (0..mesh.num_vertices() as u32)
        .filter(|&v| used[v as usize] && root(&mut parent, v) == v)
        .count();

    let misoriented = misoriented_edges(&mesh.faces, topo);
    let mut on_misoriented = vec![false; mesh.num_faces()];
    for &e in &misoriented {
        for f in topo.edge_faces[e] {
            on_misoriented[f as usize] = true;
        }
    }
    let misoriented_faces = on_misoriented.iter().filter(|m| **m).count();

    MeshReport {
        vertices: mesh.num_vertices(),
        faces: mesh.num_faces(),
        edges: topo.edges.len(),
        bbox_min: lo,
        bbox_max: hi,
        bbox_diagonal,
        mean_edge_length: mul_pow2(mean_edge_length(frame, topo), -k),
        mean_centre_distance: mul_pow2(mean_centre_distance(topo, &geo.centres), -k),
        area: mul_pow2(geo.areas.iter().sum(), -2 * k),
        boundary_edges: topo.edge_face_count.iter().filter(|&&c| c == 1).count(),
        non_manifold_edges: topo.edge_face_count.iter().filter(|&&c| c > 2).count(),
        non_manifold_vertices: non_manifold_vertices(&mesh.faces, topo).len(),
        misoriented_edges: misoriented.len(),
        misoriented_faces,
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
        outlier_vertices: crate::outliers::outlier_vertices(frame, &Default::default()).count(),
    }
}

/// The root of `x`'s set in the union-find forest `parent` (a root is its
/// own parent), halving the path on the way.
fn root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

/// Joins the sets of `a` and `b` (`b`'s root under `a`'s); whether they
/// were apart.
fn join(parent: &mut [u32], a: u32, b: u32) -> bool {
    let (a, b) = (root(parent, a), root(parent, b));
    if a != b {
        parent[b as usize] = a;
    }
    a != b
}

/// Non-manifold ("bow-tie") vertices, increasing: vertices whose incident
/// faces fall into more than one group when faces sharing an edge at the
/// vertex are joined. A vertex on a boundary is manifold if its faces form a
/// single fan; a vertex on a non-manifold edge is reported only if its faces
/// also fall apart elsewhere (the edge itself is counted as a non-manifold
/// edge). Unreferenced vertices are not reported.
///
/// `topo` must be the topology of `faces`. Time O(Σ deg(v) log deg(v)).
pub fn non_manifold_vertices(faces: &[[u32; 3]], topo: &Topology) -> Vec<u32> {
    use rayon::prelude::*;
    (0..topo.num_vertices as u32)
        .into_par_iter()
        .map_init(Vec::new, |links: &mut Vec<(u32, u32)>, v| {
            let incident = topo.vertex_faces.row(v as usize);
            if incident.len() < 2 {
                return None;
            }
            // (other end w of an edge v–w, local face index): faces with the
            // same w share the edge v–w.
            links.clear();
            for (i, &f) in incident.iter().enumerate() {
                let t = faces[f as usize];
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if a != b && (a == v || b == v) {
                        links.push((if a == v { b } else { a }, i as u32));
                    }
                }
            }
            links.sort_unstable();
            let mut parent: Vec<u32> = (0..incident.len() as u32).collect();
            let mut groups = incident.len();
            for pair in links.windows(2) {
                if pair[0].0 == pair[1].0 && join(&mut parent, pair[0].1, pair[1].1) {
                    groups -= 1;
                }
            }
            (groups > 1).then_some(v)
        })
        .flatten()
        .collect()
}

/// Edges (indices into `topo.edges`) shared by exactly two faces that both
/// traverse it in the same direction, i.e. whose orientations disagree.
/// Edges of one face only (a degenerate face `[a, a, b]` has a–b twice), of
/// more than two faces, or between a vertex and itself are not considered.
///
/// `topo` must be the topology of `faces`.
pub fn misoriented_edges(faces: &[[u32; 3]], topo: &Topology) -> Vec<usize> {
    // Direction of edge e in face f: true when f goes from edges[e][0] to edges[e][1].
    let forward = |e: usize, f: u32| {
        let t = faces[f as usize];
        let k = topo.face_edges[f as usize]
            .iter()
            .position(|&x| x as usize == e)
            .unwrap_or(0);
        t[k] == topo.edges[e][0]
    };
    (0..topo.edges.len())
        .filter(|&e| {
            let [a, b] = topo.edges[e];
            let [f, g] = topo.edge_faces[e];
            // f == g: a degenerate face `[a, a, b]` has the edge a–b twice
            a != b && f != g && topo.edge_face_count[e] == 2 && forward(e, f) == forward(e, g)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tetrahedron_is_clean_and_closed() {
        let m = Mesh::tetrahedron();
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

    /// The audit's extreme scales: a valid mesh times 1e±80 (and 1e200,
    /// past the squares' overflow) reports its lengths and area scaled, no
    /// degenerate face and nothing NaN or infinite.
    #[test]
    fn extreme_scales_report_scaled_lengths_not_degenerate_faces() {
        let m = Mesh::height_grid(6, |i, j| 0.1 * ((i * 7 + j * 3) % 5) as f64);
        let r = validate(&m);
        for s in [1e-80, 1e80, 1e200, 1e-200] {
            let big = m.with_positions(m.positions.iter().map(|p| p.map(|c| c * s)).collect());
            let q = validate(&big);
            assert_eq!(q.degenerate_faces, 0, "{s:e}");
            assert_eq!(q.outlier_vertices, r.outlier_vertices, "{s:e}");
            for (a, b, power) in [
                (q.bbox_diagonal, r.bbox_diagonal, 1),
                (q.mean_edge_length, r.mean_edge_length, 1),
                (q.mean_centre_distance, r.mean_centre_distance, 1),
                (q.area, r.area, 2),
            ] {
                let want = b * s.powi(power);
                if want.is_finite() && want > 0.0 {
                    assert!((a / want - 1.0).abs() < 1e-12, "{s:e}: {a:e} vs {want:e}");
                } else {
                    // 1e200² overflows: the area is honestly infinite
                    assert_eq!(a, want, "{s:e}");
                }
            }
        }
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
        // The degenerate face [0, 0, 3] meets the others only at vertices 0
        // and 3 (its edge 0–3 is its own): two bow ties.
        assert_eq!(r.non_manifold_vertices, 2);
        assert_eq!(r.misoriented_edges, 0);
        assert_eq!(r.warnings().len(), 5);
    }

    fn mesh(p: Vec<[f64; 3]>, f: Vec<[u32; 3]>) -> Mesh {
        Mesh::new(p, f).unwrap()
    }

    #[test]
    fn issue_14_bow_tie_vertices_are_reported() {
        // Two triangles touching only at vertex 0 (a bow tie), and a fan of
        // two triangles around vertex 5 (manifold, on a boundary).
        let m = mesh(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [-1.0, 0.0, 0.0],
                [-1.0, -1.0, 0.0],
                [5.0, 0.0, 0.0],
                [6.0, 0.0, 0.0],
                [6.0, 1.0, 0.0],
                [5.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 3, 4], [5, 6, 7], [5, 7, 8]],
        );
        let topo = Topology::new(m.num_vertices(), &m.faces);
        assert_eq!(non_manifold_vertices(&m.faces, &topo), vec![0]);
        let r = validate(&m);
        assert_eq!(r.non_manifold_vertices, 1);
        assert_eq!(r.misoriented_edges, 0);
        assert!(
            r.warnings()
                .iter()
                .any(|w| w.contains("1 non-manifold (bow-tie) vertices")),
            "{:?}",
            r.warnings()
        );
        // Two cones glued at their apex: closed fans, still a bow tie.
        let mut p = vec![[0.0, 0.0, 0.0]];
        let mut f = Vec::new();
        for (z, flip) in [(1.0, false), (-1.0, true)] {
            let base = p.len() as u32;
            for k in 0..4 {
                let a = k as f64 * std::f64::consts::FRAC_PI_2;
                p.push([a.cos(), a.sin(), z]);
            }
            for k in 0..4u32 {
                let (b, c) = (base + k, base + (k + 1) % 4);
                f.push(if flip { [0, c, b] } else { [0, b, c] });
            }
        }
        let m = mesh(p, f);
        let topo = Topology::new(m.num_vertices(), &m.faces);
        assert_eq!(non_manifold_vertices(&m.faces, &topo), vec![0]);
    }

    #[test]
    fn issue_14_inconsistent_orientation_is_reported() {
        // A closed tetrahedron with one face flipped: its three edges are
        // each traversed twice in the same direction.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let good = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let r = validate(&mesh(p.clone(), good.clone()));
        assert_eq!((r.misoriented_edges, r.misoriented_faces), (0, 0));
        assert_eq!(r.non_manifold_vertices, 0);
        let mut bad = good;
        bad[3] = [1, 3, 2];
        let r = validate(&mesh(p, bad));
        assert_eq!(r.misoriented_edges, 3);
        assert_eq!(r.misoriented_faces, 4);
        assert_eq!(r.non_manifold_vertices, 0);
        assert!(
            r.warnings()
                .iter()
                .any(|w| w.contains("3 edges traversed twice in the same direction")),
            "{:?}",
            r.warnings()
        );
    }
}
