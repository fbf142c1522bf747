//! What a run reports: seconds per stage and per iteration
//! ([`StageTimes`], [`IterationStats`]).

use serde::Serialize;

/// Wall-clock seconds per stage, summed over iterations.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// building the voxelizer and voxelizing (producer thread; overlaps the CNN)
    pub voxelize_s: f64,
    /// network forward passes and output conversion
    pub cnn_s: f64,
    /// vertex updates
    pub vertex_update_s: f64,
    /// whole run
    pub total_s: f64,
    /// faces voxelized and run through the network (all iterations)
    pub faces_processed: usize,
    /// one entry per filtering iteration that ran
    pub iterations: Vec<IterationStats>,
}

/// What one filtering iteration did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct IterationStats {
    /// the network that served it (1-based)
    pub network: usize,
    /// faces voxelized and run through the network (the others were frozen)
    pub faces_evaluated: usize,
    /// mean angle in degrees between this iteration's filtered normals
    /// (network outputs, flat faces' 2-ring means) and the previous
    /// iteration's, over all faces (0 in the first)
    pub mean_change_deg: f64,
    /// wall-clock seconds of the iteration
    pub seconds: f64,
    /// with the learned switch: the share of faces whose largest weight was
    /// "stay" (the run stops at [`crate::switch::STAY_SHARE_TO_STOP`]); 0 without it
    pub stay_share: f64,
    /// with the learned switch: the share of faces folded in the mesh the
    /// iteration started from (they take the network's output where the
    /// switch table says so, [`crate::switch::SwitchWeights::network_on_folds`]);
    /// 0 without it
    pub folded_share: f64,
    /// network evaluations per face: the yaw views this iteration took
    /// ([`crate::DenoiseParams::yaw_views`]; 1 = one evaluation)
    pub yaw_views: usize,
}

impl StageTimes {
    /// Adds `other`'s seconds and face count.
    pub(crate) fn add(&mut self, other: &StageTimes) {
        self.voxelize_s += other.voxelize_s;
        self.cnn_s += other.cnn_s;
        self.vertex_update_s += other.vertex_update_s;
        self.faces_processed += other.faces_processed;
    }
}
