//! Iterative training of the six networks (paper §4, SPEC §8).
//!
//! `M_1` = noisy copies of the clean training sources. Network k (interval
//! `[a_k, b_k]` of [`INTERVALS`]) is trained on samples of the meshes
//! `M_{a_k}`: (voxel grid of face f with random yaw, the six GT-guided GNF
//! targets of f in the same frame), balanced over the four `A_p` categories
//! and built on the fly by loader threads (`normalnet_samples::Loader`). Loss
//! MSE, Adam (0.9, 0.999, 1e-8), lr `base · 0.96^(step / 5000)`, batch 80.
//! After network k is trained, `M_{a_{k+1}}` is made by running network k
//! (μ_g 0.4, N_v 20) `a_{k+1} − a_k` times on `M_{a_k}` — network k is the one
//! inference uses for those iterations.
//!
//! Deviations for a CPU budget (all recorded in the bundle manifest):
//! - meshes marked `regen` in the config (small ones) are regenerated with
//!   the CNN; the others (large meshes, validation meshes) with the *oracle*
//!   the CNN is trained to imitate: one GT-guided GNF pass at μ_g 0.4
//!   (σ_s = 2·d_s) + N_v 20 vertex updates per iteration;
//! - network k > 1 starts from network k−1's weights (warm start);
//! - step counts and wall-clock limits per network come from the config.
//!
//! The run is resumable: every few minutes the current weights, Adam state
//! and step are written to `OUT/checkpoint/step-S/` (and `OUT/state.toml`); the best weights (lowest
//! validation error) to `OUT/netK.safetensors`; the mesh states `M_k` to
//! `OUT/states/`. `--resume` continues where it stopped.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use normalnet_filters::{GtGuidedGnfParams, gt_guided_gnf};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::noise::add_noise_mixture;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Mesh, NoProgress, NoiseParams, Progress, Topology};
use normalnet_samples::{BalancedSampler, Loader, LoaderConfig, SampleSource};
use normalnet_voxel::VoxelParams;
use serde::{Deserialize, Serialize};

use crate::NetError;
use crate::arch::{MU_GS, ModelConfig, NUM_OUTPUTS};
use crate::bundle::{INTERVALS, MANIFEST, Manifest, NetworkInfo, new_manifest, write_atomically};
use crate::data::SampleBatch;
use crate::learner::{Engine, Learner};
use crate::pipeline::filtered_normals;
use crate::weights_file::load as load_network;
use normalnet_cnn::Loss;
use normalnet_cnn::{Cnn, NetWeights};

/// Output slot of μ_g 0.35, the one validated (SPEC §8).
const VALIDATION_SLOT: usize = 2;
/// μ_g used to regenerate the meshes M_k (SPEC §8).
const REGEN_MU_G: f64 = 0.4;
/// Vertex updates per regeneration iteration (SPEC §8).
const REGEN_VERTEX_ITERATIONS: usize = 20;

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

    fn loss_fn(&self) -> Option<Loss> {
        match self.loss.as_str() {
            "mse" => Some(Loss::Mse),
            "l1" => Some(Loss::L1),
            _ => None,
        }
    }

    fn data_dir(&self) -> PathBuf {
        if self.data_dir.is_empty() {
            default_data_dir()
        } else {
            PathBuf::from(&self.data_dir)
        }
    }
}

/// A noisy/clean pair and its current state M_k.
struct Pair {
    name: String,
    clean: Mesh,
    gt: Vec<Vec3>,
    state: Mesh,
    regen: bool,
}

fn load_source(config: &TrainConfig, spec: &SourceSpec) -> Result<Mesh, NetError> {
    if let Some(rest) = spec.mesh.strip_prefix("shape:") {
        let bad = || NetError::BadConfig {
            path: PathBuf::from("<config>"),
            message: format!("{}: expected shape:SEED or shape:KIND:SEED", spec.mesh),
        };
        // shape:SEED (the kind the seed picks) or shape:KIND:SEED
        let (kind, seed) = match rest.split_once(':') {
            Some((kind, seed)) => (
                Some(normalnet_voxel::shapes::ShapeKind::from_name(kind)?),
                seed,
            ),
            None => (None, rest),
        };
        let seed: u64 = seed.parse().map_err(|_| bad())?;
        Ok(match kind {
            Some(kind) => normalnet_voxel::shapes::generate(kind, seed, config.shape_faces)?,
            None => normalnet_voxel::shapes::generate_seeded(seed, config.shape_faces)?,
        })
    } else {
        Ok(normalnet_mesh::read_mesh(
            config.data_dir().join(&spec.mesh),
        )?)
    }
}

/// The noisy copies of `specs` as `make_pairs` builds them for training
/// (same names, noise levels and seeds): `(name, clean, noisy)`. Other
/// learned methods (CNR) train on exactly NormalNet's data through it.
pub fn noisy_pairs(
    config: &TrainConfig,
    specs: &[SourceSpec],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<(String, Mesh, Mesh)>, NetError> {
    Ok(make_pairs(config, specs, seed, progress)?
        .into_iter()
        .map(|p| (p.name, p.clean, p.state))
        .collect())
}

fn make_pairs(
    config: &TrainConfig,
    specs: &[SourceSpec],
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<Pair>, NetError> {
    let mut pairs = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        progress.message(&format!("loading {}", spec.mesh));
        let clean = load_source(config, spec)?;
        let gt = face_normals(&clean);
        let mut copies: Vec<(String, Vec<NoiseParams>)> = Vec::new();
        for (j, &l) in spec.gaussian.iter().enumerate() {
            copies.push((
                format!("{} gaussian L={l}", spec.mesh),
                vec![NoiseParams {
                    level: l,
                    seed: seed + 1000 * i as u64 + j as u64,
                    ..NoiseParams::default()
                }],
            ));
        }
        for (j, &[l, p]) in spec.impulsive.iter().enumerate() {
            copies.push((
                format!("{} impulsive L={l} p={p}", spec.mesh),
                vec![NoiseParams {
                    level: l,
                    impulsive_fraction: Some(p),
                    seed: seed + 1000 * i as u64 + 500 + j as u64,
                    ..NoiseParams::default()
                }],
            ));
        }
        for (j, copy) in spec.noise.iter().enumerate() {
            let base = seed + 1000 * i as u64 + MIXTURE_SEED + 10 * j as u64;
            let components: Vec<NoiseParams> = copy
                .iter()
                .enumerate()
                .map(|(k, c)| NoiseParams {
                    seed: base + k as u64 + c.seed,
                    ..*c
                })
                .collect();
            copies.push((format!("{} noise {}", spec.mesh, j + 1), components));
        }
        for (name, noise) in copies {
            let (noisy, _) = add_noise_mixture(&clean, &noise)?;
            pairs.push(Pair {
                name,
                clean: clean.clone(),
                gt: gt.clone(),
                state: noisy,
                regen: spec.regen,
            });
        }
    }
    Ok(pairs)
}

/// Moves the training and validation meshes from the state network `k`
/// (0-based) meets to the next network's (`regenerate` for the passes of
/// network `k`'s interval) and saves them in `OUT/states/` for `--resume`.
fn advance_meshes(
    pairs: &mut [Pair],
    val_pairs: &mut [Pair],
    net: &NetWeights,
    k: usize,
    config: &TrainConfig,
    out: &Path,
    progress: &dyn Progress,
) -> Result<(), NetError> {
    let engine = Cnn::new(net).map_err(|e| NetError::Record {
        path: out.join(crate::bundle::network_file(k)),
        message: e.to_string(),
    })?;
    let passes = INTERVALS[k + 1].0 - INTERVALS[k].0;
    progress.message(&format!("regenerating meshes with network {}", k + 1));
    for set in [&mut *pairs, &mut *val_pairs] {
        regenerate(
            set,
            &engine,
            config.residual(k),
            config.voxel_params(),
            passes,
            config.inference_batch,
            progress,
        )?;
    }
    for (i, p) in pairs.iter().chain(val_pairs.iter()).enumerate() {
        normalnet_mesh::write_mesh(
            out.join("states").join(format!("stage{}_{i}.obj", k + 1)),
            &p.state,
        )?;
    }
    Ok(())
}

/// The checkpoint folder of step `step` of the network being trained.
fn checkpoint_dir(out: &Path, step: usize) -> PathBuf {
    out.join("checkpoint").join(format!("step-{step}"))
}

/// Removes the checkpoint folders under `root` but `keep`.
fn remove_checkpoints(root: &Path, keep: Option<&Path>) {
    let Ok(entries) = std::fs::read_dir(root) else {
        return;
    };
    for e in entries.flatten() {
        let path = e.path();
        if Some(path.as_path()) != keep && path.is_dir() {
            let _ = std::fs::remove_dir_all(&path);
        }
    }
    Learner::clear_checkpoint(root);
}

/// Per-network progress, saved in `OUT/state.toml` for `--resume`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct RunState {
    /// networks finished (their best weights are `OUT/netK.safetensors`)
    finished: usize,
    /// the manifest entries of finished networks
    networks: Vec<NetworkInfo>,
    /// step reached in the network being trained (checkpoint)
    step: usize,
    /// best validation error so far in that network
    best_val: f64,
    /// seconds spent so far in that network
    seconds: f64,
    /// losses summed for the manifest's mean
    loss_tail: Vec<f64>,
}

/// Trains the six networks of `config` into `out` and writes the bundle
/// there (`net1.safetensors`…`net6.safetensors` + `manifest.toml`, `train_log.csv`,
/// `loss.png`). With `resume`, continues from `out/state.toml`.
///
/// # Errors
/// Unreadable sources, invalid configuration, I/O errors.
pub fn train(
    config: &TrainConfig,
    out: &Path,
    resume: bool,
    progress: &dyn Progress,
) -> Result<Manifest, NetError> {
    config.validate(Path::new("<config>"))?;
    let run_start = Instant::now();
    std::fs::create_dir_all(out.join("checkpoint")).map_err(|e| NetError::io(out, e))?;
    std::fs::create_dir_all(out.join("states")).map_err(|e| NetError::io(out, e))?;
    let state_path = out.join("state.toml");
    let mut run = if resume && state_path.is_file() {
        let text =
            std::fs::read_to_string(&state_path).map_err(|e| NetError::io(&state_path, e))?;
        toml::from_str::<RunState>(&text).map_err(|e| NetError::BadConfig {
            path: state_path.clone(),
            message: e.to_string(),
        })?
    } else {
        RunState {
            best_val: f64::INFINITY,
            ..RunState::default()
        }
    };
    write_atomically(
        &out.join("config.toml"),
        toml::to_string_pretty(config)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    let model_config = ModelConfig::preset(&config.preset)?;
    let voxel = config.voxel_params();
    let init = init_bundle(config)?;
    let mut pairs = make_pairs(config, &config.sources, config.seed, progress)?;
    let mut val_pairs = make_pairs(config, &config.validation, config.seed + 777, progress)?;
    let log_path = out.join("train_log.csv");
    if !log_path.is_file() || !resume {
        write_atomically(&log_path, b"network,step,lr,loss,val_deg,seconds\n")?;
    }
    let mut networks: Vec<NetWeights> = Vec::new();
    for k in 0..run.finished {
        networks.push(load_network(
            &model_config,
            &config.preset,
            &out.join(crate::bundle::network_file(k)),
        )?);
    }
    // restore the mesh states M_{a_k} of the first unfinished network
    if run.finished > 0 {
        let stage = run.finished;
        for (i, p) in pairs.iter_mut().chain(val_pairs.iter_mut()).enumerate() {
            let file = out.join("states").join(format!("stage{stage}_{i}.obj"));
            if file.is_file() {
                let m = normalnet_mesh::read_mesh(&file)?;
                if m.faces == p.state.faces && m.num_vertices() == p.state.num_vertices() {
                    p.state = m;
                }
            }
        }
    }
    // networks before `first_network`: the init bundle's own, unchanged
    if let Some((dir, manifest)) = &init {
        for k in run.finished..config.first_network - 1 {
            let file = crate::bundle::network_file(k);
            std::fs::copy(dir.join(&file), out.join(&file)).map_err(|e| NetError::io(out, e))?;
            let net = load_network(&model_config, &config.preset, &out.join(&file))?;
            advance_meshes(&mut pairs, &mut val_pairs, &net, k, config, out, progress)?;
            networks.push(net);
            run.networks.truncate(k);
            run.networks.push(manifest.networks[k].clone());
            run.finished = k + 1;
            save_state(out, &run)?;
        }
    }
    let mut total_pool = 0;
    for k in run.finished..INTERVALS.len().min(config.stop_after) {
        let net_start = Instant::now();
        progress.message(&format!("network {}: building samples", k + 1));
        let residual = config.residual(k);
        let sources: Vec<SampleSource> = pairs
            .iter()
            .map(|p| {
                SampleSource::new(p.state.clone(), &p.clean, voxel, &MU_GS)
                    .map(|s| s.with_residual(residual))
            })
            .collect::<Result<_, _>>()?;
        let sources = Arc::new(sources);
        let sampler = BalancedSampler::new(sources.iter());
        let pool_faces: usize = sampler.category_sizes().iter().sum();
        total_pool = pool_faces;
        let val = validation_set(&val_pairs, voxel, config, k, residual)?;
        // model: resume checkpoint, else warm start, else fresh
        let ckpt_root = out.join("checkpoint");
        let engine = Engine::parse(&config.engine).unwrap_or(Engine::Cnn);
        let loss_fn = config.loss_fn().unwrap_or_default();
        let start_net = if let Some((dir, _)) = &init {
            load_network(
                &model_config,
                &config.preset,
                &dir.join(crate::bundle::network_file(k)),
            )?
        } else if config.warm_start && k > 0 {
            load_network(
                &model_config,
                &config.preset,
                &out.join(crate::bundle::network_file(k - 1)),
            )?
        } else {
            model_config.init_weights(config.seed + k as u64)
        };
        // a network that starts predicting residuals starts at the identity:
        // zero output layer (its own gradient is not zero, so it learns)
        let start_net = if residual && init.is_none() {
            zero_output_layer(start_net)
        } else {
            start_net
        };
        let mut learner = Learner::new(engine, &start_net, &model_config, loss_fn)?;
        let resumed = resume
            && run.step > 0
            && learner.restore(&checkpoint_dir(out, run.step), &model_config)?;
        if !resumed {
            run.step = 0;
            run.best_val = f64::INFINITY;
            run.seconds = 0.0;
            run.loss_tail.clear();
        }
        let steps = config.steps[k];
        let items = sampler.draw_count_seeded(steps * config.batch, config.seed + 10 * k as u64);
        let skip = (run.step * config.batch).min(items.len());
        let loader = Loader::new(
            Arc::clone(&sources),
            items[skip..].to_vec(),
            LoaderConfig {
                batch_size: config.batch,
                workers: config.workers,
                prefetch: 3,
                seed: config.seed + 100 * k as u64,
                first_stream: run.step as u64,
                yaw_augmentation: true,
                keep_last: false,
            },
        )?;
        let baseline = val.baseline_deg;
        if run.best_val.is_infinite() {
            let e = validation_error(&learner.compiled(&model_config)?, &val);
            run.best_val = e;
            learner.save(&out.join(crate::bundle::network_file(k)), &model_config)?;
            append_log(
                &log_path,
                k,
                run.step,
                config.lr_at(k, run.step),
                f64::NAN,
                e,
                run.seconds,
            )?;
        }
        progress.start(&format!("network {}", k + 1), steps as u64);
        progress.advance(run.step as u64);
        let mut last_ckpt = Instant::now();
        let seconds_before = run.seconds;
        let limit = config.max_seconds[k];
        let mut batch_buf = SampleBatch::with_capacity(voxel.side(), config.batch);
        for b in loader {
            let lr = config.lr_at(k, run.step);
            batch_buf.len = b.len();
            batch_buf.grids = b.grids;
            batch_buf.targets = b.targets;
            let loss = learner.step(&batch_buf, lr)?;
            run.step += 1;
            run.seconds = seconds_before + net_start.elapsed().as_secs_f64();
            run.loss_tail.push(loss);
            if run.loss_tail.len() > 50 {
                run.loss_tail.remove(0);
            }
            progress.advance(1);
            let mut val_err = f64::NAN;
            let time_up = limit > 0.0 && run.seconds >= limit;
            if run.step % config.validate_every == 0 || run.step == steps || time_up {
                val_err = validation_error(&learner.compiled(&model_config)?, &val);
                if val_err < run.best_val {
                    run.best_val = val_err;
                    learner.save(&out.join(crate::bundle::network_file(k)), &model_config)?;
                }
            }
            progress.message(&format!(
                "net {} step {} loss {loss:.4} val {:.2}° (best {:.2}°, input {baseline:.2}°)",
                k + 1,
                run.step,
                if val_err.is_nan() {
                    run.best_val
                } else {
                    val_err
                },
                run.best_val
            ));
            append_log(&log_path, k, run.step, lr, loss, val_err, run.seconds)?;
            if last_ckpt.elapsed().as_secs_f64() >= config.checkpoint_seconds {
                // the learner's state of step s in checkpoint/step-s, then the
                // run state naming s, then the older folders go: a run
                // killed anywhere in between resumes from a matching pair
                let dir = checkpoint_dir(out, run.step);
                std::fs::create_dir_all(&dir).map_err(|e| NetError::io(&dir, e))?;
                learner.checkpoint(&dir)?;
                save_state(out, &run)?;
                remove_checkpoints(&ckpt_root, Some(&dir));
                last_ckpt = Instant::now();
            }
            if time_up {
                break;
            }
        }
        progress.finish();
        // network k done: record it, then regenerate M for the next interval
        let best = load_network(
            &model_config,
            &config.preset,
            &out.join(crate::bundle::network_file(k)),
        )?;
        let (prior_samples, prior_seconds) = init.as_ref().map_or((0, 0.0), |(_, m)| {
            (m.networks[k].samples_seen, m.networks[k].train_seconds)
        });
        let info = NetworkInfo {
            file: crate::bundle::network_file(k),
            interval: Manifest::default_intervals()[k],
            steps: run.step,
            samples_seen: prior_samples + run.step * config.batch,
            pool_faces,
            epochs: (run.step * config.batch) as f64 / pool_faces.max(1) as f64,
            train_seconds: prior_seconds + run.seconds,
            train_loss: mean(&run.loss_tail),
            validation_error_deg: run.best_val,
            validation_baseline_deg: baseline,
            residual,
        };
        if k + 1 < INTERVALS.len().min(config.stop_after) {
            advance_meshes(&mut pairs, &mut val_pairs, &best, k, config, out, progress)?;
        }
        networks.push(best);
        run.networks.truncate(k);
        run.networks.push(info);
        run.finished = k + 1;
        run.step = 0;
        run.best_val = f64::INFINITY;
        run.seconds = 0.0;
        run.loss_tail.clear();
        save_state(out, &run)?;
        remove_checkpoints(&ckpt_root, None);
    }
    if run.finished < INTERVALS.len() {
        crate::plot::loss_curve_png(&log_path, &out.join("loss.png"))?;
        return Err(NetError::BadConfig {
            path: out.join("config.toml"),
            message: format!(
                "stop_after = {}: trained {} of 6 networks, no bundle written",
                config.stop_after, run.finished
            ),
        });
    }
    // the manifest
    let mut manifest = new_manifest(&config.preset)?;
    manifest.voxel = voxel;
    manifest.networks = run.networks.clone();
    manifest.training = crate::bundle::TrainingInfo {
        sources: pairs.iter().map(|p| p.name.clone()).collect(),
        validation: val_pairs.iter().map(|p| p.name.clone()).collect(),
        noise: "Gaussian along clean vertex normals, σ = L·l_e, and impulsive (fraction p of vertices); seeds = seed + 1000·source + copy".into(),
        seed: config.seed,
        batch: config.batch,
        learning_rate: format!(
            "{} (warm-started networks: {}) × {}^(step/{}) per network, Adam(0.9, 0.999, 1e-8), loss {}",
            config.lr,
            if config.lr_warm > 0.0 { config.lr_warm } else { config.lr },
            config.lr_decay,
            config.lr_decay_steps,
            config.loss.to_uppercase()
        ),
        regeneration: format!(
            "M_(k+1) from network k at μ_g {REGEN_MU_G}, N_v {REGEN_VERTEX_ITERATIONS}: CNN on {} (regen = true), oracle GT-guided GNF pass (μ_g 0.4, σ_s 2·d_s) on {}",
            names(pairs.iter().chain(&val_pairs).filter(|p| p.regen)),
            names(pairs.iter().chain(&val_pairs).filter(|p| !p.regen))
        ),
        notes: format!(
            "{}steps per network {:?}, wall-clock limits {:?} s, warm start {}, validation = mean angle (deg) of the μ_g 0.35 output vs its target on {} balanced faces (yaw 0); last sample pool {} faces; total run {:.0} s",
            init.as_ref().map_or(String::new(), |(dir, _)| format!(
                "continued from the bundle {} (samples and seconds include its training{}); ",
                dir.display(),
                if config.first_network > 1 {
                    format!(
                        "; networks 1..{} are its own, unchanged",
                        config.first_network - 1
                    )
                } else {
                    String::new()
                }
            )),
            config.steps, config.max_seconds, config.warm_start, config.validation_faces, total_pool,
            run_start.elapsed().as_secs_f64()
        ),
    };
    manifest.write(&out.join(MANIFEST))?;
    crate::plot::loss_curve_png(&log_path, &out.join("loss.png"))?;
    Ok(manifest)
}

/// The pairs' names joined for the manifest ("none" when there are none).
fn names<'a>(pairs: impl Iterator<Item = &'a Pair>) -> String {
    let list: Vec<&str> = pairs.map(|p| p.name.as_str()).collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join("; ")
    }
}

/// The bundle `init_from` names, checked against the run: same preset, the
/// same residual form per network, six networks.
fn init_bundle(config: &TrainConfig) -> Result<Option<(PathBuf, Manifest)>, NetError> {
    if config.init_from.is_empty() {
        return Ok(None);
    }
    let dir = PathBuf::from(&config.init_from);
    let path = dir.join(MANIFEST);
    let manifest = Manifest::read(&path)?;
    let bad = |message: String| NetError::BadConfig {
        path: path.clone(),
        message,
    };
    if manifest.preset != config.preset {
        return Err(bad(format!(
            "init_from: the bundle is preset {:?}, the run {:?}",
            manifest.preset, config.preset
        )));
    }
    if manifest.voxel != config.voxel_params() {
        return Err(bad(format!(
            "init_from: the bundle's voxel grid {:?} differs from the run's {:?} (voxel_scale)",
            manifest.voxel,
            config.voxel_params()
        )));
    }
    if manifest.networks.len() != INTERVALS.len() {
        return Err(bad(format!(
            "init_from: the bundle has {} networks, expected {}",
            manifest.networks.len(),
            INTERVALS.len()
        )));
    }
    for (k, n) in manifest.networks.iter().enumerate() {
        if n.residual != config.residual(k) {
            return Err(bad(format!(
                "init_from: network {} of the bundle has residual = {}, the run's residual_from = {} says {}",
                k + 1,
                n.residual,
                config.residual_from,
                config.residual(k)
            )));
        }
    }
    Ok(Some((dir, manifest)))
}

/// `w` with its output layer's weights and bias set to zero.
fn zero_output_layer(mut w: NetWeights) -> NetWeights {
    w.output.weight.fill(0.0);
    if let Some(b) = w.output.bias.as_mut() {
        b.fill(0.0);
    }
    w
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn append_log(
    path: &Path,
    k: usize,
    step: usize,
    lr: f64,
    loss: f64,
    val: f64,
    seconds: f64,
) -> Result<(), NetError> {
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(path)
        .map_err(|e| NetError::io(path, e))?;
    let fmt = |x: f64| {
        if x.is_finite() {
            format!("{x:.6}")
        } else {
            String::new()
        }
    };
    writeln!(
        f,
        "{},{step},{lr:.3e},{},{},{seconds:.1}",
        k + 1,
        fmt(loss),
        fmt(val)
    )
    .map_err(|e| NetError::io(path, e))
}

fn save_state(out: &Path, run: &RunState) -> Result<(), NetError> {
    let mut r = run.clone();
    if !r.best_val.is_finite() {
        r.best_val = 1e9;
    }
    let text = toml::to_string_pretty(&r).map_err(|e| NetError::BadConfig {
        path: out.join("state.toml"),
        message: e.to_string(),
    })?;
    write_atomically(&out.join("state.toml"), text.as_bytes())
}

/// Fixed validation faces of one stage: grids (yaw 0) and targets.
struct ValidationSet {
    batch: SampleBatch,
    baseline_deg: f64,
    /// with residual targets: each face's input normal in its local frame
    /// (added to outputs and targets before comparing)
    inputs: Option<Vec<[f32; 3]>>,
}

fn validation_set(
    pairs: &[Pair],
    voxel: VoxelParams,
    config: &TrainConfig,
    k: usize,
    residual: bool,
) -> Result<ValidationSet, NetError> {
    let sources: Vec<SampleSource> = pairs
        .iter()
        .map(|p| {
            SampleSource::new(p.state.clone(), &p.clean, voxel, &MU_GS)
                .map(|s| s.with_residual(residual))
        })
        .collect::<Result<_, _>>()?;
    let mut inputs = Vec::new();
    let mut scratch = normalnet_voxel::Scratch::new();
    let sampler = BalancedSampler::new(sources.iter());
    let items = sampler.draw_count_seeded(config.validation_faces, config.seed + 99 + k as u64);
    let mut batch = SampleBatch::with_capacity(voxel.side(), items.len());
    let grid_len = voxel.grid_len();
    let mut baseline = 0.0;
    for it in &items {
        let src = &sources[it.source as usize];
        let start = batch.grids.len();
        batch.grids.resize(start + grid_len, 0.0);
        let (t, frame) = src.sample_with(
            &mut scratch,
            it.face as usize,
            0.0,
            &mut batch.grids[start..],
        );
        batch.targets.extend_from_slice(&t);
        inputs.push(src.local_input(&frame, it.face as usize));
        let current = src.voxelizer().geometry().normals[it.face as usize];
        let target = src.world_targets(it.face as usize)[VALIDATION_SLOT];
        baseline += vec3::angle(current, target).to_degrees();
    }
    batch.len = items.len();
    Ok(ValidationSet {
        baseline_deg: baseline / items.len().max(1) as f64,
        batch,
        inputs: residual.then_some(inputs),
    })
}

/// Mean angle (degrees) between the μ_g-0.35 output and its target, on the
/// CPU inference engine (same outputs as burn's inference mode).
fn validation_error(cnn: &normalnet_cnn::Cnn, val: &ValidationSet) -> f64 {
    if val.batch.len == 0 {
        return f64::NAN;
    }
    let mut out = vec![0.0f32; val.batch.len * NUM_OUTPUTS];
    if cnn.forward(&val.batch.grids, &mut out).is_err() {
        return f64::NAN;
    }
    let mut sum = 0.0;
    for i in 0..val.batch.len {
        let o = &out[i * NUM_OUTPUTS + 3 * VALIDATION_SLOT..][..3];
        let t = &val.batch.targets[i * NUM_OUTPUTS + 3 * VALIDATION_SLOT..][..3];
        let base = val.inputs.as_ref().map_or([0.0; 3], |v| v[i]);
        let o = [
            (o[0] + base[0]) as f64,
            (o[1] + base[1]) as f64,
            (o[2] + base[2]) as f64,
        ];
        let t = [
            (t[0] + base[0]) as f64,
            (t[1] + base[1]) as f64,
            (t[2] + base[2]) as f64,
        ];
        sum += if vec3::norm(o) == 0.0 || !vec3::norm(o).is_finite() {
            90.0
        } else {
            vec3::angle(o, t).to_degrees()
        };
    }
    sum / val.batch.len as f64
}

/// Runs `passes` filtering iterations on every pair's state: network `net`
/// for pairs marked `regen`, the GT-guided oracle for the others.
#[allow(clippy::too_many_arguments)]
fn regenerate(
    pairs: &mut [Pair],
    net: &Cnn,
    residual: bool,
    voxel: VoxelParams,
    passes: usize,
    batch: usize,
    progress: &dyn Progress,
) -> Result<(), NetError> {
    let slot = crate::bundle::nearest_mu_g(&MU_GS, REGEN_MU_G);
    for p in pairs.iter_mut() {
        progress.message(&format!("regenerating {} ({} passes)", p.name, passes));
        if p.regen {
            let topology = Topology::new(p.state.num_vertices(), &p.state.faces);
            let mut positions = p.state.positions.clone();
            let mut buffers = normalnet_filters::VertexUpdateBuffers::default();
            for _ in 0..passes {
                let current = p.state.with_positions(positions.clone());
                let (normals, _) = filtered_normals(
                    &current,
                    &topology,
                    net,
                    residual,
                    voxel,
                    slot,
                    batch,
                    None,
                    &NoProgress,
                )?;
                normalnet_filters::vertex_update_in_place(
                    &mut positions,
                    &p.state.faces,
                    &topology,
                    &normals,
                    REGEN_VERTEX_ITERATIONS,
                    &mut buffers,
                );
            }
            p.state = p.state.with_positions(positions);
        } else {
            let params = GtGuidedGnfParams {
                mu_g: REGEN_MU_G,
                iterations: passes,
                vertex_iterations: REGEN_VERTEX_ITERATIONS,
                ..GtGuidedGnfParams::default()
            };
            p.state = gt_guided_gnf(&p.state, &p.gt, &params, &NoProgress)?;
        }
    }
    Ok(())
}
