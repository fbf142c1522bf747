//! What `normalnet train` reads: the run's settings and its training sources.

use std::path::{Path, PathBuf};

use normalnet_cnn::{Arithmetic, Cnn, CnnError, Int8Range, Loss, NetWeights};
use normalnet_mesh::NoiseParams;
use normalnet_voxel::VoxelParams;
use serde::{Deserialize, Serialize};

use crate::NetError;
use crate::arch::ModelConfig;
use crate::bundle::INTERVALS;
use crate::learner::Engine;

/// One clean training mesh: a file under the data folder or a procedural
/// shape.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceSpec {
    /// path relative to `data_dir`, or `shape:SEED` for a procedural shape
    /// (`shape:KIND:SEED`: of that kind, e.g. `shape:polyhedron:160`, as
    /// `normalnet shapes --kind`)
    pub mesh: String,
    /// noisy copies: Gaussian levels L (σ = L·l_e)
    #[serde(default)]
    pub gaussian: Vec<f64>,
    /// noisy copies: impulsive, `[L, fraction]`
    #[serde(default)]
    pub impulsive: Vec<[f64; 2]>,
    /// noisy copies of any kind `normalnet noise` makes: each a list of
    /// components added in order (scanner-like noise, mixtures; the
    /// validation suite's `noise` format), e.g.
    /// `noise = [[{ level = 0.3, direction = "random" }], [{ level = 0.2 },
    /// { level = 1.0, impulsive_fraction = 0.05 }]]`. A component's `seed`
    /// is added to the copy's own seed ([`MIXTURE_SEED`]).
    #[serde(default)]
    pub noise: Vec<Vec<NoiseParams>>,
    /// regenerate M_k of this mesh with the CNN (else with the oracle)
    #[serde(default)]
    pub regen: bool,
}

/// Copy `j`'s component `k` of source `i` is seeded with `seed + 1000·i +
/// MIXTURE_SEED + 10·j + k` plus the component's own `seed` (Gaussian copies
/// take `1000·i + j`, impulsive ones `1000·i + 500 + j`).
pub const MIXTURE_SEED: u64 = 800;
/// Mixture copies per source at most (their seeds stay inside the source's
/// block of 1000).
pub const MAX_MIXTURES: usize = 20;
/// Components per mixture copy at most.
pub const MAX_COMPONENTS: usize = 10;

/// Everything `normalnet train` needs; `Default` is a small CPU run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// `paper`, `lite` or `tiny`
    pub preset: String,
    /// base seed (noise, sampling, yaw, initialisation)
    pub seed: u64,
    /// samples per step (SPEC: 80)
    pub batch: usize,
    /// base learning rate (SPEC: 1e-4)
    pub lr: f64,
    /// base learning rate of warm-started networks (k > 1 with
    /// `warm_start`); 0 = `lr`
    pub lr_warm: f64,
    /// lr multiplier per `lr_decay_steps` steps (SPEC: 0.96 per 5000)
    pub lr_decay: f64,
    /// steps per lr decay
    pub lr_decay_steps: usize,
    /// optimisation steps per network (six values)
    pub steps: [usize; 6],
    /// wall-clock limit per network in seconds (six values; 0 = none)
    pub max_seconds: [f64; 6],
    /// validate every this many steps
    pub validate_every: usize,
    /// faces in the validation set
    pub validation_faces: usize,
    /// write a resumable checkpoint every this many seconds (0: after
    /// every step). A resumed run gives the same networks as an
    /// uninterrupted one (same thread count and kernel path).
    pub checkpoint_seconds: f64,
    /// start network k from network k−1's weights
    pub warm_start: bool,
    /// loader threads
    pub workers: usize,
    /// folder of the training data (`data/` with `gd/`, `c3d/`); empty =
    /// the workspace's `../shared/data`
    pub data_dir: String,
    /// clean training sources and their noisy copies
    pub sources: Vec<SourceSpec>,
    /// validation sources (held-back training sources, never test models)
    pub validation: Vec<SourceSpec>,
    /// face count of procedural shapes (`shape:SEED`)
    pub shape_faces: usize,
    /// network inference batch during regeneration
    pub inference_batch: usize,
    /// train only the first this many networks (experiments; 6 = a bundle)
    pub stop_after: usize,
    /// training engine: `cnn` (the CPU engine of normalnet-cnn) or `burn`
    pub engine: String,
    /// loss on the 18 outputs: `mse` (SPEC §8) or `l1` (cnn engine only)
    pub loss: String,
    /// networks from this one on (1-based; 0 = none) predict the residual
    /// `target − input normal` instead of the normal (see
    /// `NetworkInfo::residual`)
    pub residual_from: usize,
    /// a bundle folder to continue from (empty = none): network k starts
    /// from the bundle's network k (same preset and residual form), and
    /// the manifest counts its samples and seconds on top of the bundle's
    pub init_from: String,
    /// The first network to train (1-based; default 1). The networks before
    /// it are `init_from`'s own, copied unchanged, and the training meshes
    /// are regenerated through them: e.g. `first_network = 6` continues
    /// only the bundle's last network.
    pub first_network: usize,
    /// κ: cubes of side `κ·d_s/α_c` instead of the preset's `d_s/α_c` (SPEC
    /// §5 scale note; 1 = the preset, ≈ 1.8 = the paper's implied extent).
    /// The bundle records the resulting `α_c/κ` as its `voxel.alpha_c`.
    pub voxel_scale: f64,
    /// the int8 ranges the bundle runs with: `full` (the default: the
    /// networks train in f32) or `narrow` (quantization-aware training: the
    /// forward pass rounds weights and activations to the narrow int8 steps,
    /// validation and regeneration run the narrow int8 inference, and the
    /// manifest says `int8_range = "narrow"`; `cnn` engine only)
    pub int8_range: Int8Range,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            preset: "lite".into(),
            seed: 1,
            batch: 80,
            lr: 1e-4,
            lr_warm: 0.0,
            lr_decay: 0.96,
            lr_decay_steps: 5000,
            steps: [200; 6],
            max_seconds: [0.0; 6],
            validate_every: 50,
            validation_faces: 320,
            checkpoint_seconds: 180.0,
            warm_start: true,
            workers: 2,
            data_dir: String::new(),
            sources: Vec::new(),
            validation: Vec::new(),
            shape_faces: 2000,
            inference_batch: 128,
            stop_after: 6,
            engine: "cnn".into(),
            loss: "mse".into(),
            residual_from: 0,
            init_from: String::new(),
            first_network: 1,
            voxel_scale: 1.0,
            int8_range: Int8Range::Full,
        }
    }
}

/// The `data/` folder next to the workspace (`../shared/data`).
pub fn default_data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"))
}

/// Names of the test models that must never be trained on (SOURCES.md).
pub const TEST_MODELS: [&str; 5] = [
    "Fandisk0.3",
    "Fandisk0.7",
    "Block0.4",
    "Twelve0.5Impulsive",
    "Bunny0.2",
];

impl TrainConfig {
    /// Reads a TOML config (missing fields take their defaults).
    pub fn read(path: &Path) -> Result<TrainConfig, NetError> {
        let text = std::fs::read_to_string(path).map_err(|e| NetError::io(path, e))?;
        let config: TrainConfig = toml::from_str(&text).map_err(|e| NetError::BadConfig {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        config.validate(path)?;
        Ok(config)
    }

    /// Checks ranges and that no test model is among the sources.
    pub fn validate(&self, path: &Path) -> Result<(), NetError> {
        let bad = |message: String| NetError::BadConfig {
            path: path.to_path_buf(),
            message,
        };
        ModelConfig::preset(&self.preset).map_err(|e| bad(e.to_string()))?;
        if self.batch == 0 || self.workers == 0 || self.validate_every == 0 {
            return Err(bad(
                "batch, workers and validate_every must be positive".into()
            ));
        }
        let engine = Engine::parse(&self.engine)
            .ok_or_else(|| bad(format!("engine = {:?}: expected cnn or burn", self.engine)))?;
        let loss = self
            .loss_fn()
            .ok_or_else(|| bad(format!("loss = {:?}: expected mse or l1", self.loss)))?;
        if !engine.available() {
            return Err(bad(
                "engine = \"burn\" needs a build with --features burn".into()
            ));
        }
        if engine == Engine::Burn && loss != Loss::Mse {
            return Err(bad("the burn engine trains with loss = \"mse\" only".into()));
        }
        if engine == Engine::Burn && self.fake_quant().is_some() {
            return Err(bad(
                "int8_range = \"narrow\" trains on the cnn engine only".into()
            ));
        }
        if !(self.voxel_scale > 0.0 && self.voxel_scale.is_finite()) {
            return Err(bad(format!(
                "voxel_scale = {} must be positive",
                self.voxel_scale
            )));
        }
        if !(1..=INTERVALS.len()).contains(&self.first_network) {
            return Err(bad(format!(
                "first_network = {} must lie in 1..=6",
                self.first_network
            )));
        }
        if self.first_network > 1 && self.init_from.is_empty() {
            return Err(bad(format!(
                "first_network = {} takes networks 1..{} from a bundle: set init_from",
                self.first_network,
                self.first_network - 1
            )));
        }
        if !(self.lr > 0.0 && self.lr.is_finite()) {
            return Err(bad(format!("lr = {} must be positive", self.lr)));
        }
        if self.sources.is_empty() {
            return Err(bad("no training sources".into()));
        }
        for s in self.sources.iter().chain(&self.validation) {
            if let Some(t) = TEST_MODELS.iter().find(|t| s.mesh.contains(*t)) {
                return Err(bad(format!(
                    "source {} is the test model {t}: never train or validate on it",
                    s.mesh
                )));
            }
            if s.gaussian.is_empty() && s.impulsive.is_empty() && s.noise.is_empty() {
                return Err(bad(format!("source {} has no noisy copies", s.mesh)));
            }
            if s.noise.len() > MAX_MIXTURES {
                return Err(bad(format!(
                    "source {}: {} noise copies, at most {MAX_MIXTURES}",
                    s.mesh,
                    s.noise.len()
                )));
            }
            for (j, copy) in s.noise.iter().enumerate() {
                if copy.is_empty() || copy.len() > MAX_COMPONENTS {
                    return Err(bad(format!(
                        "source {}: noise copy {} has {} components (1 to {MAX_COMPONENTS})",
                        s.mesh,
                        j + 1,
                        copy.len()
                    )));
                }
                for (k, c) in copy.iter().enumerate() {
                    c.validate().map_err(|e| {
                        bad(format!(
                            "source {}: noise copy {} component {}: {e}",
                            s.mesh,
                            j + 1,
                            k + 1
                        ))
                    })?;
                }
            }
        }
        Ok(())
    }

    /// The learning rate of network `k` (0-based) at its step `step`.
    pub fn lr_at(&self, k: usize, step: usize) -> f64 {
        let base = if k > 0 && self.warm_start && self.lr_warm > 0.0 {
            self.lr_warm
        } else {
            self.lr
        };
        base * self
            .lr_decay
            .powf(step as f64 / self.lr_decay_steps.max(1) as f64)
    }

    /// The voxel grid of the run: the preset's, cubes scaled by `voxel_scale`.
    pub fn voxel_params(&self) -> VoxelParams {
        let mut voxel = match self.preset.as_str() {
            "paper" => VoxelParams::paper(),
            "tiny" => VoxelParams::tiny(),
            _ => VoxelParams::lite(),
        };
        voxel.alpha_c /= self.voxel_scale;
        voxel
    }

    /// Whether network `k` (0-based) predicts residuals.
    pub fn residual(&self, k: usize) -> bool {
        self.residual_from > 0 && k + 1 >= self.residual_from
    }

    /// The int8 steps the networks train on (quantization-aware training):
    /// the narrow ones with `int8_range = "narrow"`, none with full ranges.
    pub fn fake_quant(&self) -> Option<Int8Range> {
        (self.int8_range == Int8Range::Narrow).then_some(Int8Range::Narrow)
    }

    /// `net` compiled for this run's validation and regeneration: the f32
    /// inference (full ranges), or the narrow int8 inference the bundle
    /// will run (`int8_range = "narrow"`).
    pub fn inference_engine(&self, net: &NetWeights) -> Result<Cnn, CnnError> {
        let mut cnn = Cnn::new(net)?;
        if let Some(range) = self.fake_quant() {
            cnn.set_int8_range(range);
            cnn.set_arithmetic(Arithmetic::INT8);
        }
        Ok(cnn)
    }

    pub(super) fn loss_fn(&self) -> Option<Loss> {
        match self.loss.as_str() {
            "mse" => Some(Loss::Mse),
            "l1" => Some(Loss::L1),
            _ => None,
        }
    }

    pub(super) fn data_dir(&self) -> PathBuf {
        if self.data_dir.is_empty() {
            default_data_dir()
        } else {
            PathBuf::from(&self.data_dir)
        }
    }
}
