//! The learned switch (not in the paper; issue 10): in every filtering
//! iteration each face gets four candidate filtered normals —
//! 0. the network's output (the paper's form),
//! 1. the guided form: one joint-bilateral pass over the current normals
//!    with the network's outputs as guidance (range μ_g, spatial 2·d_s — the
//!    oracle's pass with learned instead of ground-truth guidance),
//! 2. one GNF pass over the current normals (GNF's own patch guidance),
//! 3. the current normal (the face stays where it is),
//! 4. CNR's normal (issue 34; only in tables that read it,
//!    [`SwitchWeights::reads_cnr`]): the face normals of the built-in CNR
//!    cascade (`normalnet_filters::cnr`) run once on the run's input,
//!
//! and a small perceptron ([`SwitchWeights`], a bundle's `[switch]` table)
//! reads [`NUM_FEATURES`] rotation-invariant features of the face and its
//! 1-ring and blends the candidates by its softmax weights. The network
//! learns organic detail, the guided pass keeps CAD edges sharp, and
//! "stay" stops the late iterations from over-smoothing: the switch is fitted
//! so that the expected angle to the ground truth is smallest, on meshes
//! that are neither validation nor test data.
//!
//! Features, in order (angles in radians): ∠(net, guided), ∠(net, GNF),
//! ∠(guided, GNF), ∠(net, current); mean and largest ∠ between the face's
//! network normal and its 1-ring's; mean ∠ between the face's current normal
//! and its 1-ring's; largest 1-ring ∠ of the GNF normals; the iteration k
//! (the perceptron clamps it to its `max_iteration`); then three per-mesh
//! values: the median of feature 6 (0-based; a noise level), the median of
//! feature 4, and the fraction of faces whose feature 5 is below 10° (how
//! much of the mesh is flat). Tables with the CNR candidate read two more:
//! ∠(net, CNR) and ∠(CNR, current).
//!
//! A bundle's switch may carry a second, late table (`[switch.late]`,
//! [`SwitchWeights::late`]) for the iterations after the main table's
//! `max_iteration`: long runs (the Table 2 settings run 20–25 iterations)
//! without changing the default 10-iteration run; and a table for noisy
//! runs (`[switch.heavy]`, [`HeavyTable`]) that replaces the main table for
//! a whole run when its input's noise level (feature 9 of the first
//! iteration) is high ([`SwitchWeights::for_run`]).

use normalnet_filters::cnr::{VERTEX_ITERATIONS, builtin, run_cascade};
use normalnet_filters::gt_guided::{GT_GUIDED_SIGMA_S, gt_guided_pass};
use normalnet_filters::{FOLD_GUARD_COS, FoldCheck, Gnf, GnfParams, NormalFilter};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, Mesh, NoProgress, Topology};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// The iteration feature's place in a feature row.
pub const ITERATION_FEATURE: usize = 8;

/// The clamp of the iteration feature of switch tables that do not name
/// one (fitted on 10-iteration runs: later iterations look like the 10th).
pub const DEFAULT_MAX_ITERATION: usize = 10;

fn default_max_iteration() -> usize {
    DEFAULT_MAX_ITERATION
}

/// Feature `j` of a row as the perceptron reads it: the iteration clamped to
/// `max_iteration`, every other feature as it is (fitting and inference both
/// read features through this).
pub fn feature_as_read(j: usize, x: f64, max_iteration: usize) -> f64 {
    if j == ITERATION_FEATURE {
        x.min(max_iteration as f64)
    } else {
        x
    }
}

/// Features per face (a row): the [`BASE_FEATURES`], then ∠(net, CNR) and
/// ∠(CNR, current) (0 in runs without the CNR candidate).
pub const NUM_FEATURES: usize = 14;

/// The features a table without the CNR candidate reads: the first ones.
pub const BASE_FEATURES: usize = 12;

/// The noise level's place in a feature row: the median over the mesh of
/// each face's mean angle to its 1-ring (feature 6), the same in every row.
pub const NOISE_LEVEL_FEATURE: usize = 9;

/// The candidates, in the switch's output order.
pub const CANDIDATES: [&str; 5] = ["network", "guided", "gnf", "current", "cnr"];

/// Number of candidates.
pub const NUM_CANDIDATES: usize = CANDIDATES.len();

/// The candidates of a table without the CNR candidate: the first ones.
pub const BASE_CANDIDATES: usize = 4;

/// Index of the CNR candidate.
pub const CNR: usize = 4;

/// The features a table reads and its candidates: all of them with the CNR
/// candidate, else the base ones.
pub const fn table_dims(cnr: bool) -> (usize, usize) {
    if cnr {
        (NUM_FEATURES, NUM_CANDIDATES)
    } else {
        (BASE_FEATURES, BASE_CANDIDATES)
    }
}

/// A perceptron with one tanh hidden layer: `softmax(W2·tanh(W1·z + b1) + b2)`
/// with `z = (x − mean) / std`. Row-major: `w1` is hidden × features, `w2`
/// candidates × hidden. A table has the [`BASE_CANDIDATES`] and reads the
/// [`BASE_FEATURES`], or has all [`NUM_CANDIDATES`] (CNR's too) and reads
/// all [`NUM_FEATURES`]; the lengths of `b2` and `mean` say which.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SwitchWeights {
    /// hidden units
    pub hidden: usize,
    /// feature means (len [`NUM_FEATURES`])
    pub mean: Vec<f64>,
    /// feature standard deviations (len [`NUM_FEATURES`], positive)
    pub std: Vec<f64>,
    /// first layer weights (hidden × [`NUM_FEATURES`])
    pub w1: Vec<f64>,
    /// first layer biases (len hidden)
    pub b1: Vec<f64>,
    /// second layer weights ([`NUM_CANDIDATES`] × hidden)
    pub w2: Vec<f64>,
    /// second layer biases (len [`NUM_CANDIDATES`]; a very negative one
    /// rules its candidate out)
    pub b2: Vec<f64>,
    /// the iteration feature is clamped to this: iterations after it look
    /// like it (the longest runs the switch was fitted on)
    #[serde(default = "default_max_iteration")]
    pub max_iteration: usize,
    /// how it was fitted, in words
    #[serde(default)]
    pub notes: String,
    /// where a face is folded in the current mesh ([`Candidates::folded`])
    /// the switch takes the network's output (issue 34): a folded face's
    /// own normal is no evidence, and the guided pass, GNF and "stay" all
    /// start from it. The switch's rows come from noise along the normals,
    /// which folds few faces; noise with a tangential part (random
    /// directions, a scanner's view direction) folds many, and there the
    /// switch without this rule lost to the paper's form by 5–22°
    /// (docs/training.md, "The switch's fold rule"). Off in tables that do
    /// not name it. Read from the main table only: its rule covers the
    /// late table's iterations too, and a late table may not set it
    /// ([`SwitchWeights::validate`]). A folded face never counts as "stay",
    /// so a run on a mesh that keeps more than 5 % of its faces folded does
    /// not end by the stay rule ([`STAY_SHARE_TO_STOP`]) and runs its N_f.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub network_on_folds: bool,
    /// the switch of the iterations after `max_iteration` (a `[switch.late]`
    /// table: long runs such as the Table 2 settings' 20–25 iterations);
    /// without it those iterations use this table with the iteration
    /// clamped. The default run (10 iterations) never reaches it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub late: Option<Box<SwitchWeights>>,
    /// the table of noisy runs (`[switch.heavy]`): a run whose first
    /// iteration's noise level reaches its threshold uses it instead of
    /// this table for every iteration up to `max_iteration`
    /// ([`SwitchWeights::for_run`]). Read from the main table only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heavy: Option<Box<HeavyTable>>,
}

/// A switch table for noisy runs and where they start (issue 34). Tables
/// refitted with heavy-noise rows win heavy noise (the shipped table keeps
/// almost every face in place from iteration 2–3 at 0.6–0.8 l_e) but lose
/// mild and moderate noise; the run's noise level, known in its first
/// iteration, says which of the two it is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeavyTable {
    /// runs whose noise level ([`NOISE_LEVEL_FEATURE`] in iteration 1,
    /// radians) is at least this use `table`
    pub from_noise_level: f64,
    /// the table; the main table's late table and fold rule apply to its
    /// runs too, so it has neither
    pub table: SwitchWeights,
}

impl SwitchWeights {
    /// Checks the shapes and that every number is finite (`b2` may hold
    /// large negative values).
    pub fn validate(&self) -> Result<(), String> {
        let h = self.hidden;
        if self.b2.len() != BASE_CANDIDATES && self.b2.len() != NUM_CANDIDATES {
            return Err(format!(
                "switch: b2 has {} values, expected {BASE_CANDIDATES} (or {NUM_CANDIDATES} with the CNR candidate)",
                self.b2.len()
            ));
        }
        let (nf, nc) = (self.num_features(), self.num_candidates());
        let shapes = [
            ("mean", self.mean.len(), nf),
            ("std", self.std.len(), nf),
            ("w1", self.w1.len(), h * nf),
            ("b1", self.b1.len(), h),
            ("w2", self.w2.len(), nc * h),
        ];
        if h == 0 {
            return Err("switch: hidden = 0".into());
        }
        if self.max_iteration == 0 {
            return Err("switch: max_iteration = 0".into());
        }
        for (name, got, want) in shapes {
            if got != want {
                return Err(format!("switch: {name} has {got} values, expected {want}"));
            }
        }
        let all = [
            &self.mean, &self.std, &self.w1, &self.b1, &self.w2, &self.b2,
        ];
        if all.iter().any(|v| v.iter().any(|x| !x.is_finite())) {
            return Err("switch: a weight is not finite".into());
        }
        if self.std.iter().any(|s| *s <= 0.0) {
            return Err("switch: std must be positive".into());
        }
        if let Some(heavy) = &self.heavy {
            let t = &heavy.table;
            if !(heavy.from_noise_level.is_finite() && heavy.from_noise_level > 0.0) {
                return Err("switch.heavy: from_noise_level must be a positive angle".into());
            }
            if t.heavy.is_some() || t.late.is_some() || t.network_on_folds {
                return Err("switch.heavy: its table takes the main table's late table and fold rule; it has none of its own".into());
            }
            if t.max_iteration != self.max_iteration {
                return Err(format!(
                    "switch.heavy: max_iteration {} differs from the main table's {} (where the late table takes over)",
                    t.max_iteration, self.max_iteration
                ));
            }
            t.validate()
                .map_err(|e| e.replacen("switch", "switch.heavy", 1))?;
        }
        match &self.late {
            Some(late) if late.late.is_some() || late.heavy.is_some() => {
                Err("switch.late: late tables do not nest".into())
            }
            Some(late) if late.network_on_folds => Err(
                "switch.late: network_on_folds belongs to [switch], whose rule covers every iteration"
                    .into(),
            ),
            Some(late) => late
                .validate()
                .map_err(|e| e.replacen("switch", "switch.late", 1)),
            None => Ok(()),
        }
    }

    /// Whether this table has the CNR candidate (and reads its features).
    pub fn reads_cnr(&self) -> bool {
        self.b2.len() == NUM_CANDIDATES
    }

    /// Whether a run with this switch needs CNR's normals: a table of it
    /// (this one, its late or heavy table) has the CNR candidate.
    pub fn needs_cnr(&self) -> bool {
        self.reads_cnr()
            || self.late.as_ref().is_some_and(|t| t.reads_cnr())
            || self.heavy.as_ref().is_some_and(|t| t.table.reads_cnr())
    }

    /// The candidates of this table.
    pub fn num_candidates(&self) -> usize {
        table_dims(self.reads_cnr()).1
    }

    /// The features this table reads (the first ones of a row).
    pub fn num_features(&self) -> usize {
        table_dims(self.reads_cnr()).0
    }

    /// The table of a run whose first iteration has noise level
    /// `noise_level` ([`NOISE_LEVEL_FEATURE`]): this one, or from the heavy
    /// table's threshold on that table with this one's late table and fold
    /// rule.
    pub fn for_run(&self, noise_level: f64) -> Cow<'_, SwitchWeights> {
        match &self.heavy {
            Some(heavy) if noise_level >= heavy.from_noise_level => {
                let mut table = heavy.table.clone();
                table.late.clone_from(&self.late);
                table.network_on_folds = self.network_on_folds;
                Cow::Owned(table)
            }
            _ => Cow::Borrowed(self),
        }
    }

    /// The table of a run from the feature rows of its first iteration
    /// ([`SwitchWeights::for_run`] at their noise level; 0 for a mesh
    /// without faces).
    pub fn for_run_features(&self, first: &[[f64; NUM_FEATURES]]) -> Cow<'_, SwitchWeights> {
        self.for_run(first.first().map_or(0.0, |x| x[NOISE_LEVEL_FEATURE]))
    }

    /// The softmax weights of the candidates for one face's features (the
    /// late table's after `max_iteration` when there is one); 0 for the
    /// candidates the table does not have.
    pub fn probabilities(&self, x: &[f64; NUM_FEATURES]) -> [f64; NUM_CANDIDATES] {
        if let Some(late) = &self.late
            && x[ITERATION_FEATURE] > self.max_iteration as f64
        {
            return late.probabilities(x);
        }
        let (nf, nc) = (self.num_features(), self.num_candidates());
        let mut z = [0.0; NUM_FEATURES];
        for (j, z) in z[..nf].iter_mut().enumerate() {
            *z = (feature_as_read(j, x[j], self.max_iteration) - self.mean[j]) / self.std[j];
        }
        let hidden: Vec<f64> = self
            .w1
            .chunks_exact(nf)
            .zip(&self.b1)
            .map(|(w, b)| (dot(w, &z[..nf]) + b).tanh())
            .collect();
        let mut logits = [0.0; NUM_CANDIDATES];
        for ((l, w), b) in logits[..nc]
            .iter_mut()
            .zip(self.w2.chunks_exact(self.hidden))
            .zip(&self.b2)
        {
            *l = dot(w, &hidden) + b;
        }
        let max = logits[..nc]
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let mut sum = 0.0;
        for l in &mut logits[..nc] {
            *l = (*l - max).exp();
            sum += *l;
        }
        let mut p = [0.0; NUM_CANDIDATES];
        for (p, e) in p.iter_mut().zip(&logits[..nc]) {
            *p = e / sum;
        }
        p
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// The candidates of one iteration, one normal per face each.
pub struct Candidates {
    /// in [`CANDIDATES`] order; CNR's empty in runs without it
    pub normals: [Vec<Vec3>; NUM_CANDIDATES],
    /// per face: folded in the current mesh (the fold test of
    /// `normalnet_filters::fold_repair` with the current mesh as its own
    /// reference: the face opposes its 1-ring, or turned more than 75.5°
    /// from the ring's area-weighted mean normal; a degenerate face, whose
    /// normal is zero, counts as folded)
    pub folded: Vec<bool>,
}

/// What the switch needs across iterations: GNF's neighbourhood, built once
/// on the input mesh (as GNF does), and CNR's normals where a table reads
/// them.
pub struct SwitchState {
    gnf: Gnf,
    mu_g: f64,
    cnr: Vec<Vec3>,
}

/// The face normals of the built-in CNR cascade (every stage, 20 vertex
/// passes each, the fold guard) run on `mesh`.
pub fn cnr_normals(mesh: &Mesh) -> Vec<Vec3> {
    // the built-in model is the library's own file: it parses (a test says so)
    let model = builtin().expect("the built-in CNR model parses");
    let out = run_cascade(
        model,
        mesh,
        0,
        VERTEX_ITERATIONS,
        Some(FOLD_GUARD_COS),
        &NoProgress,
    );
    face_normals(&out)
}

impl SwitchState {
    /// Prepares the GNF pass for `mesh` (the input of the run), and CNR's
    /// normals with `cnr`.
    pub fn new(mesh: &Mesh, topology: &Topology, mu_g: f64, cnr: bool) -> SwitchState {
        let params = GnfParams {
            mu_g,
            ..GnfParams::default()
        };
        // the only error is a parameter out of range; μ_g was validated
        let gnf = Gnf::new(&params, mesh, topology).expect("GNF parameters validated");
        let cnr = if cnr { cnr_normals(mesh) } else { Vec::new() };
        SwitchState { gnf, mu_g, cnr }
    }

    /// The candidates for the current mesh given the network's outputs.
    pub fn candidates(
        &mut self,
        current: &Mesh,
        topology: &Topology,
        net: Vec<Vec3>,
    ) -> Candidates {
        let geometry = FaceGeometry::new(current);
        let guided = gt_guided_pass(topology, &geometry, &net, &[self.mu_g], GT_GUIDED_SIGMA_S);
        let mut gnf = vec![[0.0; 3]; current.num_faces()];
        self.gnf
            .pass(topology, &geometry, &geometry.normals, &mut gnf);
        let folded =
            FoldCheck::new(&current.positions, &current.faces, topology).folded(&current.positions);
        Candidates {
            normals: [net, guided, gnf, geometry.normals, self.cnr.clone()],
            folded,
        }
    }
}

/// Mean and largest angle between face `f`'s normal and its 1-ring's.
fn ring_angles(topology: &Topology, normals: &[Vec3], f: usize) -> (f64, f64) {
    let ring = topology.face_neighbours.row(f);
    if ring.is_empty() {
        return (0.0, 0.0);
    }
    let mut sum = 0.0;
    let mut max: f64 = 0.0;
    for &g in ring {
        let a = vec3::angle(normals[f], normals[g as usize]);
        sum += a;
        max = max.max(a);
    }
    (sum / ring.len() as f64, max)
}

/// The noise level of a mesh with face normals `normals`: the median over
/// faces of the mean angle (radians) between a face's normal and its
/// 1-ring's ([`NOISE_LEVEL_FEATURE`] in iteration 1).
pub fn noise_level(topology: &Topology, normals: &[Vec3]) -> f64 {
    median(
        (0..normals.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|f| ring_angles(topology, normals, f).0)
            .collect(),
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The features of every face (see the module docs) in iteration `k`.
pub fn features(topology: &Topology, c: &Candidates, k: usize) -> Vec<[f64; NUM_FEATURES]> {
    let [net, guided, gnf, current, cnr] = &c.normals;
    let mut rows: Vec<[f64; NUM_FEATURES]> = (0..net.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|f| {
            let (net_mean, net_max) = ring_angles(topology, net, f);
            let (current_mean, _) = ring_angles(topology, current, f);
            let (_, gnf_max) = ring_angles(topology, gnf, f);
            let (net_cnr, cnr_current) = match cnr.get(f) {
                Some(&n) => (vec3::angle(net[f], n), vec3::angle(n, current[f])),
                None => (0.0, 0.0),
            };
            [
                vec3::angle(net[f], guided[f]),
                vec3::angle(net[f], gnf[f]),
                vec3::angle(guided[f], gnf[f]),
                vec3::angle(net[f], current[f]),
                net_mean,
                net_max,
                current_mean,
                gnf_max,
                k as f64,
                0.0,
                0.0,
                0.0,
                net_cnr,
                cnr_current,
            ]
        })
        .collect();
    let n = rows.len().max(1) as f64;
    let noise_level = median(rows.iter().map(|r| r[6]).collect());
    let net_flatness = median(rows.iter().map(|r| r[4]).collect());
    let flat_share = rows.iter().filter(|r| r[5] < 10f64.to_radians()).count() as f64 / n;
    for r in &mut rows {
        r[9] = noise_level;
        r[10] = net_flatness;
        r[11] = flat_share;
    }
    rows
}

/// Index of the "network" candidate (the paper's form).
pub const NETWORK: usize = 0;

/// Index of the "stay" candidate (the current normal).
pub const STAY: usize = 3;

/// The run stops after an iteration in which at least this share of the
/// faces gave "stay" the largest weight (with `auto_stop_deg > 0`): the
/// switch says the mesh has converged. Chosen on the validation meshes:
/// the organic ones reach it after 2–3 iterations, the CAD shapes, still
/// sharpening, never within 10.
pub const STAY_SHARE_TO_STOP: f64 = 0.95;

/// The filtered normals: each face's candidates blended by the switch's
/// weights (normalised; a zero sum keeps the current normal), and how many
/// faces gave "stay" the largest weight.
pub fn blend(
    weights: &SwitchWeights,
    c: &Candidates,
    features: &[[f64; NUM_FEATURES]],
) -> (Vec<Vec3>, usize) {
    let (blended, stays) = blend_with_stays(weights, c, features);
    let stay = stays.iter().filter(|&&s| s).count();
    (blended, stay)
}

/// [`blend`], with per face whether "stay" had the largest weight (never
/// on a folded face that takes the network's output,
/// [`SwitchWeights::network_on_folds`]).
pub fn blend_with_stays(
    weights: &SwitchWeights,
    c: &Candidates,
    features: &[[f64; NUM_FEATURES]],
) -> (Vec<Vec3>, Vec<bool>) {
    let blended: Vec<(Vec3, bool)> = features
        .par_iter()
        .enumerate()
        .with_min_len(256)
        .map(|(f, x)| {
            if weights.network_on_folds && c.folded[f] {
                return (c.normals[NETWORK][f], false);
            }
            let p = weights.probabilities(x);
            let mut sum = [0.0; 3];
            // a run without CNR's normals has no CNR candidate
            for (candidate, w) in c.normals.iter().zip(p).filter(|(c, _)| !c.is_empty()) {
                sum = vec3::add(sum, vec3::scale(candidate[f], w));
            }
            let n = vec3::normalize_or_zero(sum);
            let stays = (0..NUM_CANDIDATES).all(|k| p[k] <= p[STAY]);
            (if n == [0.0; 3] { c.normals[STAY][f] } else { n }, stays)
        })
        .collect();
    blended.into_iter().unzip()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A switch that always picks candidate `c` (a constant perceptron),
    /// with the CNR candidate only where `c` is it.
    pub(crate) fn constant(c: usize) -> SwitchWeights {
        let (nf, nc) = if c == CNR {
            (NUM_FEATURES, NUM_CANDIDATES)
        } else {
            (BASE_FEATURES, BASE_CANDIDATES)
        };
        let mut b2 = vec![-1e9; nc];
        b2[c] = 0.0;
        SwitchWeights {
            hidden: 2,
            mean: vec![0.0; nf],
            std: vec![1.0; nf],
            w1: vec![0.1; 2 * nf],
            b1: vec![0.0; 2],
            w2: vec![0.0; 2 * nc],
            b2,
            max_iteration: DEFAULT_MAX_ITERATION,
            notes: String::new(),
            network_on_folds: false,
            late: None,
            heavy: None,
        }
    }

    #[test]
    fn probabilities_are_a_softmax_of_the_perceptron() {
        let mut w = constant(0);
        w.b2 = vec![0.0, 1.0, 2.0, 3.0];
        w.w2[0] = 1.0; // candidate 0 reads hidden unit 0
        let x = [0.5; NUM_FEATURES];
        let h0 = (0.1f64 * 0.5 * BASE_FEATURES as f64).tanh();
        let logits = [h0, 1.0, 2.0, 3.0];
        let sum: f64 = logits.iter().map(|l| l.exp()).sum();
        let p = w.probabilities(&x);
        for (p, l) in p.iter().zip(logits) {
            assert!((p - l.exp() / sum).abs() < 1e-12);
        }
        assert!(constant(2).probabilities(&x)[2] > 1.0 - 1e-12);
    }

    #[test]
    fn the_iteration_is_clamped_to_the_switch_s_longest_run() {
        let mut w = constant(0);
        w.b2 = vec![0.0; BASE_CANDIDATES];
        w.w2[0] = 1.0; // candidate 0 reads hidden unit 0, which reads k
        w.w1 = vec![0.0; 2 * BASE_FEATURES];
        w.w1[ITERATION_FEATURE] = 0.1;
        let at = |w: &SwitchWeights, k: f64| {
            let mut x = [0.0; NUM_FEATURES];
            x[ITERATION_FEATURE] = k;
            w.probabilities(&x)[0]
        };
        assert!(at(&w, 9.0) < at(&w, 10.0));
        assert_eq!(at(&w, 10.0), at(&w, 25.0));
        w.max_iteration = 25;
        assert!(at(&w, 10.0) < at(&w, 25.0));
        assert_eq!(at(&w, 25.0), at(&w, 40.0));
        // tables written before the clamp was a field read as 10
        let text = toml::to_string(&constant(1)).unwrap();
        let text = text.replace("max_iteration = 10\n", "");
        assert!(!text.contains("max_iteration"));
        let back: SwitchWeights = toml::from_str(&text).unwrap();
        assert_eq!(back.max_iteration, DEFAULT_MAX_ITERATION);
    }

    /// The candidate `w` weighs most in iteration `k` (other features 0).
    fn best_at(w: &SwitchWeights, k: f64) -> usize {
        let mut x = [0.0; NUM_FEATURES];
        x[ITERATION_FEATURE] = k;
        let p = w.probabilities(&x);
        (0..NUM_CANDIDATES)
            .max_by(|&a, &b| p[a].total_cmp(&p[b]))
            .unwrap()
    }

    #[test]
    fn a_late_table_switches_the_iterations_after_the_clamp() {
        let mut w = constant(1);
        w.late = Some(Box::new(constant(2)));
        let at = best_at;
        assert_eq!((at(&w, 1.0), at(&w, 10.0)), (1, 1));
        assert_eq!((at(&w, 11.0), at(&w, 25.0)), (2, 2));
        // written and read back as a [switch.late] table inside [switch]
        #[derive(Serialize, Deserialize)]
        struct Manifest {
            switch: SwitchWeights,
        }
        let text = toml::to_string(&Manifest { switch: w.clone() }).unwrap();
        assert!(text.contains("[switch.late]"), "{text}");
        let back: Manifest = toml::from_str(&text).unwrap();
        assert_eq!(back.switch, w);
        assert!(!toml::to_string(&constant(1)).unwrap().contains("late"));
        // a bad late table is named; late tables do not nest
        w.late.as_mut().unwrap().b1.pop();
        assert!(w.validate().unwrap_err().starts_with("switch.late: b1"));
        let mut nested = constant(1);
        nested.late = Some(Box::new(constant(2)));
        w.late = Some(Box::new(nested));
        assert!(w.validate().unwrap_err().contains("do not nest"));
    }

    #[test]
    fn a_heavy_table_switches_the_runs_whose_noise_level_reaches_its_threshold() {
        let mut w = constant(1);
        w.network_on_folds = true;
        w.late = Some(Box::new(constant(3)));
        w.heavy = Some(Box::new(HeavyTable {
            from_noise_level: 1.0,
            table: constant(2),
        }));
        assert!(w.validate().is_ok());
        let best = best_at;
        // below the threshold the main table itself, from it the heavy one
        // with the main table's late table and fold rule
        assert!(matches!(w.for_run(0.99), Cow::Borrowed(t) if std::ptr::eq(t, &w)));
        let heavy = w.for_run(1.0);
        assert_eq!((best(&heavy, 1.0), best(&heavy, 10.0)), (2, 2));
        assert_eq!(best(&heavy, 11.0), 3);
        assert!(heavy.network_on_folds && heavy.heavy.is_none());
        assert_eq!(best(&w.for_run(0.5), 1.0), 1);
        // written and read back as [switch.heavy] inside [switch]
        #[derive(Serialize, Deserialize)]
        struct Manifest {
            switch: SwitchWeights,
        }
        let text = toml::to_string(&Manifest { switch: w.clone() }).unwrap();
        assert!(text.contains("[switch.heavy]") && text.contains("from_noise_level = 1.0"));
        let back: Manifest = toml::from_str(&text).unwrap();
        assert_eq!(back.switch, w);
        assert!(!toml::to_string(&constant(1)).unwrap().contains("heavy"));
        // the heavy table has no late table, fold rule or heavy table of
        // its own, and a positive threshold; a bad one is named
        let refused = |edit: fn(&mut HeavyTable), expected: &str| {
            let mut bad = w.clone();
            edit(bad.heavy.as_mut().unwrap());
            let err = bad.validate().unwrap_err();
            assert!(err.contains(expected), "{err}");
        };
        refused(
            |h| h.table.late = Some(Box::new(constant(0))),
            "none of its own",
        );
        refused(|h| h.table.network_on_folds = true, "none of its own");
        refused(|h| h.from_noise_level = 0.0, "positive");
        refused(
            |h| h.table.max_iteration = 5,
            "differs from the main table's",
        );
        refused(|h| h.from_noise_level = f64::NAN, "positive");
        refused(
            |h| {
                h.table.b1.pop();
            },
            "switch.heavy: b1",
        );
    }

    #[test]
    fn validate_names_the_bad_part() {
        assert!(constant(1).validate().is_ok());
        let mut w = constant(1);
        w.w1.pop();
        assert!(w.validate().unwrap_err().contains("w1"));
        let mut w = constant(1);
        w.mean[3] = f64::NAN;
        assert!(w.validate().unwrap_err().contains("finite"));
        let mut w = constant(1);
        w.std[0] = 0.0;
        assert!(w.validate().unwrap_err().contains("std"));
        let mut w = constant(1);
        w.max_iteration = 0;
        assert!(w.validate().unwrap_err().contains("max_iteration"));
        // the fold rule is the main table's
        let mut w = constant(1);
        let mut late = constant(2);
        late.network_on_folds = true;
        w.late = Some(Box::new(late));
        assert!(w.validate().unwrap_err().contains("network_on_folds"));
        w.late.as_mut().unwrap().network_on_folds = false;
        w.network_on_folds = true;
        assert!(w.validate().is_ok());
    }

    #[test]
    fn features_see_agreement_and_the_mesh_wide_values() {
        let mesh = normalnet_voxel::shapes::generate_seeded(3, 300).unwrap();
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        let current = normalnet_mesh::geometry::face_normals(&mesh);
        let mut state = SwitchState::new(&mesh, &topology, 0.35, true);
        // the network "outputs" the current normals
        let c = state.candidates(&mesh, &topology, current.clone());
        assert_eq!(c.normals[3], current);
        let x = features(&topology, &c, 4);
        assert_eq!(x.len(), mesh.num_faces());
        for r in &x {
            assert!(r[3] < 1e-7, "∠(net, current) with net = current");
            assert_eq!(r[8], 4.0);
            assert!(r.iter().all(|v| v.is_finite() && *v >= 0.0));
            assert_eq!(r[9..12], x[0][9..12], "per-mesh values are shared");
            assert!(r[12] > 0.0 || r[13] > 0.0 || c.normals[CNR].is_empty());
        }
        // noise makes fewer 1-rings flat and raises the noise level
        let l = normalnet_mesh::geometry::mean_edge_length(&mesh, &topology);
        let noisy = mesh.with_positions(
            mesh.positions
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let s = ((i * 7919 % 13) as f64 / 6.0 - 1.0) * 0.2 * l;
                    [p[0] + s, p[1] - s, p[2] + 0.5 * s]
                })
                .collect(),
        );
        let noisy_normals = normalnet_mesh::geometry::face_normals(&noisy);
        let cn = state.candidates(&noisy, &topology, noisy_normals);
        let xn = features(&topology, &cn, 4);
        assert!(
            xn[0][11] < x[0][11],
            "flat share {} vs {}",
            xn[0][11],
            x[0][11]
        );
        assert!(
            xn[0][9] > x[0][9],
            "noise level {} vs {}",
            xn[0][9],
            x[0][9]
        );
        // a constant switch blends to its candidate
        for k in 0..NUM_CANDIDATES {
            let (b, stay) = blend(&constant(k), &c, &x);
            assert_eq!(stay, if k == STAY { x.len() } else { 0 });
            for (a, e) in b.iter().zip(&c.normals[k]) {
                if *e != [0.0; 3] {
                    assert!(vec3::angle(*a, *e) < 1e-9);
                }
            }
        }
        // the clean mesh has no folded face
        assert!(c.folded.iter().all(|f| !f));
    }

    #[test]
    fn with_the_fold_rule_folded_faces_take_the_network_output() {
        let mesh = normalnet_voxel::shapes::generate_seeded(3, 300).unwrap();
        let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
        // one vertex pushed through the surface: its faces fold
        let mut folded = mesh.clone();
        let v = mesh.faces[0][0] as usize;
        let n = normalnet_mesh::geometry::face_normals(&mesh)[0];
        let l = normalnet_mesh::geometry::mean_edge_length(&mesh, &topology);
        folded.positions[v] = vec3::sub(folded.positions[v], vec3::scale(n, 3.0 * l));
        let mut state = SwitchState::new(&folded, &topology, 0.35, false);
        // a "network" that outputs +x everywhere: unlike every other candidate
        let net = vec![[1.0, 0.0, 0.0]; mesh.num_faces()];
        let c = state.candidates(&folded, &topology, net);
        let check = FoldCheck::new(&folded.positions, &folded.faces, &topology);
        assert_eq!(c.folded, check.folded(&folded.positions));
        let count = c.folded.iter().filter(|&&f| f).count();
        assert!(count > 0, "pushing a vertex through folds its fan");
        let x = features(&topology, &c, 1);
        let mut stay = constant(STAY);
        let close = |a: Vec3, b: Vec3| vec3::angle(a, b) < 1e-9;
        let (b, stays) = blend_with_stays(&stay, &c, &x);
        assert!(stays.iter().all(|&s| s));
        assert!((0..b.len()).all(|f| close(b[f], c.normals[STAY][f])));
        stay.network_on_folds = true;
        let (b, stays) = blend_with_stays(&stay, &c, &x);
        for f in 0..b.len() {
            let want = if c.folded[f] { NETWORK } else { STAY };
            assert!(close(b[f], c.normals[want][f]), "face {f}");
            assert_eq!(stays[f], !c.folded[f], "face {f}");
        }
        // the rule is part of the table as a bundle stores it
        let text = toml::to_string(&stay).unwrap();
        assert!(text.contains("network_on_folds = true"));
        let back: SwitchWeights = toml::from_str(&text).unwrap();
        assert!(back.network_on_folds);
        let off = toml::to_string(&constant(STAY)).unwrap();
        assert!(!off.contains("network_on_folds"));
    }
}
