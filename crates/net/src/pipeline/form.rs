//! The choose stage: each face's filtered normal from the network's output,
//! in the run's [`Form`].

use normalnet_filters::gt_guided::{GT_GUIDED_SIGMA_S, gt_guided_normals};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, Topology};

use super::params::{Form, GuidedLimit};
use super::skips::Selection;
use crate::switch::{self, SwitchState, SwitchWeights};
use std::borrow::Cow;

/// A [`Form`] with what it carries from one iteration to the next (the
/// switch's GNF state and CNR's normals).
pub struct Chooser<'a> {
    form: Form<'a>,
    switch_state: Option<SwitchState>,
    /// the switch table of this run, chosen in its first iteration
    /// ([`switch::SwitchWeights::for_run`])
    run_table: Option<Cow<'a, SwitchWeights>>,
}

/// The filtered normals of one iteration, and with the switch the shares of
/// faces that chose "stay" and that were folded (0 in the other forms).
pub struct Choice {
    /// per face, unit length
    pub normals: Vec<Vec3>,
    /// see [`crate::pipeline::IterationStats::stay_share`]
    pub stay_share: f64,
    /// see [`crate::pipeline::IterationStats::folded_share`]
    pub folded_share: f64,
}

impl<'a> Chooser<'a> {
    /// The chooser of `form` for a run on `mesh` at `mu_g`.
    pub fn new(form: Form<'a>, mesh: &Mesh, topology: &Topology, mu_g: f64) -> Chooser<'a> {
        let switch_state = match form {
            Form::Switch(weights) => {
                Some(SwitchState::new(mesh, topology, mu_g, weights.needs_cnr()))
            }
            _ => None,
        };
        Chooser {
            form,
            switch_state,
            run_table: None,
        }
    }

    /// The filtered normals of iteration `k` of `current` from the network's
    /// `normals`; `selection` says which faces reused an output (they do not
    /// count towards the switch's stay share: a reused output is no new
    /// evidence that its face has settled).
    pub fn choose(
        &mut self,
        k: usize,
        current: &Mesh,
        topology: &Topology,
        normals: Vec<Vec3>,
        selection: &Selection,
    ) -> Choice {
        let paper = |normals| Choice {
            normals,
            stay_share: 0.0,
            folded_share: 0.0,
        };
        match self.form {
            Form::Paper => paper(normals),
            Form::Guided { from, .. } if k < from => paper(normals),
            Form::Guided { mu_g, limit, .. } => {
                paper(guided(current, topology, &normals, mu_g, limit))
            }
            Form::Switch(weights) => {
                let state = self.switch_state.as_mut().expect("made with the switch");
                let candidates = state.candidates(current, topology, normals);
                let features = switch::features(topology, &candidates, k);
                let table = self
                    .run_table
                    .get_or_insert_with(|| weights.for_run_features(&features));
                let (blended, stays) = switch::blend_with_stays(table, &candidates, &features);
                let counted = |f: usize| !selection.is_reused(f);
                let n = blended.len();
                let stay = (0..n).filter(|&f| stays[f] && counted(f)).count();
                let total = (0..n).filter(|&f| counted(f)).count();
                let folded = candidates.folded.iter().filter(|&&b| b).count();
                Choice {
                    normals: blended,
                    stay_share: stay as f64 / total.max(1) as f64,
                    folded_share: folded as f64 / n.max(1) as f64,
                }
            }
        }
    }
}

/// The guided form: one joint-bilateral pass over the current normals
/// guided by the network's, taken where `limit` allows.
fn guided(
    current: &Mesh,
    topology: &Topology,
    normals: &[Vec3],
    mu_g: f64,
    limit: GuidedLimit,
) -> Vec<Vec3> {
    let guided = gt_guided_normals(current, topology, normals, &[mu_g], GT_GUIDED_SIGMA_S);
    match limit {
        GuidedLimit::Everywhere => guided,
        GuidedLimit::FlatRing { deg, frac } => {
            let cos_t = deg.to_radians().cos();
            let flat = |f: usize| {
                let ring = topology.face_neighbours.row(f);
                let close = ring
                    .iter()
                    .filter(|&&g| vec3::dot(normals[f], normals[g as usize]) >= cos_t)
                    .count();
                !ring.is_empty() && close as f64 >= frac * ring.len() as f64
            };
            (0..normals.len())
                .map(|f| if flat(f) { guided[f] } else { normals[f] })
                .collect()
        }
        GuidedLimit::MaxTurn { deg } => {
            let limit = deg.to_radians();
            guided
                .iter()
                .zip(normals)
                .map(|(g, n)| if vec3::angle(*g, *n) > limit { *n } else { *g })
                .collect()
        }
    }
}
