//! `Topology`: connectivity built once from the faces, never mutated
//! (vertex → faces, face → vertex-adjacent faces, unique edges with their
//! faces, edge-adjacent faces, boundary and non-manifold edges, r-rings).

use crate::csr::Csr;
use rayon::prelude::*;

/// Sentinel for "no face" (boundary side of an edge).
pub const NO_FACE: u32 = u32::MAX;

/// Connectivity of a triangle mesh, in flat CSR arrays.
#[derive(Clone, Debug)]
pub struct Topology {
    /// Number of vertices the topology was built for.
    pub num_vertices: usize,
    /// Faces incident to each vertex, increasing face order (len #V rows).
    pub vertex_faces: Csr,
    /// Faces sharing at least one vertex with each face, the face itself
    /// excluded, increasing order (the 1-ring by vertex adjacency; len #F rows).
    pub face_neighbours: Csr,
    /// Unique edges `[a, b]` with `a < b`.
    pub edges: Vec<[u32; 2]>,
    /// The first two faces of each edge; `NO_FACE` on a boundary side.
    pub edge_faces: Vec<[u32; 2]>,
    /// Number of faces on each edge (1 boundary, 2 manifold, >2 non-manifold).
    pub edge_face_count: Vec<u32>,
    /// Edge index of face corners (0,1), (1,2), (2,0) per face.
    pub face_edges: Vec<[u32; 3]>,
}

impl Topology {
    /// Builds the topology of `faces` over `num_vertices` vertices.
    ///
    /// Time O(#F log #F), memory ~100 bytes per face.
    pub fn new(num_vertices: usize, faces: &[[u32; 3]]) -> Topology {
        let vertex_faces = vertex_faces(num_vertices, faces);
        let face_neighbours = face_neighbours(faces, &vertex_faces);

        // Unique edges by sorting (key, face, local edge).
        let mut half: Vec<(u64, u32, u8)> = Vec::with_capacity(faces.len() * 3);
        for (f, t) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                half.push((((a as u64) << 32) | b as u64, f as u32, k as u8));
            }
        }
        half.par_sort_unstable();
        let mut edges = Vec::with_capacity(faces.len() * 3 / 2 + 1);
        let mut edge_faces = Vec::with_capacity(edges.capacity());
        let mut edge_face_count = Vec::with_capacity(edges.capacity());
        let mut face_edges = vec![[u32::MAX; 3]; faces.len()];
        let mut i = 0;
        while i < half.len() {
            let key = half[i].0;
            let e = edges.len() as u32;
            edges.push([(key >> 32) as u32, key as u32]);
            let mut ef = [NO_FACE; 2];
            let mut count = 0u32;
            while i < half.len() && half[i].0 == key {
                let (_, f, k) = half[i];
                if (count as usize) < 2 {
                    ef[count as usize] = f;
                }
                count += 1;
                face_edges[f as usize][k as usize] = e;
                i += 1;
            }
            edge_faces.push(ef);
            edge_face_count.push(count);
        }
        Topology {
            num_vertices,
            vertex_faces,
            face_neighbours,
            edges,
            edge_faces,
            edge_face_count,
            face_edges,
        }
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.face_edges.len()
    }

    /// Faces sharing edge `k` of face `f` with `f` (at most one on a manifold
    /// edge; `NO_FACE` on a boundary).
    #[inline]
    pub fn edge_neighbour(&self, f: usize, k: usize) -> u32 {
        let e = self.face_edges[f][k] as usize;
        let [a, b] = self.edge_faces[e];
        if a as usize == f { b } else { a }
    }

    /// Edge-adjacent faces of every face (`NO_FACE` where none).
    pub fn face_edge_neighbours(&self) -> Vec<[u32; 3]> {
        (0..self.num_faces())
            .map(|f| [0, 1, 2].map(|k| self.edge_neighbour(f, k)))
            .collect()
    }

    /// Number of boundary edges (one incident face).
    pub fn num_boundary_edges(&self) -> usize {
        self.edge_face_count.iter().filter(|&&c| c == 1).count()
    }

    /// Indices of non-manifold edges (more than two incident faces).
    pub fn non_manifold_edges(&self) -> Vec<usize> {
        (0..self.edges.len())
            .filter(|&e| self.edge_face_count[e] > 2)
            .collect()
    }

    /// Vertices on a boundary edge (flags, len #V).
    pub fn boundary_vertices(&self) -> Vec<bool> {
        let mut b = vec![false; self.num_vertices];
        for (e, &[u, v]) in self.edges.iter().enumerate() {
            if self.edge_face_count[e] == 1 {
                b[u as usize] = true;
                b[v as usize] = true;
            }
        }
        b
    }

    /// The vertex-based r-ring patch of face `f` (SPEC §1): `f` plus all faces
    /// sharing a vertex with the patch, repeated `r` times. `f` comes first,
    /// then the rings in order of growth. `mark` is scratch of len #F, all
    /// false on entry and on return.
    pub fn face_ring_into(&self, f: usize, r: usize, mark: &mut [bool], out: &mut Vec<u32>) {
        out.clear();
        out.push(f as u32);
        mark[f] = true;
        let mut start = 0;
        for _ in 0..r {
            let end = out.len();
            for i in start..end {
                let g = out[i] as usize;
                for &h in self.face_neighbours.row(g) {
                    if !mark[h as usize] {
                        mark[h as usize] = true;
                        out.push(h);
                    }
                }
            }
            start = end;
        }
        for &g in out.iter() {
            mark[g as usize] = false;
        }
    }

    /// The r-ring patch of face `f` (allocating form of [`Self::face_ring_into`]).
    pub fn face_ring(&self, f: usize, r: usize) -> Vec<u32> {
        let mut mark = vec![false; self.num_faces()];
        let mut out = Vec::new();
        self.face_ring_into(f, r, &mut mark, &mut out);
        out
    }

    /// The r-ring patch of every face, in parallel.
    pub fn face_rings(&self, r: usize) -> Csr {
        let n = self.num_faces();
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map_init(
                || vec![false; n],
                |mark, f| {
                    let mut out = Vec::new();
                    self.face_ring_into(f, r, mark, &mut out);
                    out
                },
            )
            .collect();
        Csr::from_rows(rows)
    }
}

/// Faces incident to each vertex (CSR over vertices, increasing face order).
pub fn vertex_faces(num_vertices: usize, faces: &[[u32; 3]]) -> Csr {
    let mut counts = vec![0u32; num_vertices + 1];
    for t in faces {
        for &v in t {
            counts[v as usize + 1] += 1;
        }
    }
    for i in 0..num_vertices {
        counts[i + 1] += counts[i];
    }
    let offsets = counts.clone();
    let mut fill = counts;
    let mut indices = vec![0u32; offsets[num_vertices] as usize];
    for (f, t) in faces.iter().enumerate() {
        for &v in t {
            let slot = &mut fill[v as usize];
            indices[*slot as usize] = f as u32;
            *slot += 1;
        }
    }
    // A face with a repeated vertex appears twice in that vertex's row.
    let mut out = Csr {
        offsets: vec![0],
        indices: Vec::with_capacity(indices.len()),
    };
    for v in 0..num_vertices {
        let row = &indices[offsets[v] as usize..offsets[v + 1] as usize];
        let mut last = u32::MAX;
        for &f in row {
            if f != last {
                out.indices.push(f);
                last = f;
            }
        }
        out.offsets.push(out.indices.len() as u32);
    }
    out
}

fn face_neighbours(faces: &[[u32; 3]], vertex_faces: &Csr) -> Csr {
    let rows: Vec<Vec<u32>> = faces
        .par_iter()
        .enumerate()
        .map(|(f, t)| {
            let mut row: Vec<u32> = t
                .iter()
                .flat_map(|&v| vertex_faces.row(v as usize).iter().copied())
                .filter(|&g| g as usize != f)
                .collect();
            row.sort_unstable();
            row.dedup();
            row
        })
        .collect();
    Csr::from_rows(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing edge (1,2), plus one touching only vertex 3.
    fn strip() -> Vec<[u32; 3]> {
        vec![[0, 1, 2], [2, 1, 3], [3, 4, 5]]
    }

    #[test]
    fn edges_and_neighbours() {
        let t = Topology::new(6, &strip());
        assert_eq!(t.edges.len(), 8);
        assert_eq!(t.num_boundary_edges(), 7);
        assert!(t.non_manifold_edges().is_empty());
        assert_eq!(t.face_neighbours.row(0), &[1]);
        assert_eq!(t.face_neighbours.row(1), &[0, 2]);
        assert_eq!(t.edge_neighbour(0, 1), 1);
        assert_eq!(t.edge_neighbour(0, 0), NO_FACE);
        assert_eq!(t.face_ring(0, 1), vec![0, 1]);
        assert_eq!(t.face_ring(0, 2), vec![0, 1, 2]);
        assert_eq!(t.face_rings(1).row(2), &[2, 1]);
    }

    #[test]
    fn non_manifold_edge_is_reported() {
        let t = Topology::new(5, &[[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        assert_eq!(t.non_manifold_edges().len(), 1);
        let e = t.non_manifold_edges()[0];
        assert_eq!(t.edges[e], [0, 1]);
        assert_eq!(t.edge_face_count[e], 3);
    }

    #[test]
    fn repeated_vertex_face_listed_once() {
        let t = Topology::new(3, &[[0, 0, 1], [0, 1, 2]]);
        assert_eq!(t.vertex_faces.row(0), &[0, 1]);
    }
}
