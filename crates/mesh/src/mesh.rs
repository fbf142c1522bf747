//! `Mesh`: the triangle mesh at rest, two plain arrays (libigl's V/F).

use crate::error::MeshError;
use crate::vec3::Vec3;

/// A triangle mesh: vertex positions and faces as vertex-index triples.
///
/// Invariants (checked by [`Mesh::new`]): at least one vertex and one face,
/// every index `< positions.len()`, every coordinate finite, counts fit u32.
/// Degenerate faces (zero area, repeated indices) are allowed: their normal
/// is zero everywhere in the toolkit.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// one `[x, y, z]` per vertex (len #V)
    pub positions: Vec<Vec3>,
    /// one `[i, j, k]` per face, counter-clockwise seen from outside (len #F)
    pub faces: Vec<[u32; 3]>,
}

impl Mesh {
    /// A `k × k` grid of unit squares in x/y, each split into two
    /// triangles, with vertex `(x, y)` at height `z(x, y)` (vertex index
    /// `y·(k+1) + x`): a height field, the smallest mesh with an interior,
    /// a boundary and whatever relief `z` gives it (tests and examples).
    ///
    /// # Panics
    /// If `k` is 0 or `z` gives a non-finite height.
    pub fn height_grid(k: usize, z: impl Fn(usize, usize) -> f64) -> Mesh {
        Mesh::grid(k, |x, y| [x as f64, y as f64, z(x, y)])
    }

    /// The connectivity of [`Mesh::height_grid`] with vertex `(x, y)` at
    /// `position(x, y)` (a jittered, bent or wrapped grid).
    ///
    /// # Panics
    /// If `k` is 0 or `position` gives a non-finite coordinate.
    pub fn grid(k: usize, position: impl Fn(usize, usize) -> Vec3) -> Mesh {
        let mut p = Vec::new();
        for y in 0..=k {
            for x in 0..=k {
                p.push(position(x, y));
            }
        }
        let id = |x: usize, y: usize| (y * (k + 1) + x) as u32;
        let mut f = Vec::new();
        for y in 0..k {
            for x in 0..k {
                f.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                f.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        Mesh::new(p, f).expect("a grid with finite positions is a valid mesh")
    }

    /// The unit square in the z = 0 plane as two triangles (normal +z).
    pub fn unit_square() -> Mesh {
        let corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let positions = corners.map(|[x, y]| [x, y, 0.0]).to_vec();
        Mesh::new(positions, vec![[0, 1, 2], [0, 2, 3]]).expect("the unit square is a valid mesh")
    }

    /// The closed tetrahedron on the origin and the three unit points
    /// (faces outward): the smallest closed, oriented mesh.
    pub fn tetrahedron() -> Mesh {
        Mesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .expect("the tetrahedron is a valid mesh")
    }

    /// A unit UV sphere: `rings` bands of latitude and `segs` of longitude,
    /// `2·segs·(rings − 1)` triangles facing outwards. Vertex 0 is the north
    /// pole `(0, 0, 1)`, vertex `1 + (i − 1)·segs + j` lies on ring
    /// `i ∈ 1..rings` (polar angle `π·i/rings`) at azimuth `2π·j/segs`, and
    /// the last vertex is the south pole. A closed, curved, genus-0 mesh
    /// (tests and examples scale its positions for relief and noise).
    ///
    /// # Panics
    /// If `rings < 2` or `segs < 3`.
    pub fn uv_sphere(rings: usize, segs: usize) -> Mesh {
        assert!(
            rings >= 2 && segs >= 3,
            "uv_sphere({rings}, {segs}): at least 2 rings and 3 segments"
        );
        let mut p = vec![[0.0, 0.0, 1.0]];
        for i in 1..rings {
            let th = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segs {
                let ph = 2.0 * std::f64::consts::PI * j as f64 / segs as f64;
                p.push([th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()]);
            }
        }
        p.push([0.0, 0.0, -1.0]);
        let last = (p.len() - 1) as u32;
        let id = |i: usize, j: usize| (1 + (i - 1) * segs + j % segs) as u32;
        let mut f = Vec::new();
        for j in 0..segs {
            f.push([0, id(1, j), id(1, j + 1)]);
            f.push([last, id(rings - 1, j + 1), id(rings - 1, j)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segs {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        Mesh::new(p, f).expect("a UV sphere is a valid mesh")
    }

    /// Builds a mesh and checks its invariants.
    ///
    /// # Errors
    /// [`MeshError::Empty`], [`MeshError::IndexOutOfRange`],
    /// [`MeshError::NonFinite`], [`MeshError::TooLarge`].
    pub fn new(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        if positions.is_empty() || faces.is_empty() {
            return Err(MeshError::Empty {
                vertices: positions.len(),
                faces: faces.len(),
            });
        }
        if positions.len() > u32::MAX as usize {
            return Err(MeshError::TooLarge(positions.len()));
        }
        if faces.len() > u32::MAX as usize {
            return Err(MeshError::TooLarge(faces.len()));
        }
        if let Some((vertex, p)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
        {
            return Err(MeshError::NonFinite { vertex, value: *p });
        }
        let n = positions.len();
        for (face, f) in faces.iter().enumerate() {
            if let Some(&index) = f.iter().find(|&&i| i as usize >= n) {
                return Err(MeshError::IndexOutOfRange {
                    face,
                    index: index as u64,
                    num_vertices: n,
                });
            }
        }
        Ok(Mesh { positions, faces })
    }

    /// Number of vertices (#V).
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces (#F).
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }

    /// The three corner positions of face `f`.
    #[inline]
    pub fn corners(&self, f: usize) -> [Vec3; 3] {
        let [a, b, c] = self.faces[f];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The same connectivity with other positions (len must be #V).
    ///
    /// # Panics
    /// If `positions.len() != self.num_vertices()`.
    pub fn with_positions(&self, positions: Vec<Vec3>) -> Mesh {
        assert_eq!(
            positions.len(),
            self.positions.len(),
            "vertex count must not change"
        );
        Mesh {
            positions,
            faces: self.faces.clone(),
        }
    }

    /// Axis-aligned bounding box `(min, max)`.
    pub fn bounding_box(&self) -> (Vec3, Vec3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_empty_bad_index_and_nan() {
        assert!(matches!(
            Mesh::new(vec![], vec![]),
            Err(MeshError::Empty { .. })
        ));
        let p = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(matches!(
            Mesh::new(p.clone(), vec![[0, 1, 3]]),
            Err(MeshError::IndexOutOfRange {
                face: 0,
                index: 3,
                ..
            })
        ));
        let mut q = p.clone();
        q[1][2] = f64::NAN;
        let err = Mesh::new(q, vec![[0, 1, 2]]).unwrap_err();
        assert!(err.to_string().contains("vertex 1"), "{err}");
        assert!(Mesh::new(p, vec![[0, 1, 2]]).is_ok());
    }

    #[test]
    fn uv_sphere_is_closed_unit_and_faces_outwards() {
        let m = Mesh::uv_sphere(5, 8);
        assert_eq!((m.num_vertices(), m.num_faces()), (2 + 4 * 8, 2 * 8 * 4));
        let t = crate::Topology::new(m.num_vertices(), &m.faces);
        assert_eq!(t.num_boundary_edges(), 0);
        assert!(t.non_manifold_edges().is_empty());
        for p in &m.positions {
            assert!((crate::vec3::norm(*p) - 1.0).abs() < 1e-15);
        }
        for f in 0..m.num_faces() {
            let [a, b, c] = m.corners(f);
            let n = crate::vec3::cross(crate::vec3::sub(b, a), crate::vec3::sub(c, a));
            let centre = crate::vec3::add(crate::vec3::add(a, b), c);
            assert!(crate::vec3::dot(n, centre) > 0.0, "face {f} faces inwards");
        }
    }
}
