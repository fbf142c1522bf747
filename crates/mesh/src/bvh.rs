//! Exact point-to-surface distance (SPEC §3, the `d(x_i, T)` of `E_v`):
//! Ericson's closest point on a triangle ("Real-Time Collision Detection",
//! §5.1.5) and a bounding-volume hierarchy over the triangles of a mesh.
//!
//! The BVH is built once (median split of the triangle centroids along the
//! longest axis, leaves of at most [`LEAF_SIZE`] triangles) and queried
//! nearest-child-first with box-distance pruning, so the answer is the exact
//! minimum over all triangles, not an approximation. Queries run in parallel
//! with rayon; each query is sequential and deterministic.

use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};
use rayon::prelude::*;

/// Most triangles in one leaf.
pub const LEAF_SIZE: usize = 4;

/// Closest point to `p` on the segment `[a, b]` (a point when `a == b`).
#[inline]
fn closest_on_segment(p: Vec3, a: Vec3, b: Vec3) -> Vec3 {
    let ab = vec3::sub(b, a);
    let denom = vec3::dot(ab, ab);
    let t = if denom > 0.0 {
        (vec3::dot(vec3::sub(p, a), ab) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    vec3::add(a, vec3::scale(ab, t))
}

/// Closest point to `p` on the triangle `(a, b, c)`: Ericson's Voronoi-region
/// method; a degenerate triangle (where the method divides by zero) is
/// handled through its three edges. Always finite for finite input.
#[inline]
pub fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let ab = vec3::sub(b, a);
    let ac = vec3::sub(c, a);
    let ap = vec3::sub(p, a);
    let d1 = vec3::dot(ab, ap);
    let d2 = vec3::dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = vec3::sub(p, b);
    let d3 = vec3::dot(ab, bp);
    let d4 = vec3::dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    let q = 'region: {
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            break 'region vec3::add(a, vec3::scale(ab, d1 / (d1 - d3)));
        }
        let cp = vec3::sub(p, c);
        let d5 = vec3::dot(ab, cp);
        let d6 = vec3::dot(ac, cp);
        if d6 >= 0.0 && d5 <= d6 {
            return c;
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            break 'region vec3::add(a, vec3::scale(ac, d2 / (d2 - d6)));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            break 'region vec3::add(b, vec3::scale(vec3::sub(c, b), w));
        }
        let den = va + vb + vc;
        let v = vb / den;
        let w = vc / den;
        vec3::add(a, vec3::add(vec3::scale(ab, v), vec3::scale(ac, w)))
    };
    if q.iter().all(|x| x.is_finite()) {
        return q;
    }
    // Degenerate triangle: the best of its three edges.
    let mut best = closest_on_segment(p, a, b);
    let mut bd = vec3::dist2(best, p);
    for (x, y) in [(b, c), (c, a)] {
        let s = closest_on_segment(p, x, y);
        let d = vec3::dist2(s, p);
        if d < bd {
            best = s;
            bd = d;
        }
    }
    best
}

/// Squared distance from `p` to the box `[lo, hi]` (0 inside).
#[inline]
fn box_dist2(p: Vec3, lo: Vec3, hi: Vec3) -> f64 {
    let mut d = 0.0;
    for k in 0..3 {
        let e = (lo[k] - p[k]).max(0.0).max(p[k] - hi[k]);
        d += e * e;
    }
    d
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// leaf: first triangle slot; inner: index of the left child (the right
    /// child is `left + 1`)
    start: u32,
    /// leaf: number of triangles (> 0); inner: 0
    count: u32,
}

/// The nearest surface point found by [`TriangleBvh::closest`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// squared distance
    pub dist2: f64,
    /// face index in the mesh
    pub face: u32,
    /// the closest point
    pub point: Vec3,
}

/// A bounding-volume hierarchy over the triangles of one mesh.
#[derive(Clone, Debug)]
pub struct TriangleBvh {
    nodes: Vec<Node>,
    /// triangle corners in leaf order
    tris: Vec<[Vec3; 3]>,
    /// original face index of each slot in `tris`
    ids: Vec<u32>,
    /// Margin on box pruning, in squared length units: a point-triangle
    /// distance computed in floating point can come out an ulp or so below
    /// the (exactly computed) distance to the triangle's box, and pruning on
    /// the bare box distance then missed the true minimum by one ulp.
    /// `1e-12 × diagonal²` covers the rounding of `closest_point_on_triangle`
    /// at a cost of a handful of extra node visits.
    prune_slack: f64,
}

impl TriangleBvh {
    /// Builds the hierarchy over all faces of `mesh`.
    pub fn new(mesh: &Mesh) -> TriangleBvh {
        /// One triangle while building: centroid, bounds, face index.
        #[derive(Clone, Copy)]
        struct Item {
            c: Vec3,
            lo: Vec3,
            hi: Vec3,
            id: u32,
        }
        let n = mesh.num_faces();
        let mut items: Vec<Item> = (0..n)
            .map(|f| {
                let [a, b, c] = mesh.corners(f);
                let mut lo = a;
                let mut hi = a;
                for p in [b, c] {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                Item {
                    c: vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0),
                    lo,
                    hi,
                    id: f as u32,
                }
            })
            .collect();
        let empty = Node {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
            start: 0,
            count: 0,
        };
        let mut nodes = Vec::with_capacity(2 * n / LEAF_SIZE + 2);
        nodes.push(empty);
        // Top-down split with an explicit stack of (node, start, end); a child
        // always has a larger index than its parent, so the inner bounds are
        // filled bottom-up afterwards by one reverse sweep.
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((ni, s, e)) = stack.pop() {
            if e - s <= LEAF_SIZE {
                let node = &mut nodes[ni];
                node.start = s as u32;
                node.count = (e - s) as u32;
                for it in &items[s..e] {
                    for k in 0..3 {
                        node.lo[k] = node.lo[k].min(it.lo[k]);
                        node.hi[k] = node.hi[k].max(it.hi[k]);
                    }
                }
                continue;
            }
            let mut clo = [f64::INFINITY; 3];
            let mut chi = [f64::NEG_INFINITY; 3];
            for it in &items[s..e] {
                for k in 0..3 {
                    clo[k] = clo[k].min(it.c[k]);
                    chi[k] = chi[k].max(it.c[k]);
                }
            }
            let ext = vec3::sub(chi, clo);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = s + (e - s) / 2;
            items[s..e].select_nth_unstable_by(mid - s, |x, y| x.c[axis].total_cmp(&y.c[axis]));
            let left = nodes.len();
            nodes.push(empty);
            nodes.push(empty);
            nodes[ni].start = left as u32;
            stack.push((left, s, mid));
            stack.push((left + 1, mid, e));
        }
        for ni in (0..nodes.len()).rev() {
            if nodes[ni].count == 0 {
                let (l, r) = (nodes[ni].start as usize, nodes[ni].start as usize + 1);
                for k in 0..3 {
                    nodes[ni].lo[k] = nodes[l].lo[k].min(nodes[r].lo[k]);
                    nodes[ni].hi[k] = nodes[l].hi[k].max(nodes[r].hi[k]);
                }
            }
        }
        let prune_slack = nodes.first().map_or(0.0, |root| {
            let d2 = vec3::dist2(root.lo, root.hi);
            if d2.is_finite() { 1e-12 * d2 } else { 0.0 }
        });
        TriangleBvh {
            nodes,
            prune_slack,
            tris: items
                .iter()
                .map(|it| mesh.corners(it.id as usize))
                .collect(),
            ids: items.iter().map(|it| it.id).collect(),
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether the hierarchy holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The exact closest point of the surface to `p` (`None` without
    /// triangles). Ties keep the first triangle met.
    pub fn closest(&self, p: Vec3) -> Option<Closest> {
        self.closest_from(
            p,
            Closest {
                dist2: f64::INFINITY,
                face: u32::MAX,
                point: [f64::NAN; 3],
            },
        )
    }

    /// [`closest`](Self::closest) starting from a known candidate (for
    /// example the distance to a triangle incident to the query's own vertex):
    /// a tight start prunes most of the tree. The answer is the same as
    /// `closest(p)` whenever `start` is a true point-triangle distance of
    /// this mesh (ties go to the smallest face index either way).
    pub fn closest_from(&self, p: Vec3, start: Closest) -> Option<Closest> {
        if self.ids.is_empty() {
            return None;
        }
        let mut best = start;
        // Median splits keep the depth <= 32 for u32 face counts; the stack
        // holds at most depth + 1 entries, so a fixed array suffices.
        let mut stack = [(0.0f64, 0u32); 64];
        stack[0] = (box_dist2(p, self.nodes[0].lo, self.nodes[0].hi), 0);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (d, ni) = stack[top];
            if d > best.dist2 + self.prune_slack {
                continue;
            }
            let node = self.nodes[ni as usize];
            if node.count > 0 {
                let s = node.start as usize;
                for slot in s..s + node.count as usize {
                    let [a, b, c] = self.tris[slot];
                    let q = closest_point_on_triangle(p, a, b, c);
                    let d2 = vec3::dist2(q, p);
                    if d2 < best.dist2 || (d2 == best.dist2 && self.ids[slot] < best.face) {
                        best = Closest {
                            dist2: d2,
                            face: self.ids[slot],
                            point: q,
                        };
                    }
                }
            } else {
                let l = node.start;
                let r = l + 1;
                let dl = box_dist2(p, self.nodes[l as usize].lo, self.nodes[l as usize].hi);
                let dr = box_dist2(p, self.nodes[r as usize].lo, self.nodes[r as usize].hi);
                // Push the farther child first so the nearer one is visited next.
                let (near, far) = if dl <= dr {
                    ((dl, l), (dr, r))
                } else {
                    ((dr, r), (dl, l))
                };
                if far.0 <= best.dist2 + self.prune_slack {
                    stack[top] = far;
                    top += 1;
                }
                if near.0 <= best.dist2 + self.prune_slack {
                    stack[top] = near;
                    top += 1;
                }
            }
        }
        Some(best)
    }

    /// Exact unsigned distances of many points, computed in parallel
    /// (`NaN` only when the hierarchy is empty).
    pub fn distances(&self, points: &[Vec3]) -> Vec<f64> {
        points
            .par_iter()
            .map(|&p| self.closest(p).map_or(f64::NAN, |c| c.dist2.sqrt()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let q = closest_point_on_triangle([0.2, 0.2, 3.0], a, b, c);
        assert!(vec3::dist2(q, [0.2, 0.2, 0.0]) < 1e-30, "{q:?}");
        assert_eq!(closest_point_on_triangle([-1.0, -1.0, 0.0], a, b, c), a);
        assert_eq!(closest_point_on_triangle([2.0, -1.0, 0.0], a, b, c), b);
        assert_eq!(closest_point_on_triangle([-1.0, 2.0, 1.0], a, b, c), c);
        assert_eq!(
            closest_point_on_triangle([0.5, -1.0, 0.0], a, b, c),
            [0.5, 0.0, 0.0]
        );
        assert_eq!(
            closest_point_on_triangle([-1.0, 0.5, 0.0], a, b, c),
            [0.0, 0.5, 0.0]
        );
        let q = closest_point_on_triangle([1.0, 1.0, 0.0], a, b, c);
        assert!(vec3::dist2(q, [0.5, 0.5, 0.0]) < 1e-30);
        // Degenerate: collinear and a single point.
        let q = closest_point_on_triangle([0.5, 1.0, 0.0], a, b, [2.0, 0.0, 0.0]);
        assert_eq!(q, [0.5, 0.0, 0.0]);
        let q = closest_point_on_triangle([0.5, 1.0, 0.0], b, b, b);
        assert_eq!(q, b);
    }

    fn random_mesh(rng: &mut ChaCha8Rng, nv: usize, nf: usize) -> Mesh {
        let positions = (0..nv)
            .map(|_| {
                [
                    rng.random::<f64>(),
                    rng.random::<f64>(),
                    rng.random::<f64>() * 0.2,
                ]
            })
            .collect();
        let faces = (0..nf)
            .map(|_| {
                [
                    rng.random_range(0..nv as u32),
                    rng.random_range(0..nv as u32),
                    rng.random_range(0..nv as u32),
                ]
            })
            .collect();
        Mesh::new(positions, faces).unwrap()
    }

    #[test]
    fn bvh_matches_brute_force_on_random_points() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (nv, nf) in [(3, 1), (20, 9), (300, 700)] {
            let m = random_mesh(&mut rng, nv, nf);
            let bvh = TriangleBvh::new(&m);
            for _ in 0..300 {
                let p = [
                    rng.random::<f64>() * 1.6 - 0.3,
                    rng.random::<f64>() * 1.6 - 0.3,
                    rng.random::<f64>() * 1.6 - 0.3,
                ];
                let brute = (0..nf)
                    .map(|f| {
                        let [a, b, c] = m.corners(f);
                        vec3::dist2(closest_point_on_triangle(p, a, b, c), p)
                    })
                    .fold(f64::INFINITY, f64::min);
                let got = bvh.closest(p).unwrap();
                assert_eq!(got.dist2, brute, "nv {nv} nf {nf} p {p:?}");
                // Any true candidate as a start gives the same answer.
                let h = rng.random_range(0..nf);
                let [a, b, c] = m.corners(h);
                let q = closest_point_on_triangle(p, a, b, c);
                let start = Closest {
                    dist2: vec3::dist2(q, p),
                    face: h as u32,
                    point: q,
                };
                assert_eq!(bvh.closest_from(p, start).unwrap(), got);
                let [a, b, c] = m.corners(got.face as usize);
                assert_eq!(
                    vec3::dist2(closest_point_on_triangle(p, a, b, c), p),
                    got.dist2
                );
            }
        }
    }

    #[test]
    fn closest_point_is_never_farther_than_corners_and_finite() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..2000 {
            let mut r = || {
                [
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                ]
            };
            let (p, a, b, c0, k) = (r(), r(), r(), r(), r()[0]);
            // Every third triangle or so degenerate (c on the line ab).
            let c = if k < -0.17 {
                vec3::add(a, vec3::scale(vec3::sub(b, a), 2.0))
            } else {
                c0
            };
            let q = closest_point_on_triangle(p, a, b, c);
            assert!(q.iter().all(|x| x.is_finite()));
            let d = vec3::dist2(q, p);
            for v in [a, b, c] {
                assert!(d <= vec3::dist2(v, p) + 1e-15);
            }
        }
    }
}
