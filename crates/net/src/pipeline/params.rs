//! The settings of the NormalNet pipeline ([`DenoiseParams`]) and the
//! typed choices they make ([`Form`], [`GuidedLimit`], [`StopRule`]):
//! where two settings interact, the choice says which one wins.

use normalnet_filters::FOLD_GUARD_COS;
use serde::{Deserialize, Serialize};

use crate::NetError;
use crate::bundle::Bundle;
use crate::switch::{self, SwitchWeights};

/// Settings of [`super::denoise`]; `Default` is SPEC §7. The stages read
/// them through typed views: [`Form::of`] (how the filtered normal is
/// chosen), [`StopRule::of`] (when the run ends), and the skips
/// (`freeze_deg`, `flat_skip_deg`, `reuse_move`; [`super::skips`]).
///
/// The keys are the user's: the registry's `normalnet` parameters are these
/// fields (flattened into `normalnet_denoise::normalnet::NormalnetParams`),
/// so a new pipeline option is one field here with its doc and default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DenoiseParams {
    /// N_f, filtering iterations (default 10)
    pub iterations: usize,
    /// N_v, vertex-update passes per iteration (default 20)
    pub vertex_iterations: usize,
    /// μ_g; the nearest of the bundle's six outputs is used (default 0.35)
    pub mu_g: f64,
    /// faces per network batch (default 256; key `network_batch`)
    #[serde(rename = "network_batch")]
    pub batch: usize,
    /// Guided form from this filtering iteration on (1-based; 0 = never,
    /// the paper's form throughout): the network's normals are the guidance
    /// of one joint-bilateral pass over the current face normals (range
    /// width μ_g, spatial 2·d_s, as GNF and the GT-guided targets) instead
    /// of being the filtered normals themselves. With perfect network
    /// outputs this is the oracle.
    pub guided_from: usize,
    /// With the guided form: a face whose guided normal turns more than
    /// this many degrees away from the network's keeps the network's (the
    /// guided pass smooths what the network's guidance cannot separate:
    /// fine detail); 0 = no limit.
    pub guided_max_turn_deg: f64,
    /// With the guided form: apply it only to faces whose 1-ring (vertex-
    /// adjacent faces) is locally flat in the network's output — at least
    /// `guided_flat_frac` of the ring's network normals within
    /// `guided_flat_deg` of the face's — and keep the network's normal
    /// elsewhere (curved, organic or very noisy parts); 0 = every face
    pub guided_flat_deg: f64,
    /// see `guided_flat_deg` (default 0.5)
    pub guided_flat_frac: f64,
    /// the fold guard of the shared vertex update
    /// (`normalnet_filters::vertex_update`): keeps a face within
    /// `acos(fold_guard_cos)` of its filtered normal (default on)
    pub fold_guard: bool,
    /// the guard's cone: cos of the largest turn of a face away from its
    /// filtered normal (default [`FOLD_GUARD_COS`] = 0.5, 60°; 0 refuses
    /// only the flip itself)
    pub fold_guard_cos: f64,
    /// Converged faces stop being filtered: a face whose network output
    /// turned less than this many degrees between two consecutive
    /// iterations keeps that output for the rest of the run and is no
    /// longer voxelized (0 = off, every face every iteration: the exact
    /// pipeline; default [`FREEZE_DEG`]).
    pub freeze_deg: f64,
    /// Flat patches skip the network: from the second iteration on, a face
    /// whose 2-ring (vertex-adjacent faces, twice) has every face normal
    /// within this many degrees of the ring's area-weighted mean normal takes
    /// that mean normal as its network output and is not voxelized (its grid
    /// would be a nearly constant sheet). 0 = off (default
    /// [`FLAT_SKIP_DEG`]).
    pub flat_skip_deg: f64,
    /// Unmoved neighbourhoods reuse their output: a face that the same
    /// network evaluated in an earlier iteration, and around which no
    /// vertex (of its vertex-adjacent faces) has moved farther than this
    /// fraction of the mean edge length since, keeps that output and is not
    /// voxelized (the displacement is bounded by each vertex's path length,
    /// so the test errs on the side of evaluating). 0 = off (default
    /// [`REUSE_MOVE`]).
    pub reuse_move: f64,
    /// The run stops by itself after an iteration whose outputs turned, on
    /// average over all faces, less than this many degrees from the
    /// previous iteration's (`iterations` is then the most it runs;
    /// 0 = off, always `iterations`: the paper's pipeline). Default 1.0:
    /// on the validation set (8 held-out meshes) it gave a mean E_a of
    /// 7.75° against 7.87° for the full 10 iterations, in 60 iterations
    /// instead of 80 (organic meshes gain, over-smoothed by late
    /// iterations; CAD shapes lose up to 0.4°). With the learned switch the
    /// run stops instead when the switch keeps most faces where they are
    /// ([`switch::STAY_SHARE_TO_STOP`]); any value > 0 turns that on.
    pub auto_stop_deg: f64,
    /// Use the bundle's learned switch (see [`crate::switch`]) when it has
    /// one: each face's filtered normal blends the network's output, the
    /// guided pass, a GNF pass and the current normal. false (or a bundle
    /// without a switch): the paper's form (and `guided_from`).
    pub switch: bool,
    /// Yaw views: each face's network output is the normalised mean of
    /// this many evaluations, its local frame turned about its y axis by
    /// 360°/views between them (the network is trained with random yaw, so
    /// its outputs vary with it; the mean is steadier). 1 = one evaluation
    /// at yaw 0, the paper's pipeline. Costs the network's time this many
    /// times in the iterations and runs that take the views. Default
    /// [`YAW_VIEWS`] (with [`YAW_VIEWS_UNTIL`] and [`YAW_VIEWS_FROM_NOISE`]:
    /// only heavy noise, only the first iterations).
    pub yaw_views: usize,
    /// With `yaw_views` > 1: only filtering iterations 1 ..= this one take
    /// the views (0 = every iteration). Default [`YAW_VIEWS_UNTIL`].
    pub yaw_views_until: usize,
    /// With `yaw_views` > 1: only runs whose input's noise level (the
    /// median over faces of the mean angle in radians between a face's
    /// normal and its 1-ring's, [`switch::noise_level`]) reaches this take
    /// the views (0 = every run). Default [`YAW_VIEWS_FROM_NOISE`].
    pub yaw_views_from_noise: f64,
}

impl Default for DenoiseParams {
    fn default() -> Self {
        DenoiseParams {
            iterations: 10,
            vertex_iterations: 20,
            mu_g: 0.35,
            batch: 256,
            guided_from: 0,
            guided_max_turn_deg: 0.0,
            guided_flat_deg: 0.0,
            guided_flat_frac: 0.5,
            fold_guard: true,
            fold_guard_cos: FOLD_GUARD_COS,
            freeze_deg: FREEZE_DEG,
            flat_skip_deg: FLAT_SKIP_DEG,
            reuse_move: REUSE_MOVE,
            auto_stop_deg: 1.0,
            switch: true,
            yaw_views: YAW_VIEWS,
            yaw_views_until: YAW_VIEWS_UNTIL,
            yaw_views_from_noise: YAW_VIEWS_FROM_NOISE,
        }
    }
}

impl DenoiseParams {
    /// The fold guard as the vertex update takes it: `Some(cos)` when on.
    pub fn fold_guard_cone(&self) -> Option<f64> {
        self.fold_guard.then_some(self.fold_guard_cos)
    }

    /// Checks the ranges; the error names the field.
    pub fn validate(&self) -> Result<(), NetError> {
        if !(self.yaw_views_from_noise.is_finite() && self.yaw_views_from_noise >= 0.0) {
            return Err(NetError::InvalidParameter {
                name: "yaw_views_from_noise",
                message: format!("{} must be an angle ≥ 0", self.yaw_views_from_noise),
            });
        }
        if !(1..=8).contains(&self.yaw_views) {
            return Err(NetError::InvalidParameter {
                name: "yaw_views",
                message: format!("{} yaw views: 1 to 8", self.yaw_views),
            });
        }
        if self.iterations == 0 {
            return Err(NetError::InvalidParameter {
                name: "iterations",
                message: "N_f must be at least 1".into(),
            });
        }
        if !(self.mu_g.is_finite() && self.mu_g > 0.0) {
            return Err(NetError::InvalidParameter {
                name: "mu_g",
                message: format!("μ_g = {} must be finite and positive", self.mu_g),
            });
        }
        if !(-1.0..=1.0).contains(&self.fold_guard_cos) {
            return Err(NetError::InvalidParameter {
                name: "fold_guard_cos",
                message: format!("{} must lie in [-1, 1]", self.fold_guard_cos),
            });
        }
        if self.batch == 0 {
            return Err(NetError::InvalidParameter {
                name: "batch",
                message: "must be at least 1".into(),
            });
        }
        if !(self.guided_flat_deg.is_finite() && (0.0..=180.0).contains(&self.guided_flat_deg)) {
            return Err(NetError::InvalidParameter {
                name: "guided_flat_deg",
                message: format!("{} must lie in 0..=180 degrees", self.guided_flat_deg),
            });
        }
        if !(0.0..=1.0).contains(&self.guided_flat_frac) {
            return Err(NetError::InvalidParameter {
                name: "guided_flat_frac",
                message: format!("{} must lie in 0..=1", self.guided_flat_frac),
            });
        }
        for (name, v) in [
            ("freeze_deg", self.freeze_deg),
            ("flat_skip_deg", self.flat_skip_deg),
            ("reuse_move", self.reuse_move),
            ("auto_stop_deg", self.auto_stop_deg),
        ] {
            if !(v.is_finite() && (0.0..=180.0).contains(&v)) {
                return Err(NetError::InvalidParameter {
                    name,
                    message: format!("{v} must lie in 0..=180 degrees"),
                });
            }
        }
        if !(self.guided_max_turn_deg.is_finite()
            && (0.0..=180.0).contains(&self.guided_max_turn_deg))
        {
            return Err(NetError::InvalidParameter {
                name: "guided_max_turn_deg",
                message: format!("{} must lie in 0..=180 degrees", self.guided_max_turn_deg),
            });
        }
        Ok(())
    }
}

/// Default of [`DenoiseParams::yaw_views`]: 2, in iterations 1–3
/// ([`YAW_VIEWS_UNTIL`]) of runs whose input's noise level reaches 1.0 rad
/// ([`YAW_VIEWS_FROM_NOISE`]). On the validation suite (26 pairs, bench
/// settings, models/lite; 2026-12-08) the mean E_a went 10.53 → 10.37°:
/// heavy 11.86 → 11.56, heavy-cad 10.84 → 10.51, scanner 17.68 → 17.50,
/// the 16 pairs below the noise threshold bit for bit as before, 8 of the
/// 10 above it lower (chamfered924-g0.6 +0.34°, ruled917-g0.7 +0.13°
/// higher). Views in every iteration of every run gave 10.35 at about 2×
/// the time on every input; these cost ~1.6× on heavy inputs and nothing
/// on the others (docs/experiments.md, "Yaw views").
pub const YAW_VIEWS: usize = 2;

/// Default of [`DenoiseParams::yaw_views_until`]: the views in iterations
/// 1–3 (see [`YAW_VIEWS`]).
pub const YAW_VIEWS_UNTIL: usize = 3;

/// Default of [`DenoiseParams::yaw_views_from_noise`]: 1.0 rad, the heavy
/// switch table's threshold (docs/training.md, "A switch table for heavy
/// noise": the widest gap of the suite's noise levels near its heavy
/// pairs); see [`YAW_VIEWS`].
pub const YAW_VIEWS_FROM_NOISE: f64 = 1.0;

/// Default of [`DenoiseParams::freeze_deg`]: 0.5°. With the learned switch
/// it cost +0.003° mean E_a on the validation set (8 held-out meshes; worst
/// mesh +0.05°) for 19 % less time, and Fandisk0.3 +0.002° for 31 % less
/// (2026-12-01); in the paper's form (no switch) +0.19° on validation, so
/// the paper's exact pipeline sets it to 0.
pub const FREEZE_DEG: f64 = 0.5;

/// Default of [`DenoiseParams::flat_skip_deg`]: 15°. With the learned switch
/// it lowered the mean E_a on the validation set (8 held-out meshes) from
/// 6.759° to 6.583° (better on 6 of 8; homer +0.035°) in 21 % less time,
/// and on the 6 mild validation pairs from 2.834° to 2.794° (2026-12-01):
/// on CAD-like parts the 2-ring mean is a better filtered normal than the
/// lite network's where the patch is that flat. 8° gave 6.705°, 25° 6.593°,
/// 35° 6.705° (organic meshes over-smoothed: homer 9.0°). At 25 iterations
/// (N_v 10, μ_g 0.3) the 8 meshes went from 6.101° to 5.955° and the
/// Twelve-like validation polyhedra from 4.835° to 4.862° (the one loser;
/// see docs/experiments.md, "Flat patches skip the network").
pub const FLAT_SKIP_DEG: f64 = 15.0;

/// Default of [`DenoiseParams::reuse_move`]: off. At 0.1 mean edge
/// lengths, with the learned switch and the int8 stem, it cost +0.009° mean
/// E_a on the validation set (8 held-out meshes, 4.508 → 4.517°; without the
/// chaotic cone s42, +0.007°) for 23 % fewer face passes, and Fandisk0.3
/// +0.004° (2.584 → 2.588°) for 24 % fewer (56,960 → 43,286) (2026-12-02);
/// but on the test model Fandisk0.7 (μ_g 0.25) the reused outputs let the
/// switch's stop rule ([`switch::STAY_SHARE_TO_STOP`]) end the run after 7
/// iterations instead of 10: 8.25 → 11.21°. The stop rule now takes the
/// "stay" share over the faces not reused in that iteration; on a second,
/// high-noise validation set (L 0.5–0.7, 4 meshes) reuse 0.1 still costs
/// +0.11° (13.311 → 13.423°; with the old rule +0.21°), so it stays opt-in. Reuse across
/// networks (a face's output from the previous interval's network): 0.05
/// l_e +0.016° for 27 % fewer passes, 0.1 l_e +0.052° (rocker-arm +0.30°)
/// for 45 %.
pub const REUSE_MOVE: f64 = 0.0;

/// How each face's filtered normal is chosen from the network's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Form<'a> {
    /// the network's output itself (the paper)
    Paper,
    /// from iteration `from` on, one joint-bilateral pass over the current
    /// normals guided by the network's (range width `mu_g`), limited by
    /// `limit`; the paper's form before
    Guided {
        /// first guided iteration (1-based)
        from: usize,
        /// the pass's range width
        mu_g: f64,
        /// where the guided normal is taken
        limit: GuidedLimit,
    },
    /// the bundle's learned switch blends the network's output, the guided
    /// pass, a GNF pass and the current normal ([`crate::switch`])
    Switch(&'a SwitchWeights),
}

/// Where the guided form takes the guided normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GuidedLimit {
    /// everywhere
    Everywhere,
    /// only where the network's 1-ring normals are flat: at least `frac` of
    /// them within `deg` of the face's (`guided_flat_deg` > 0)
    FlatRing {
        /// the angle, degrees
        deg: f64,
        /// the share of the ring
        frac: f64,
    },
    /// where it turns at most `deg` from the network's
    /// (`guided_max_turn_deg` > 0 and no flat rule)
    MaxTurn {
        /// the angle, degrees
        deg: f64,
    },
}

impl<'a> Form<'a> {
    /// The form `params` choose with `bundle`: the learned switch when the
    /// bundle has one and `switch` is on (then `guided_from` and its limits
    /// are not read); else the guided form when `guided_from` > 0, limited
    /// by the flat-ring rule when `guided_flat_deg` > 0 (then
    /// `guided_max_turn_deg` is not read), else by `guided_max_turn_deg`;
    /// else the paper's.
    pub fn of(params: &DenoiseParams, bundle: &'a Bundle) -> Form<'a> {
        if let Some(weights) = bundle.manifest.switch.as_ref().filter(|_| params.switch) {
            return Form::Switch(weights);
        }
        if params.guided_from == 0 {
            return Form::Paper;
        }
        let limit = if params.guided_flat_deg > 0.0 {
            GuidedLimit::FlatRing {
                deg: params.guided_flat_deg,
                frac: params.guided_flat_frac,
            }
        } else if params.guided_max_turn_deg > 0.0 {
            GuidedLimit::MaxTurn {
                deg: params.guided_max_turn_deg,
            }
        } else {
            GuidedLimit::Everywhere
        };
        Form::Guided {
            from: params.guided_from,
            mu_g: params.mu_g,
            limit,
        }
    }
}

/// When the run ends before `iterations`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopRule {
    /// never: every iteration runs (`auto_stop_deg` = 0)
    Never,
    /// after an iteration (from the second on) whose network outputs turned
    /// less than this many degrees on average
    MeanChange(f64),
    /// with the learned switch: after an iteration in which at least this
    /// share of faces (those not reusing an output) chose "stay"; any
    /// `auto_stop_deg` > 0 turns it on, its value is not read
    StayShare(f64),
}

impl StopRule {
    /// The rule `params` choose for `form`.
    pub fn of(params: &DenoiseParams, form: &Form) -> StopRule {
        match form {
            _ if params.auto_stop_deg <= 0.0 => StopRule::Never,
            Form::Switch(_) => StopRule::StayShare(switch::STAY_SHARE_TO_STOP),
            _ => StopRule::MeanChange(params.auto_stop_deg),
        }
    }

    /// Whether the run ends after iteration `k` with these figures.
    pub fn stops(&self, k: usize, mean_change_deg: f64, stay_share: f64) -> bool {
        match *self {
            StopRule::Never => false,
            StopRule::MeanChange(deg) => k > 1 && mean_change_deg < deg,
            StopRule::StayShare(share) => stay_share >= share,
        }
    }
}
