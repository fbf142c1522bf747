//! `EditMesh`: a closed triangle mesh under local edits (midpoint edge
//! splits, edge flips, in-plane vertex moves), kept manifold through a
//! directed-edge map. Used only to build procedural shapes: splits keep the
//! piecewise-linear surface exactly (or move the new vertex onto the smooth
//! surface it samples), flips are allowed only where they keep the surface.

use super::surface::Surface;
use normalnet_mesh::vec3::{self, Vec3};
use rand::Rng;
use std::collections::{BinaryHeap, HashMap};

/// A triangle mesh with per-face surface tags and a directed-edge map.
#[derive(Clone, Debug, Default)]
pub struct EditMesh {
    /// vertex positions
    pub positions: Vec<Vec3>,
    /// faces, counter-clockwise seen from outside
    pub faces: Vec<[u32; 3]>,
    /// index into `surfaces` per face
    pub tags: Vec<u16>,
    /// the surfaces the faces sample (`surfaces[0]` is the plane tag)
    pub surfaces: Vec<Surface>,
    half: HashMap<(u32, u32), u32>,
}

impl EditMesh {
    /// An empty mesh whose tag 0 means "planar face".
    pub fn new() -> EditMesh {
        EditMesh {
            surfaces: vec![Surface::Plane],
            ..Default::default()
        }
    }

    /// Adds a surface, returns its tag.
    pub fn add_surface(&mut self, s: Surface) -> u16 {
        self.surfaces.push(s);
        (self.surfaces.len() - 1) as u16
    }

    /// Adds a vertex.
    pub fn add_vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Adds a face (no checks; see [`Self::is_closed_manifold`]).
    pub fn add_face(&mut self, f: [u32; 3], tag: u16) {
        self.faces.push(f);
        self.tags.push(tag);
        let i = (self.faces.len() - 1) as u32;
        self.register(i);
    }

    fn register(&mut self, f: u32) {
        let t = self.faces[f as usize];
        for k in 0..3 {
            self.half.insert((t[k], t[(k + 1) % 3]), f);
        }
    }

    /// Every directed edge is used once and has its twin.
    pub fn is_closed_manifold(&self) -> bool {
        self.half.len() == 3 * self.faces.len()
            && self
                .half
                .keys()
                .all(|&(a, b)| self.half.contains_key(&(b, a)))
    }

    /// Reverses every face.
    pub fn flip_orientation(&mut self) {
        for t in &mut self.faces {
            t.swap(1, 2);
        }
        self.half.clear();
        for f in 0..self.faces.len() as u32 {
            self.register(f);
        }
    }

    /// Six times the signed volume enclosed.
    pub fn signed_volume6(&self) -> f64 {
        self.faces
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| self.positions[v as usize]);
                vec3::dot(a, vec3::cross(b, c))
            })
            .sum()
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        (0..self.faces.len())
            .map(|f| 0.5 * vec3::norm(self.raw_normal(f)))
            .sum()
    }

    fn raw_normal(&self, f: usize) -> Vec3 {
        let [a, b, c] = self.faces[f].map(|v| self.positions[v as usize]);
        vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
    }

    /// `(c, f)`: the face `f` holding the directed edge `a → b` and its third vertex `c`.
    fn wing(&self, a: u32, b: u32) -> Option<(u32, u32)> {
        let f = *self.half.get(&(a, b))?;
        let t = self.faces[f as usize];
        let c = t.into_iter().find(|&v| v != a && v != b)?;
        Some((c, f))
    }

    fn set_face(&mut self, f: u32, t: [u32; 3]) {
        self.faces[f as usize] = t;
        self.register(f);
    }

    /// Splits edge `(a, b)` at its midpoint, moved onto the surfaces of the
    /// two faces. Returns the new vertex.
    pub fn split(&mut self, a: u32, b: u32) -> Option<u32> {
        let (c, f1) = self.wing(a, b)?;
        let (d, f2) = self.wing(b, a)?;
        let (t1, t2) = (self.tags[f1 as usize], self.tags[f2 as usize]);
        let pa = self.positions[a as usize];
        let pb = self.positions[b as usize];
        let mut m = vec3::scale(vec3::add(pa, pb), 0.5);
        for _ in 0..2 {
            m = self.surfaces[t1 as usize].project(m);
            if t2 != t1 {
                m = self.surfaces[t2 as usize].project(m);
            }
        }
        let v = self.add_vertex(m);
        self.half.remove(&(a, b));
        self.half.remove(&(b, a));
        self.set_face(f1, [a, v, c]);
        self.faces.push([v, b, c]);
        self.tags.push(t1);
        self.register((self.faces.len() - 1) as u32);
        self.set_face(f2, [b, v, d]);
        self.faces.push([v, a, d]);
        self.tags.push(t2);
        self.register((self.faces.len() - 1) as u32);
        Some(v)
    }

    /// May edge `(a, b)` be flipped without changing the surface much: same
    /// tag, coplanar faces (or the same smooth surface within 15°), a convex
    /// quad, no existing edge `(c, d)`, and new angles of at least
    /// `min_angle` degrees? Returns `(c, d)` if so.
    fn flippable(&self, a: u32, b: u32, min_angle: f64) -> Option<(u32, u32, u32, u32)> {
        let (c, f1) = self.wing(a, b)?;
        let (d, f2) = self.wing(b, a)?;
        if c == d || self.half.contains_key(&(c, d)) || self.half.contains_key(&(d, c)) {
            return None;
        }
        let (t1, t2) = (self.tags[f1 as usize], self.tags[f2 as usize]);
        if t1 != t2 {
            return None;
        }
        let n1 = vec3::normalize_or_zero(self.raw_normal(f1 as usize));
        let n2 = vec3::normalize_or_zero(self.raw_normal(f2 as usize));
        let limit = if t1 == 0 {
            1.0 - 1e-10
        } else {
            15f64.to_radians().cos()
        };
        if vec3::dot(n1, n2) < limit {
            return None;
        }
        let p = |v: u32| self.positions[v as usize];
        let navg = vec3::normalize_or_zero(vec3::add(n1, n2));
        for t in [[a, d, c], [d, b, c]] {
            let n = vec3::cross(vec3::sub(p(t[1]), p(t[0])), vec3::sub(p(t[2]), p(t[0])));
            if vec3::dot(vec3::normalize_or_zero(n), navg) < 0.5 {
                return None;
            }
            if min_triangle_angle(p(t[0]), p(t[1]), p(t[2])) < min_angle {
                return None;
            }
        }
        Some((c, d, f1, f2))
    }

    fn do_flip(&mut self, a: u32, b: u32, c: u32, d: u32, f1: u32, f2: u32) {
        self.half.remove(&(a, b));
        self.half.remove(&(b, a));
        self.set_face(f1, [a, d, c]);
        self.set_face(f2, [d, b, c]);
    }

    /// Undirected edges `(a, b)`, `a < b`, sorted (deterministic order).
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut e: Vec<(u32, u32)> = self.half.keys().filter(|(a, b)| a < b).copied().collect();
        e.sort_unstable();
        e
    }

    /// Splits the longest edges until every edge is at most `target(midpoint)`
    /// long (longest-edge bisection). Stops at `max_faces`.
    pub fn refine(&mut self, target: impl Fn(Vec3) -> f64, max_faces: usize) {
        let mut heap: BinaryHeap<(u64, u32, u32)> = BinaryHeap::new();
        let len = |m: &EditMesh, a: u32, b: u32| {
            vec3::dist2(m.positions[a as usize], m.positions[b as usize]).sqrt()
        };
        for (a, b) in self.edges() {
            heap.push((len(self, a, b).to_bits(), a, b));
        }
        while let Some((l, a, b)) = heap.pop() {
            if self.faces.len() >= max_faces {
                break;
            }
            if !self.half.contains_key(&(a, b)) {
                continue;
            }
            let l = f64::from_bits(l);
            let mid = vec3::scale(
                vec3::add(self.positions[a as usize], self.positions[b as usize]),
                0.5,
            );
            if l <= target(mid) {
                continue;
            }
            let (c, _) = self.wing(a, b).expect("edge without face");
            let (d, _) = self.wing(b, a).expect("edge without twin");
            if let Some(v) = self.split(a, b) {
                for w in [a, b, c, d] {
                    let (p, q) = if w < v { (w, v) } else { (v, w) };
                    heap.push((len(self, p, q).to_bits(), p, q));
                }
            }
        }
    }

    /// Lawson flips towards a Delaunay triangulation inside each planar
    /// region and smooth surface (a few sweeps).
    pub fn delaunay_flips(&mut self, sweeps: usize) {
        for _ in 0..sweeps {
            let mut flipped = 0;
            for (a, b) in self.edges() {
                if let Some((c, d, f1, f2)) = self.flippable(a, b, 0.0) {
                    let p = |v: u32| self.positions[v as usize];
                    let opposite = angle_at(p(c), p(a), p(b)) + angle_at(p(d), p(a), p(b));
                    if opposite > std::f64::consts::PI + 1e-9 {
                        self.do_flip(a, b, c, d, f1, f2);
                        flipped += 1;
                    }
                }
            }
            if flipped == 0 {
                break;
            }
        }
    }

    /// Flips each edge with probability `p` where that keeps the surface
    /// and leaves angles of at least `min_angle` degrees.
    pub fn random_flips<R: Rng>(&mut self, p: f64, min_angle: f64, rng: &mut R) {
        for (a, b) in self.edges() {
            if rng.random_bool(p)
                && let Some((c, d, f1, f2)) = self.flippable(a, b, min_angle)
            {
                self.do_flip(a, b, c, d, f1, f2);
            }
        }
    }

    /// Moves vertices whose faces are all coplanar within their plane by up
    /// to `amount` × their shortest edge, keeping orientation and angles of
    /// at least `min_angle` degrees.
    #[allow(clippy::needless_range_loop)]
    pub fn jitter_planar<R: Rng>(&mut self, amount: f64, min_angle: f64, rng: &mut R) {
        let nv = self.positions.len();
        let mut vf: Vec<Vec<u32>> = vec![Vec::new(); nv];
        for (f, t) in self.faces.iter().enumerate() {
            for &v in t {
                vf[v as usize].push(f as u32);
            }
        }
        for v in 0..nv {
            let fs = &vf[v];
            if fs.is_empty() || fs.iter().any(|&f| self.tags[f as usize] != 0) {
                continue;
            }
            let n0 = vec3::normalize_or_zero(self.raw_normal(fs[0] as usize));
            if fs.iter().any(|&f| {
                vec3::dot(vec3::normalize_or_zero(self.raw_normal(f as usize)), n0) < 1.0 - 1e-12
            }) {
                continue;
            }
            let p0 = self.positions[v];
            let shortest = fs
                .iter()
                .flat_map(|&f| self.faces[f as usize])
                .filter(|&w| w as usize != v)
                .map(|w| vec3::dist2(self.positions[w as usize], p0).sqrt())
                .fold(f64::INFINITY, f64::min);
            // A random in-plane direction.
            let r = [0; 3].map(|_| rng.random_range(-1.0..1.0));
            let t = vec3::sub(r, vec3::scale(n0, vec3::dot(r, n0)));
            let t = vec3::normalize_or_zero(t);
            let step = amount * shortest * rng.random_range(0.0..1.0);
            self.positions[v] = vec3::add(p0, vec3::scale(t, step));
            let ok = fs.iter().all(|&f| {
                let [a, b, c] = self.faces[f as usize].map(|w| self.positions[w as usize]);
                let n = vec3::normalize_or_zero(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)));
                vec3::dot(n, n0) > 0.999 && min_triangle_angle(a, b, c) >= min_angle
            });
            if !ok {
                self.positions[v] = p0;
            }
        }
    }

    /// Applies `f` to every position (surfaces are not updated: call after
    /// the last split, or use [`Self::translate`]).
    pub fn transform(&mut self, f: impl Fn(Vec3) -> Vec3) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }

    /// Moves positions and surfaces by `t`.
    pub fn translate(&mut self, t: Vec3) {
        self.transform(|p| vec3::add(p, t));
        for s in &mut self.surfaces {
            *s = s.translated(t);
        }
    }

    /// Axis-aligned bounding box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    }

    /// Appends another mesh (its surfaces re-tagged).
    pub fn append(&mut self, other: &EditMesh) {
        let vo = self.positions.len() as u32;
        let so = self.surfaces.len() as u16 - 1;
        self.positions.extend_from_slice(&other.positions);
        self.surfaces.extend(other.surfaces.iter().skip(1).cloned());
        for (t, &tag) in other.faces.iter().zip(&other.tags) {
            let tag = if tag == 0 { 0 } else { tag + so };
            self.add_face(t.map(|v| v + vo), tag);
        }
    }

    /// Smallest angle in degrees and smallest area over all faces.
    pub fn quality(&self) -> (f64, f64) {
        let mut min_angle = f64::INFINITY;
        let mut min_area = f64::INFINITY;
        for f in 0..self.faces.len() {
            let [a, b, c] = self.faces[f].map(|v| self.positions[v as usize]);
            min_angle = min_angle.min(min_triangle_angle(a, b, c));
            min_area = min_area.min(0.5 * vec3::norm(self.raw_normal(f)));
        }
        (min_angle, min_area)
    }
}

/// Angle at `p` of the triangle `(p, q, r)`, radians.
fn angle_at(p: Vec3, q: Vec3, r: Vec3) -> f64 {
    vec3::angle(vec3::sub(q, p), vec3::sub(r, p))
}

/// Smallest angle of a triangle in degrees (0 when degenerate).
pub fn min_triangle_angle(a: Vec3, b: Vec3, c: Vec3) -> f64 {
    if vec3::norm2(vec3::cross(vec3::sub(b, a), vec3::sub(c, a))) == 0.0 {
        return 0.0;
    }
    angle_at(a, b, c)
        .min(angle_at(b, c, a))
        .min(angle_at(c, a, b))
        .to_degrees()
}
