//! The final fold check and repair (issue 39): after a method's last vertex
//! update, faces that folded over are found without the ground truth and
//! the moves of their vertices are redirected or shortened, so that no
//! method leaves more folded faces than its input had. Run once by
//! `normalnet_denoise::Denoiser::run` after every method (nothing to add
//! for a new one); not part of any paper.
//!
//! **Folded face** ([`FoldCheck::is_folded`]). With `n_f` the unit normal of
//! face f in the result (zero when degenerate), `r_f` its *reference
//! normal*, the area-weighted mean normal of f and its 1-ring (the faces
//! sharing a vertex with it) **in the input**, normalised, and `s_f` the sum
//! of the result's unit normals over the 1-ring (f left out), f is folded
//! when
//! - `n_f · s_f < 0`: it opposes its neighbours, or
//! - `n_f · r_f <` [`FOLD_CONE_COS`]: it turned more than 75.5° from the
//!   input's local orientation, or
//! - it collapsed to a sliver (area below [`SLIVER_AREA`] of its input
//!   area) and turned more than 60° from `r_f` ([`SLIVER_CONE_COS`]): the
//!   edge-on triangles a vertex update leaves astride a sharp edge.
//!
//! Counted the same way on the input, this is what a user without ground
//! truth can check ([`FoldCheck::count`]). On noise-0.3 cow, spot, homer and
//! the gd pairs it finds the faces that oppose the ground truth after
//! denoising, and a noisy input always has more of them than a denoised one.
//!
//! **Repair** ([`repair_folds`]), in rounds (at most [`REPAIR_ROUNDS`]):
//! 1. every vertex of a folded face that the method moved (in increasing
//!    index order, one after another) tries, in turn, 1, 1/2 and 1/4 of
//!    the way to the mean of its neighbour vertices, then 1/2 and all of the
//!    way back to its input position (the method's move shortened or
//!    rejected); it takes the first position that lowers the number of
//!    folded faces in its 2-ring (the faces whose verdict it can change) and
//!    turns no unfolded face around it more than 60° (from where it was, nor
//!    below `min(n_f · r_f, cos 60°)`);
//! 2. when no vertex moved, each cluster of folded faces (connected through
//!    shared vertices) is smoothed as a whole, its moved vertices to the mean
//!    of their neighbours, up to [`CLUSTER_SMOOTHINGS`] times, keeping the
//!    first that lowers the count around the cluster.
//!
//! Every accepted step lowers the total count, so the result has no more
//! folded faces than the method's output. If it still had more than the
//! input (never seen on the meshes above), the moves of the vertices around
//! the faces folded now but not in the input are halved, up to three times
//! and then undone, until it has no more: a face whose vertices and
//! neighbours' vertices are back at their input positions has the input's
//! verdict, so this ends, and then the result has no more folded faces than
//! the input. Vertices the method did not move (outliers, fixed boundaries)
//! never move.
//!
//! Cost: two passes over the faces (parallel, pure per face), then work in
//! proportion to the folded faces (sequential, so the result does not
//! depend on the thread count); nothing when no face is folded.

use normalnet_mesh::outliers::{OutlierParams, outlier_vertices, without_vertices};
use normalnet_mesh::vec3::{self, Vec3, add, cross, dot, scale, sub};
use normalnet_mesh::{Mesh, Topology};
use rayon::prelude::*;

/// A face folds when it turns farther than `acos(FOLD_CONE_COS)` = 75.5°
/// from its reference normal (module docs). Chosen on noise-0.3 cow, spot,
/// homer, the shipped example, Fandisk0.3, Block0.4, Twelve0.5Impulsive
/// (0: the flip itself only, half the folds against the ground truth stay
/// on Block0.4; 0.5: E_a up to +0.5° on the shipped CAD part).
pub const FOLD_CONE_COS: f64 = 0.25;

/// A sliver: a face whose area fell below this fraction of its input area.
pub const SLIVER_AREA: f64 = 0.1;

/// A sliver folds when it turns farther than `acos(SLIVER_CONE_COS)` = 60°
/// from its reference normal.
pub const SLIVER_CONE_COS: f64 = 0.5;

/// A repair step may not turn an unfolded face more than
/// `acos(STEP_TURN_COS)` = 60°, nor below `min(n_f · r_f, STEP_TURN_COS)`.
const STEP_TURN_COS: f64 = 0.5;

/// At most this many rounds of the repair.
pub const REPAIR_ROUNDS: usize = 10;

/// At most this many smoothings of one cluster of folded faces.
pub const CLUSTER_SMOOTHINGS: usize = 5;

/// What [`repair_folds`] found and did (folded faces as in the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FoldReport {
    /// folded faces of the input
    pub input: usize,
    /// folded faces of the method's result
    pub before: usize,
    /// folded faces after the repair (at most `input`, at most `before`)
    pub after: usize,
    /// vertices the repair moved
    pub moved: usize,
    /// whether the last resort (moves halved towards the input) ran
    pub shortened: bool,
}

/// The input's side of the fold test: reference normals and areas.
#[derive(Clone, Debug)]
pub struct FoldCheck<'a> {
    faces: &'a [[u32; 3]],
    topology: &'a Topology,
    /// r_f: the input's area-weighted 1-ring mean normal (len #F)
    reference: Vec<Vec3>,
    /// the input's face areas ×2 (len #F)
    input_areas: Vec<f64>,
}

/// Unit normal (zero when degenerate) and twice the area of a triangle.
#[inline]
fn normal_area(p: &[Vec3], t: &[u32; 3]) -> (Vec3, f64) {
    let a = p[t[0] as usize];
    let c = cross(sub(p[t[1] as usize], a), sub(p[t[2] as usize], a));
    let l = vec3::norm(c);
    if l > 0.0 && l.is_finite() {
        (scale(c, 1.0 / l), l)
    } else {
        ([0.0; 3], 0.0)
    }
}

/// Unit normals and doubled areas of every face (parallel, pure per face).
fn normals_areas(p: &[Vec3], faces: &[[u32; 3]]) -> (Vec<Vec3>, Vec<f64>) {
    faces
        .par_iter()
        .with_min_len(1024)
        .map(|t| normal_area(p, t))
        .unzip()
}

impl<'a> FoldCheck<'a> {
    /// The fold test against `input` positions (len #V) of `faces`, whose
    /// `topology` is given.
    ///
    /// # Panics
    /// If `topology` was built for other faces or another vertex count.
    pub fn new(input: &[Vec3], faces: &'a [[u32; 3]], topology: &'a Topology) -> FoldCheck<'a> {
        assert_eq!(
            topology.num_faces(),
            faces.len(),
            "topology of another mesh"
        );
        assert_eq!(
            topology.num_vertices,
            input.len(),
            "topology of another mesh"
        );
        let (n, input_areas) = normals_areas(input, faces);
        let reference = (0..faces.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|f| {
                let mut sum = scale(n[f], input_areas[f]);
                for &g in topology.face_neighbours.row(f) {
                    sum = add(sum, scale(n[g as usize], input_areas[g as usize]));
                }
                vec3::normalize_or_zero(sum)
            })
            .collect();
        FoldCheck {
            faces,
            topology,
            reference,
            input_areas,
        }
    }

    /// Whether face `f` is folded (module docs), given the unit `normals`
    /// and doubled `areas` of every face of the positions tested.
    pub fn is_folded(&self, normals: &[Vec3], areas: &[f64], f: usize) -> bool {
        let n_f = normals[f];
        let d = dot(n_f, self.reference[f]);
        if d < FOLD_CONE_COS
            || (d < SLIVER_CONE_COS && areas[f] < SLIVER_AREA * self.input_areas[f])
        {
            return true;
        }
        let mut s = [0.0; 3];
        for &g in self.topology.face_neighbours.row(f) {
            s = add(s, normals[g as usize]);
        }
        dot(s, n_f) < 0.0
    }

    /// One flag per face: folded at `positions` (len #V).
    pub fn folded(&self, positions: &[Vec3]) -> Vec<bool> {
        let (n, a) = normals_areas(positions, self.faces);
        (0..self.faces.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|f| self.is_folded(&n, &a, f))
            .collect()
    }

    /// The number of folded faces at `positions` (len #V).
    pub fn count(&self, positions: &[Vec3]) -> usize {
        self.folded(positions).iter().filter(|&&b| b).count()
    }
}

/// How many of `mesh`'s faces are folded by themselves: the [`FoldCheck`]
/// of its own positions against themselves (a degenerate face, whose
/// normal is zero, counts as folded). Noise along the normals folds few
/// faces (fish at 0.1 l_e: 0.01 %); noise with a tangential part (random
/// directions, a scanner's view direction) folds many (springer, random
/// directions at 0.5 l_e: 27 %). `normalnet info` prints it; NormalNet's
/// switch reads the per-face flags
/// (`normalnet_net::switch::Candidates::folded`).
pub fn self_folded_faces(mesh: &Mesh, topology: &Topology) -> usize {
    FoldCheck::new(&mesh.positions, &mesh.faces, topology).count(&mesh.positions)
}

/// [`repair_folds`] on `input` without its outlier vertices
/// (`normalnet_mesh::outliers`, default thresholds), as the methods denoise
/// it ([`crate::denoise`]): the faces touching an outlier take no part, so
/// no vertex is pulled towards a stray one. `output` is the method's result
/// for `input` (same vertices and faces), repaired in place. The one entry
/// point of `normalnet_denoise::Denoiser::run`.
///
/// # Panics
/// If `output` has another vertex count than `input`.
pub fn repair_mesh_folds(input: &Mesh, output: &mut [Vec3]) -> FoldReport {
    assert_eq!(
        input.positions.len(),
        output.len(),
        "one position per vertex"
    );
    let outliers = outlier_vertices(input, &OutlierParams::default());
    let inner = if outliers.count() == 0 {
        None
    } else {
        without_vertices(input, &outliers.mask)
    };
    let Some((inner, kept)) = inner else {
        let topology = Topology::new(input.num_vertices(), &input.faces);
        return repair_folds(input, output, &topology);
    };
    let topology = Topology::new(inner.num_vertices(), &inner.faces);
    let mut inner_output: Vec<Vec3> = kept.iter().map(|&v| output[v as usize]).collect();
    let report = repair_folds(&inner, &mut inner_output, &topology);
    for (&v, &p) in kept.iter().zip(&inner_output) {
        output[v as usize] = p;
    }
    report
}

/// Repairs the folds of `output` (the positions a method returned for
/// `input`, same faces; len #V), in place: module docs. Returns what it
/// found and did.
///
/// # Panics
/// If `output` and `input` differ in vertex count or `topology` is not the
/// input's.
pub fn repair_folds(input: &Mesh, output: &mut [Vec3], topology: &Topology) -> FoldReport {
    assert_eq!(
        input.positions.len(),
        output.len(),
        "one position per vertex"
    );
    let check = FoldCheck::new(&input.positions, &input.faces, topology);
    let count_input = check.count(&input.positions);
    let mut repair = Repair::new(&check, &input.positions, output);
    let before = repair.folded_faces().len();
    let mut report = FoldReport {
        input: count_input,
        before,
        after: before,
        ..FoldReport::default()
    };
    if before == 0 {
        return report;
    }
    for _ in 0..REPAIR_ROUNDS {
        let folded = repair.folded_faces();
        if folded.is_empty() {
            break;
        }
        let mut vertices: Vec<u32> = folded
            .iter()
            .flat_map(|&f| input.faces[f as usize])
            .filter(|&v| repair.movable[v as usize])
            .collect();
        vertices.sort_unstable();
        vertices.dedup();
        let mut moved = 0;
        for &v in &vertices {
            moved += repair.try_vertex(v as usize) as usize;
        }
        if moved == 0 {
            moved = repair.smooth_clusters(&folded);
        }
        if moved == 0 {
            break;
        }
    }
    let mut after = repair.folded_faces().len();
    if after > count_input {
        shorten_towards_input(&check, &input.positions, &mut repair.p, count_input);
        report.shortened = true;
        after = check.count(&repair.p);
    }
    report.after = after;
    report.moved = repair
        .p
        .iter()
        .zip(output.iter())
        .filter(|(a, b)| a != b)
        .count();
    output.copy_from_slice(&repair.p);
    report
}

/// The last resort of [`repair_folds`]: halves (up to three times, then
/// undoes) the moves from `input` of the vertices around faces folded at
/// `p` but not in the input, until at most `target` faces are folded.
fn shorten_towards_input(check: &FoldCheck, input: &[Vec3], p: &mut [Vec3], target: usize) {
    let folded_input = check.folded(input);
    let steps: Vec<Vec3> = p.iter().zip(input).map(|(&x, &x0)| sub(x, x0)).collect();
    let mut halvings = vec![0u8; p.len()];
    let mut mark = vec![false; check.faces.len()];
    loop {
        let folded = check.folded(p);
        if folded.iter().filter(|&&b| b).count() <= target {
            return;
        }
        let mut vertices = Vec::new();
        for f in (0..folded.len()).filter(|&f| folded[f] && !folded_input[f]) {
            for g in std::iter::once(f as u32)
                .chain(check.topology.face_neighbours.row(f).iter().copied())
            {
                if !mark[g as usize] {
                    mark[g as usize] = true;
                    vertices.extend(check.faces[g as usize]);
                }
            }
        }
        mark.iter_mut().for_each(|m| *m = false);
        vertices.sort_unstable();
        vertices.dedup();
        vertices.retain(|&v| halvings[v as usize] <= 3);
        if vertices.is_empty() {
            // Unreachable: a face folded now but not in the input has a
            // vertex around it away from its input position.
            return;
        }
        for &v in &vertices {
            let v = v as usize;
            halvings[v] += 1;
            p[v] = if halvings[v] > 3 {
                input[v]
            } else {
                add(input[v], scale(steps[v], 0.5f64.powi(halvings[v] as i32)))
            };
        }
    }
}

/// The state of one repair: current positions, their face normals and
/// areas, scratch marks.
struct Repair<'c, 'a> {
    check: &'c FoldCheck<'a>,
    input: &'c [Vec3],
    p: Vec<Vec3>,
    n: Vec<Vec3>,
    areas: Vec<f64>,
    /// vertices the method moved (and that have faces): only these move
    movable: Vec<bool>,
    mark: Vec<bool>,
}

impl<'c, 'a> Repair<'c, 'a> {
    fn new(check: &'c FoldCheck<'a>, input: &'c [Vec3], output: &[Vec3]) -> Repair<'c, 'a> {
        let (n, areas) = normals_areas(output, check.faces);
        let movable = (0..output.len())
            .map(|v| output[v] != input[v] && !check.topology.vertex_faces.row(v).is_empty())
            .collect();
        Repair {
            check,
            input,
            p: output.to_vec(),
            n,
            areas,
            movable,
            mark: vec![false; check.faces.len()],
        }
    }

    fn folded_faces(&self) -> Vec<u32> {
        (0..self.check.faces.len() as u32)
            .into_par_iter()
            .with_min_len(1024)
            .filter(|&f| self.check.is_folded(&self.n, &self.areas, f as usize))
            .collect()
    }

    fn is_folded(&self, f: u32) -> bool {
        self.check.is_folded(&self.n, &self.areas, f as usize)
    }

    /// Recomputes the normals and areas of the faces around `vertices`.
    fn refresh(&mut self, star: &[u32]) {
        for &f in star {
            let (n, a) = normal_area(&self.p, &self.check.faces[f as usize]);
            self.n[f as usize] = n;
            self.areas[f as usize] = a;
        }
    }

    /// The faces around `vertices` (their star) and the faces whose verdict
    /// they can change (the star and its 1-ring), each once.
    fn star_and_region(&mut self, vertices: &[u32]) -> (Vec<u32>, Vec<u32>) {
        let topology = self.check.topology;
        let mut star = Vec::new();
        for &v in vertices {
            for &f in topology.vertex_faces.row(v as usize) {
                if !self.mark[f as usize] {
                    self.mark[f as usize] = true;
                    star.push(f);
                }
            }
        }
        let mut region = star.clone();
        for &f in &star {
            for &g in topology.face_neighbours.row(f as usize) {
                if !self.mark[g as usize] {
                    self.mark[g as usize] = true;
                    region.push(g);
                }
            }
        }
        for &f in &region {
            self.mark[f as usize] = false;
        }
        (star, region)
    }

    fn count(&self, region: &[u32]) -> usize {
        region.iter().filter(|&&f| self.is_folded(f)).count()
    }

    /// The mean of the vertices sharing a face with `v` (`v` left out).
    fn umbrella(&self, v: usize) -> Vec3 {
        let mut ring: Vec<u32> = self
            .check
            .topology
            .vertex_faces
            .row(v)
            .iter()
            .flat_map(|&f| self.check.faces[f as usize])
            .filter(|&w| w as usize != v)
            .collect();
        ring.sort_unstable();
        ring.dedup();
        let mut sum = [0.0; 3];
        for &w in &ring {
            sum = add(sum, self.p[w as usize]);
        }
        scale(sum, 1.0 / ring.len() as f64)
    }

    /// Step 1 of the repair for vertex `v` (module docs); whether it moved.
    fn try_vertex(&mut self, v: usize) -> bool {
        let (star, region) = self.star_and_region(&[v as u32]);
        let before = self.count(&region);
        if before == 0 {
            return false;
        }
        let x = self.p[v];
        let saved: Vec<(Vec3, f64, bool)> = star
            .iter()
            .map(|&f| {
                (
                    self.n[f as usize],
                    self.areas[f as usize],
                    self.is_folded(f),
                )
            })
            .collect();
        let u = self.umbrella(v);
        let x0 = self.input[v];
        let candidates = [(u, 1.0), (u, 0.5), (u, 0.25), (x0, 0.5), (x0, 1.0)];
        for (target, t) in candidates {
            self.p[v] = add(x, scale(sub(target, x), t));
            self.refresh(&star);
            let keeps_others = star.iter().zip(&saved).all(|(&f, &(n0, _, folded0))| {
                let n = self.n[f as usize];
                let r = self.check.reference[f as usize];
                folded0
                    || (dot(n, n0) >= STEP_TURN_COS && dot(n, r) >= dot(n0, r).min(STEP_TURN_COS))
            });
            if keeps_others && self.count(&region) < before {
                return true;
            }
        }
        self.p[v] = x;
        for (&f, &(n, a, _)) in star.iter().zip(&saved) {
            self.n[f as usize] = n;
            self.areas[f as usize] = a;
        }
        false
    }

    /// Step 2 of the repair (module docs): returns how many clusters moved.
    fn smooth_clusters(&mut self, folded: &[u32]) -> usize {
        let faces = self.check.faces;
        // Union-find over the folded faces, joined through shared vertices.
        let mut parent: Vec<usize> = (0..folded.len()).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut owner: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
        for (i, &f) in folded.iter().enumerate() {
            for v in faces[f as usize] {
                match owner.get(&v) {
                    Some(&j) => {
                        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                        parent[a.max(b)] = a.min(b);
                    }
                    None => {
                        owner.insert(v, i);
                    }
                }
            }
        }
        let mut clusters: Vec<Vec<u32>> = vec![Vec::new(); folded.len()];
        for (i, &f) in folded.iter().enumerate() {
            let r = root(&mut parent, i);
            clusters[r].push(f);
        }
        let mut moved = 0;
        for cluster in clusters.iter().filter(|c| !c.is_empty()) {
            let mut vertices: Vec<u32> = cluster
                .iter()
                .flat_map(|&f| faces[f as usize])
                .filter(|&v| self.movable[v as usize])
                .collect();
            vertices.sort_unstable();
            vertices.dedup();
            if vertices.is_empty() {
                continue;
            }
            let (star, region) = self.star_and_region(&vertices);
            let before = self.count(&region);
            let saved: Vec<Vec3> = vertices.iter().map(|&v| self.p[v as usize]).collect();
            let mut better = false;
            for _ in 0..CLUSTER_SMOOTHINGS {
                let next: Vec<Vec3> = vertices
                    .iter()
                    .map(|&v| self.umbrella(v as usize))
                    .collect();
                for (&v, &x) in vertices.iter().zip(&next) {
                    self.p[v as usize] = x;
                }
                self.refresh(&star);
                if self.count(&region) < before {
                    better = true;
                    break;
                }
            }
            if better {
                moved += 1;
            } else {
                for (&v, &x) in vertices.iter().zip(&saved) {
                    self.p[v as usize] = x;
                }
                self.refresh(&star);
            }
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat 6 × 6 grid of unit squares (vertices at integer x, y).
    fn grid() -> Mesh {
        Mesh::height_grid(6, |_, _| 0.0)
    }

    #[test]
    fn a_flat_mesh_has_no_folds_and_is_left_alone() {
        let m = grid();
        let t = Topology::new(m.num_vertices(), &m.faces);
        let mut out = m.positions.clone();
        let r = repair_folds(&m, &mut out, &t);
        assert_eq!((r.input, r.before, r.after, r.moved), (0, 0, 0, 0));
        assert_eq!(out, m.positions);
    }

    #[test]
    fn the_self_folded_faces_are_those_a_crossed_vertex_turns_over() {
        let m = grid();
        let t = Topology::new(m.num_vertices(), &m.faces);
        assert_eq!(self_folded_faces(&m, &t), 0);
        // one inner vertex moved across two rings: its own mesh is folded
        let mut folded = m.clone();
        folded.positions[3 * 7 + 3][0] += 2.5;
        let flags = FoldCheck::new(&folded.positions, &folded.faces, &t).folded(&folded.positions);
        let v = (3 * 7 + 3) as u32;
        let fan: Vec<usize> = (0..m.num_faces())
            .filter(|&f| folded.faces[f].contains(&v))
            .collect();
        let folded_fan: Vec<usize> = fan.iter().copied().filter(|&f| flags[f]).collect();
        let count = flags.iter().filter(|&&b| b).count();
        // of its six triangles the two whose far edge it crossed turn over
        // (the others only stretch), and no other face folds
        assert_eq!((fan.len(), folded_fan.len(), count), (6, 2, 2), "{flags:?}");
        assert_eq!(self_folded_faces(&folded, &t), count);
    }

    #[test]
    fn a_vertex_moved_across_its_neighbours_is_brought_back() {
        let m = grid();
        let t = Topology::new(m.num_vertices(), &m.faces);
        // Move one inner vertex sideways across two rings: its fan folds.
        let v = 3 * 7 + 3;
        assert_eq!(m.positions[v], [3.0, 3.0, 0.0]);
        let mut out = m.positions.clone();
        out[v][0] += 2.5;
        let r = repair_folds(&m, &mut out, &t);
        assert!(r.before > 0, "{r:?}");
        assert_eq!((r.input, r.after), (0, 0), "{r:?}");
        let check = FoldCheck::new(&m.positions, &m.faces, &t);
        assert_eq!(check.count(&out), 0);
    }

    #[test]
    fn unmoved_vertices_stay_and_the_result_is_thread_count_free() {
        let m = grid();
        let t = Topology::new(m.num_vertices(), &m.faces);
        let mut out = m.positions.clone();
        // Every inner vertex moved pseudo-randomly in the plane and up.
        for (i, p) in out.iter_mut().enumerate() {
            if i % 3 == 0 {
                continue;
            }
            let h = (i as f64 * 0.61803).fract() - 0.5;
            p[0] += 1.7 * h;
            p[1] -= 1.3 * h;
            p[2] += 0.3 * ((i as f64 * 0.414).fract() - 0.5);
        }
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut o = out.clone();
                let r = repair_folds(&m, &mut o, &t);
                (o, r)
            })
        };
        let (a, ra) = run(1);
        let (b, rb) = run(3);
        assert_eq!(a, b);
        assert_eq!(ra, rb);
        assert!(ra.before > 0, "{ra:?}");
        assert_eq!(
            (ra.input, ra.after),
            (0, 0),
            "the flat input has no folds: {ra:?}"
        );
        for (i, p) in a.iter().enumerate() {
            if i % 3 == 0 {
                assert_eq!(*p, m.positions[i], "vertex {i} was not moved by the method");
            }
        }
    }
}
