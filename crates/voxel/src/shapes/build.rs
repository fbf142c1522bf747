//! Coarse polyhedral builders: 2D profiles, ear clipping, lofts (rings of a
//! profile stacked along y, capped), the icosahedron and convex polyhedra
//! cut by planes.

use super::edit::EditMesh;
use super::surface::Surface;
use normalnet_mesh::vec3::{self, Vec3};
use std::f64::consts::TAU;

/// A closed 2D polygon in the (x, z) plane, counter-clockwise (positive
/// signed area), no repeated points.
pub type Profile = Vec<[f64; 2]>;

/// Signed area of a 2D polygon.
pub fn signed_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| p[i][0] * p[(i + 1) % n][1] - p[(i + 1) % n][0] * p[i][1])
        .sum::<f64>()
        * 0.5
}

/// Makes the polygon counter-clockwise.
pub fn ccw(mut p: Profile) -> Profile {
    if signed_area(&p) < 0.0 {
        p.reverse();
    }
    p
}

/// Axis-aligned rectangle `w × d` centred at the origin.
pub fn rect(w: f64, d: f64) -> Profile {
    ccw(vec![
        [-w / 2.0, -d / 2.0],
        [w / 2.0, -d / 2.0],
        [w / 2.0, d / 2.0],
        [-w / 2.0, d / 2.0],
    ])
}

/// Regular `n`-gon of circumradius `r`, rotated by `phase`.
pub fn ngon(n: usize, r: f64, phase: f64) -> Profile {
    ccw((0..n)
        .map(|i| {
            let t = phase + TAU * i as f64 / n as f64;
            [r * t.cos(), r * t.sin()]
        })
        .collect())
}

/// Star with `n` tips: radii alternate `r_out`, `r_in`.
pub fn star(n: usize, r_out: f64, r_in: f64, phase: f64) -> Profile {
    ccw((0..2 * n)
        .map(|i| {
            let t = phase + TAU * i as f64 / (2 * n) as f64;
            let r = if i % 2 == 0 { r_out } else { r_in };
            [r * t.cos(), r * t.sin()]
        })
        .collect())
}

/// Rectangle `w × d` with its corners cut by `c` (a chamfered rectangle).
pub fn chamfered_rect(w: f64, d: f64, c: f64) -> Profile {
    let (x, z) = (w / 2.0, d / 2.0);
    ccw(vec![
        [-x + c, -z],
        [x - c, -z],
        [x, -z + c],
        [x, z - c],
        [x - c, z],
        [-x + c, z],
        [-x, z - c],
        [-x, -z + c],
    ])
}

/// Rectangle `w × d` with corners rounded to radius `r` (`k` segments each).
pub fn rounded_rect(w: f64, d: f64, r: f64, k: usize) -> Profile {
    let (x, z) = (w / 2.0 - r, d / 2.0 - r);
    let mut p = Vec::new();
    for (q, (cx, cz)) in [(x, -z), (x, z), (-x, z), (-x, -z)].into_iter().enumerate() {
        let start = -TAU / 4.0 + q as f64 * TAU / 4.0;
        for i in 0..=k {
            let t = start + TAU / 4.0 * i as f64 / k as f64;
            p.push([cx + r * t.cos(), cz + r * t.sin()]);
        }
    }
    ccw(p)
}

/// An L shape in the unit square (arm width `a`).
pub fn l_shape(a: f64) -> Profile {
    ccw(vec![
        [-0.5, -0.5],
        [0.5, -0.5],
        [0.5, -0.5 + a],
        [-0.5 + a, -0.5 + a],
        [-0.5 + a, 0.5],
        [-0.5, 0.5],
    ])
}

/// A cross (plus sign) with arm half-width `a` in the unit square.
pub fn cross_shape(a: f64) -> Profile {
    ccw(vec![
        [-a, -0.5],
        [a, -0.5],
        [a, -a],
        [0.5, -a],
        [0.5, a],
        [a, a],
        [a, 0.5],
        [-a, 0.5],
        [-a, a],
        [-0.5, a],
        [-0.5, -a],
        [-a, -a],
    ])
}

/// A `w × d` rectangle with rectangular notches cut into its +z side:
/// each `(centre x, width, depth)`, non-overlapping, inside the side.
pub fn notched_rect(w: f64, d: f64, notches: &[(f64, f64, f64)]) -> Profile {
    let (x, z) = (w / 2.0, d / 2.0);
    let mut p = vec![[-x, -z], [x, -z], [x, z]];
    let mut ns = notches.to_vec();
    ns.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (cx, nw, nd) in ns {
        p.push([cx + nw / 2.0, z]);
        p.push([cx + nw / 2.0, z - nd]);
        p.push([cx - nw / 2.0, z - nd]);
        p.push([cx - nw / 2.0, z]);
    }
    p.push([-x, z]);
    ccw(p)
}

/// Inserts points along each polygon edge so no segment is longer than `s`.
pub fn resample(p: &[[f64; 2]], s: f64) -> Profile {
    let mut out = Vec::new();
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let k = (l / s).ceil().max(1.0) as usize;
        for j in 0..k {
            let t = j as f64 / k as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}

/// Ear clipping of a simple counter-clockwise polygon: triangles as index
/// triples, counter-clockwise. O(n²)–O(n³), for coarse polygons.
pub fn ear_clip(p: &[[f64; 2]]) -> Vec<[usize; 3]> {
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut idx: Vec<usize> = (0..p.len()).collect();
    let mut tris = Vec::new();
    while idx.len() > 3 {
        let n = idx.len();
        // Best ear: convex, no other vertex inside, largest minimum angle proxy.
        let mut best: Option<(usize, f64)> = None;
        for i in 0..n {
            let (a, b, c) = (p[idx[(i + n - 1) % n]], p[idx[i]], p[idx[(i + 1) % n]]);
            let area = cross(a, b, c);
            if area <= 1e-14 {
                continue;
            }
            let inside = idx.iter().any(|&j| {
                let q = p[j];
                q != a
                    && q != b
                    && q != c
                    && cross(a, b, q) >= 0.0
                    && cross(b, c, q) >= 0.0
                    && cross(c, a, q) >= 0.0
            });
            if inside {
                continue;
            }
            let l2 = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2);
            let quality = area / (l2(a, b) + l2(b, c) + l2(c, a));
            if best.is_none_or(|(_, q)| quality > q) {
                best = Some((i, quality));
            }
        }
        let Some((i, _)) = best else {
            // Numerically stuck (collinear remainder): clip any vertex.
            let i = 0;
            tris.push([idx[(i + n - 1) % n], idx[i], idx[(i + 1) % n]]);
            idx.remove(i);
            continue;
        };
        tris.push([idx[(i + n - 1) % n], idx[i], idx[(i + 1) % n]]);
        idx.remove(i);
    }
    tris.push([idx[0], idx[1], idx[2]]);
    tris
}

/// One ring of a loft: the profile's points placed in 3D.
pub struct Ring {
    /// 3D points, same count and order as the profile
    pub points: Vec<Vec3>,
    /// tag of the band from this ring to the next (ignored on the last)
    pub band: u16,
}

/// Stacks `rings` (same point count, counter-clockwise seen from +y,
/// increasing y) into a closed solid: bands of quads between consecutive
/// rings, the first ring capped by a planar cap (tag 0), the last either
/// by a cap with tag `top` (its points lifted by `lift`) or, when `apex` is
/// given, by a fan to that point.
pub fn loft(
    m: &mut EditMesh,
    rings: &[Ring],
    profile: &[[f64; 2]],
    top: u16,
    apex: Option<Vec3>,
    lift: impl Fn(Vec3) -> Vec3,
) {
    let n = profile.len();
    let ids: Vec<Vec<u32>> = rings
        .iter()
        .map(|r| r.points.iter().map(|&p| m.add_vertex(p)).collect())
        .collect();
    for k in 0..rings.len() - 1 {
        let (a, b) = (&ids[k], &ids[k + 1]);
        for i in 0..n {
            let j = (i + 1) % n;
            // Outward for counter-clockwise (x, z) rings with y up: (x, z, y)
            // is left-handed, so the band runs a_j → a_i → b_i.
            m.add_face([a[j], a[i], b[i]], rings[k].band);
            m.add_face([a[j], b[i], b[j]], rings[k].band);
        }
    }
    let tris = ear_clip(profile);
    let bottom = &ids[0];
    for t in &tris {
        m.add_face([bottom[t[0]], bottom[t[1]], bottom[t[2]]], 0);
    }
    let last = ids.last().unwrap();
    match apex {
        Some(p) => {
            let c = m.add_vertex(p);
            for i in 0..n {
                m.add_face([last[(i + 1) % n], last[i], c], rings.last().unwrap().band);
            }
        }
        None => {
            for &v in last {
                m.positions[v as usize] = lift(m.positions[v as usize]);
            }
            for t in &tris {
                m.add_face([last[t[0]], last[t[2]], last[t[1]]], top);
            }
        }
    }
}

/// A straight prism: `profile` (about `centre`) extruded from y = 0 to y = `h`,
/// capped at both ends.
pub fn prism(m: &mut EditMesh, profile: &[[f64; 2]], centre: [f64; 2], h: f64) {
    loft(
        m,
        &[
            ring(profile, 1.0, centre, 0.0, 0),
            ring(profile, 1.0, centre, h, 0),
        ],
        profile,
        0,
        None,
        |q| q,
    );
}

/// A ring of `profile` scaled by `s` about `(cx, cz)` at height `y`.
pub fn ring(profile: &[[f64; 2]], s: f64, centre: [f64; 2], y: f64, band: u16) -> Ring {
    Ring {
        points: profile
            .iter()
            .map(|q| {
                [
                    centre[0] + s * (q[0] - centre[0]),
                    y,
                    centre[1] + s * (q[1] - centre[1]),
                ]
            })
            .collect(),
        band,
    }
}

/// The icosahedron inscribed in the unit sphere, counter-clockwise faces.
pub fn icosahedron(m: &mut EditMesh, tag: u16) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let raw = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let base = m.positions.len() as u32;
    for p in raw {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        m.add_vertex([p[0] / l, p[1] / l, p[2] / l]);
    }
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for f in faces {
        m.add_face(f.map(|v: u32| v + base), tag);
    }
}

/// Convenience for the [`Surface::Cone`] of a ring pair.
pub fn cone_surface(centre: [f64; 2], y0: f64, r0: f64, y1: f64, r1: f64) -> Surface {
    Surface::Cone {
        cx: centre[0],
        cz: centre[1],
        y0,
        r0,
        y1,
        r1,
    }
}

/// A convex polyhedron: its vertices and its facets (vertex indices,
/// counter-clockwise seen from outside).
pub struct ConvexPolyhedron {
    /// corner points
    pub vertices: Vec<Vec3>,
    /// one polygon per facet
    pub facets: Vec<Vec<usize>>,
}

impl ConvexPolyhedron {
    /// The intersection of the half-spaces `n·x ≤ d` of `planes` (unit
    /// normal `n`, offset `d > 0`: the origin is inside). By polar duality
    /// its corners are the facets of the convex hull of the points `n / d`
    /// (a corner `x` solves `n·x = d` for the three planes of a hull
    /// triangle) and its facets are the hull's vertices (a plane whose point
    /// is inside the hull is redundant). `None` when the planes do not bound
    /// a polyhedron (the origin is not strictly inside the hull) or four
    /// points are nearly coplanar (a corner shared by four planes).
    pub fn from_planes(planes: &[(Vec3, f64)]) -> Option<ConvexPolyhedron> {
        if planes.len() < 4 || planes.iter().any(|&(_, d)| d.is_nan() || d <= 0.0) {
            return None;
        }
        let p: Vec<Vec3> = planes
            .iter()
            .map(|&(n, d)| vec3::scale(n, 1.0 / d))
            .collect();
        let eps = 1e-9 * p.iter().map(|q| vec3::norm(*q)).fold(0.0, f64::max).powi(3);
        // hull triangles by brute force (a few dozen planes at most)
        let mut corners: Vec<([usize; 3], Vec3)> = Vec::new();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                for k in j + 1..p.len() {
                    let normal = vec3::cross(vec3::sub(p[j], p[i]), vec3::sub(p[k], p[i]));
                    let (mut above, mut below, mut on) = (false, false, false);
                    for (l, q) in p.iter().enumerate() {
                        if l == i || l == j || l == k {
                            continue;
                        }
                        let s = vec3::dot(normal, vec3::sub(*q, p[i]));
                        above |= s > eps;
                        below |= s < -eps;
                        on |= s.abs() <= eps;
                    }
                    if above && below {
                        continue;
                    }
                    if on {
                        // a hull face through four points: four planes
                        // meet at one corner
                        return None;
                    }
                    let outward = if above {
                        vec3::scale(normal, -1.0)
                    } else {
                        normal
                    };
                    let c = vec3::dot(outward, p[i]);
                    if c <= eps {
                        return None;
                    }
                    corners.push(([i, j, k], vec3::scale(outward, 1.0 / c)));
                }
            }
        }
        let mut facets = Vec::new();
        for (i, &(n, _)) in planes.iter().enumerate() {
            let mut ring: Vec<usize> = (0..corners.len())
                .filter(|&c| corners[c].0.contains(&i))
                .collect();
            if ring.is_empty() {
                continue;
            }
            if ring.len() < 3 {
                return None;
            }
            let centre = centroid(ring.iter().map(|&c| corners[c].1));
            let u = vec3::normalize_or_zero(vec3::cross(
                n,
                if n[0].abs() < 0.9 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0]
                },
            ));
            let v = vec3::cross(n, u);
            let angle = |c: usize| {
                let q = vec3::sub(corners[c].1, centre);
                vec3::dot(q, v).atan2(vec3::dot(q, u))
            };
            ring.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)));
            facets.push(ring);
        }
        Some(ConvexPolyhedron {
            vertices: corners.into_iter().map(|(_, x)| x).collect(),
            facets,
        })
    }

    /// The shortest edge.
    pub fn shortest_edge(&self) -> f64 {
        self.facets
            .iter()
            .flat_map(|f| (0..f.len()).map(move |a| (f[a], f[(a + 1) % f.len()])))
            .map(|(a, b)| vec3::dist2(self.vertices[a], self.vertices[b]).sqrt())
            .fold(f64::INFINITY, f64::min)
    }

    /// The smallest and the largest interior angle of a facet corner, in
    /// degrees (near 0°: a needle; near 180°: a corner that barely bends the
    /// facet's outline).
    pub fn corner_angles(&self) -> (f64, f64) {
        let (mut smallest, mut largest) = (180.0f64, 0.0f64);
        for f in &self.facets {
            for a in 0..f.len() {
                let at = self.vertices[f[a]];
                let prev = vec3::sub(self.vertices[f[(a + f.len() - 1) % f.len()]], at);
                let next = vec3::sub(self.vertices[f[(a + 1) % f.len()]], at);
                let angle = vec3::angle(prev, next).to_degrees();
                smallest = smallest.min(angle);
                largest = largest.max(angle);
            }
        }
        (smallest, largest)
    }

    /// Adds the polyhedron to `m`: each facet a fan of triangles about its
    /// centroid, tag 0 (planar).
    pub fn add_to(&self, m: &mut EditMesh) {
        let ids: Vec<u32> = self.vertices.iter().map(|&x| m.add_vertex(x)).collect();
        for f in &self.facets {
            let centre = centroid(f.iter().map(|&c| self.vertices[c]));
            let c = m.add_vertex(centre);
            for a in 0..f.len() {
                m.add_face([c, ids[f[a]], ids[f[(a + 1) % f.len()]]], 0);
            }
        }
    }
}

/// The mean of `points`.
fn centroid(points: impl ExactSizeIterator<Item = Vec3>) -> Vec3 {
    let count = points.len() as f64;
    vec3::scale(points.fold([0.0; 3], vec3::add), 1.0 / count)
}
