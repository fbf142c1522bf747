//! The training run in `OUT`: the six networks one after another, each from
//! its checkpoint, warm start or initialisation, its best weights kept, the
//! meshes moved on to the next network's state, then the bundle's manifest.
//! Every step writes what a resumed run needs (module docs of [`super`]).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use normalnet_cnn::{Cnn, NetWeights};
use normalnet_mesh::{Mesh, Progress};
use normalnet_samples::{BalancedSampler, Loader, LoaderConfig, SampleRef, SampleSource};
use normalnet_voxel::VoxelParams;
use serde::{Deserialize, Serialize};

use super::pairs::{Pair, make_pairs, names, regenerate, sample_sources};
use super::validation::{ValidationSet, validation_error, validation_set};
use super::{REGEN_MU_G, REGEN_VERTEX_ITERATIONS, TrainConfig};
use crate::NetError;
use crate::arch::ModelConfig;
use crate::bundle::{
    INTERVALS, MANIFEST, Manifest, NetworkInfo, TrainingInfo, fnv1a, network_file, new_manifest,
    write_atomically,
};
use crate::data::SampleBatch;
use crate::learner::{Engine, Learner};
use crate::weights_file::load as load_network;

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
    let started = Instant::now();
    let mut run = Run::open(config, out, resume, progress)?;
    run.restore_finished()?;
    run.take_init_networks()?;
    let mut pool_faces = 0;
    for k in run.state.finished..run.networks_to_train() {
        pool_faces = run.train_network(k)?;
    }
    run.finish(pool_faces, started)
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

impl RunState {
    /// `OUT/state.toml` when resuming and it exists, else a new run's.
    fn read_or_new(out: &Path, resume: bool) -> Result<RunState, NetError> {
        let path = out.join("state.toml");
        if !(resume && path.is_file()) {
            return Ok(RunState {
                best_val: f64::INFINITY,
                ..RunState::default()
            });
        }
        let text = std::fs::read_to_string(&path).map_err(|e| NetError::io(&path, e))?;
        toml::from_str(&text).map_err(|e| NetError::BadConfig {
            path,
            message: e.to_string(),
        })
    }

    /// Writes `OUT/state.toml` whole.
    fn save(&self, out: &Path) -> Result<(), NetError> {
        let mut state = self.clone();
        if !state.best_val.is_finite() {
            state.best_val = 1e9;
        }
        let text = toml::to_string_pretty(&state).map_err(|e| NetError::BadConfig {
            path: out.join("state.toml"),
            message: e.to_string(),
        })?;
        write_atomically(&out.join("state.toml"), text.as_bytes())
    }

    /// The progress of a network not started yet.
    fn start_network(&mut self) {
        self.step = 0;
        self.best_val = f64::INFINITY;
        self.seconds = 0.0;
        self.loss_tail.clear();
    }

    /// One training step done, with its loss, `seconds` into the network.
    fn after_step(&mut self, loss: f64, seconds: f64) {
        self.step += 1;
        self.seconds = seconds;
        self.loss_tail.push(loss);
        if self.loss_tail.len() > 50 {
            self.loss_tail.remove(0);
        }
    }

    /// Network `k` (0-based) is done, as `info`.
    fn finish_network(&mut self, k: usize, info: NetworkInfo) {
        self.networks.truncate(k);
        self.networks.push(info);
        self.finished = k + 1;
    }
}

/// A training run: its config and folder, the meshes each network meets and
/// the progress so far.
struct Run<'a> {
    config: &'a TrainConfig,
    out: &'a Path,
    resume: bool,
    progress: &'a dyn Progress,
    model: ModelConfig,
    voxel: VoxelParams,
    /// the bundle `init_from` names, and its manifest
    init: Option<(PathBuf, Manifest)>,
    /// the training meshes at the state the next network meets
    pairs: Vec<Pair>,
    /// the validation meshes likewise
    val_pairs: Vec<Pair>,
    log_path: PathBuf,
    state: RunState,
}

impl<'a> Run<'a> {
    /// The run in `out`: its folders, state (resumed or new), `config.toml`,
    /// the noisy meshes and the log.
    fn open(
        config: &'a TrainConfig,
        out: &'a Path,
        resume: bool,
        progress: &'a dyn Progress,
    ) -> Result<Run<'a>, NetError> {
        std::fs::create_dir_all(out.join("checkpoint")).map_err(|e| NetError::io(out, e))?;
        let states = out.join("states");
        std::fs::create_dir_all(&states).map_err(|e| NetError::io(out, e))?;
        let fresh = !(resume && out.join("state.toml").is_file());
        let state = RunState::read_or_new(out, resume)?;
        let model = ModelConfig::preset(&config.preset)?;
        let init = init_bundle(config)?;
        let pairs = make_pairs(config, &config.sources, config.seed, progress)?;
        let val_pairs = make_pairs(config, &config.validation, config.seed + 777, progress)?;
        write_atomically(
            &out.join("config.toml"),
            toml::to_string_pretty(config)
                .unwrap_or_default()
                .as_bytes(),
        )?;
        let log_path = out.join("train_log.csv");
        if fresh || !log_path.is_file() {
            write_atomically(&log_path, b"network,step,lr,loss,val_deg,seconds\n")?;
        }
        if fresh {
            // a new run: no state of an earlier run is taken back, and a
            // stop from here on resumes (the recipe resumes a stage whose
            // folder has state.toml)
            remove_states(&states)?;
            state.save(out)?;
        }
        Ok(Run {
            config,
            out,
            resume,
            progress,
            model,
            voxel: config.voxel_params(),
            init,
            pairs,
            val_pairs,
            log_path,
            state,
        })
    }

    /// How many networks this run trains (`stop_after`, at most six).
    fn networks_to_train(&self) -> usize {
        INTERVALS.len().min(self.config.stop_after)
    }

    /// `OUT/netK.safetensors` of network `k` (0-based).
    fn network_path(&self, k: usize) -> PathBuf {
        self.out.join(network_file(k))
    }

    fn load(&self, path: &Path) -> Result<NetWeights, NetError> {
        load_network(&self.model, &self.config.preset, path)
    }

    /// A resumed run: the finished networks' files load, and the meshes
    /// are back at the state the first unfinished network meets.
    fn restore_finished(&mut self) -> Result<(), NetError> {
        for k in 0..self.state.finished {
            self.load(&self.network_path(k))?;
        }
        let stage = self.state.finished;
        // (no network left to train: the last one moves no meshes on)
        if stage == 0 || stage >= self.networks_to_train() {
            return Ok(());
        }
        // the latest stage whose states are all saved (0: the noisy inputs),
        // then on through the finished networks after it (a run that ended
        // at `stop_after` did not move the meshes on past its last network)
        let states = self.out.join("states");
        let count = self.pairs.len() + self.val_pairs.len();
        let saved = |s: usize| (0..count).all(|i| state_file(&states, s, i).is_file());
        let from = (1..=stage).rev().find(|&s| saved(s)).unwrap_or(0);
        if from > 0 {
            for (i, p) in self.pairs.iter_mut().chain(&mut self.val_pairs).enumerate() {
                let file = state_file(&states, from, i);
                p.state = saved_state(&file, &p.state)?.ok_or_else(|| NetError::BadConfig {
                    path: file.clone(),
                    message:
                        "a saved mesh state of another mesh: the run cannot resume (start it anew)"
                            .into(),
                })?;
            }
        }
        for k in from..stage {
            let net = self.load(&self.network_path(k))?;
            self.advance_meshes(&net, k)?;
        }
        Ok(())
    }

    /// The networks before `first_network`: the init bundle's own, copied
    /// unchanged, the meshes moved on through them.
    fn take_init_networks(&mut self) -> Result<(), NetError> {
        let Some((dir, manifest)) = self.init.clone() else {
            return Ok(());
        };
        for k in self.state.finished..self.config.first_network - 1 {
            let path = self.network_path(k);
            std::fs::copy(dir.join(network_file(k)), &path)
                .map_err(|e| NetError::io(self.out, e))?;
            let net = self.load(&path)?;
            self.advance_meshes(&net, k)?;
            self.state.finish_network(k, manifest.networks[k].clone());
            self.state.save(self.out)?;
        }
        Ok(())
    }

    /// Trains network `k` (0-based) from where it stands, keeps its best
    /// weights and moves the meshes on to the next network's state.
    /// Returns the size of its sample pool.
    fn train_network(&mut self, k: usize) -> Result<usize, NetError> {
        let started = Instant::now();
        self.progress
            .message(&format!("network {}: building samples", k + 1));
        let residual = self.config.residual(k);
        let sources = Arc::new(sample_sources(&self.pairs, self.voxel, residual)?);
        let sampler = BalancedSampler::new(sources.iter());
        let pool_faces: usize = sampler.category_sizes().iter().sum();
        let val = validation_set(&self.val_pairs, self.voxel, self.config, k, residual)?;
        let mut learner = self.start_learner(k, residual)?;
        let items = sampler.draw_count_seeded(
            self.config.steps[k] * self.config.batch,
            self.config.seed + 10 * k as u64,
        );
        let loader = self.loader(k, sources, items)?;
        if self.state.best_val.is_infinite() {
            self.validate_start(k, &learner, &val)?;
        }
        self.run_steps(k, &mut learner, loader, &val, started)?;
        self.finish_network(k, pool_faces, val.baseline_deg)?;
        Ok(pool_faces)
    }

    /// Network `k`'s learner: from its checkpoint when resuming, else from
    /// [`Self::start_weights`] with a new progress.
    fn start_learner(&mut self, k: usize, residual: bool) -> Result<Learner, NetError> {
        let engine = Engine::parse(&self.config.engine).unwrap_or(Engine::Cnn);
        let loss = self.config.loss_fn().unwrap_or_default();
        let weights = self.start_weights(k, residual)?;
        let quant = self.config.fake_quant();
        let mut learner = Learner::new(engine, &weights, &self.model, loss, quant)?;
        let resumed = self.resume
            && self.state.step > 0
            && learner.restore(&checkpoint_dir(self.out, self.state.step), &self.model)?;
        if !resumed {
            self.state.start_network();
        }
        Ok(learner)
    }

    /// The weights network `k` starts from: the init bundle's, else the
    /// previous network's (warm start), else fresh ones. A residual network
    /// started fresh or warm starts at the identity: its output layer zero
    /// (its own gradient is not zero, so it learns).
    fn start_weights(&self, k: usize, residual: bool) -> Result<NetWeights, NetError> {
        let weights = if let Some((dir, _)) = &self.init {
            self.load(&dir.join(network_file(k)))?
        } else if self.config.warm_start && k > 0 {
            self.load(&self.network_path(k - 1))?
        } else {
            self.model.init_weights(self.config.seed + k as u64)
        };
        Ok(if residual && self.init.is_none() {
            zero_output_layer(weights)
        } else {
            weights
        })
    }

    /// The batches of network `k` from the step reached: the draws `items`
    /// past those already trained on, yaw streams offset likewise.
    fn loader(
        &self,
        k: usize,
        sources: Arc<Vec<SampleSource>>,
        mut items: Vec<SampleRef>,
    ) -> Result<Loader, NetError> {
        let skip = (self.state.step * self.config.batch).min(items.len());
        items.drain(..skip);
        Ok(Loader::new(
            sources,
            items,
            LoaderConfig {
                batch_size: self.config.batch,
                workers: self.config.workers,
                prefetch: 3,
                seed: self.config.seed + 100 * k as u64,
                first_stream: self.state.step as u64,
                yaw_augmentation: true,
                keep_last: false,
            },
        )?)
    }

    /// The starting weights' validation error: the best so far, saved.
    fn validate_start(
        &mut self,
        k: usize,
        learner: &Learner,
        val: &ValidationSet,
    ) -> Result<(), NetError> {
        let error = validation_error(&self.compiled(&learner.network(&self.model)?)?, val);
        self.state.best_val = error;
        learner.save(&self.network_path(k), &self.model)?;
        self.log(k, self.config.lr_at(k, self.state.step), f64::NAN, error)
    }

    /// The training steps of network `k` until its draws run out or its
    /// time is up: validated every `validate_every` steps and at the end
    /// (the best weights saved), logged, checkpointed every
    /// `checkpoint_seconds`.
    fn run_steps(
        &mut self,
        k: usize,
        learner: &mut Learner,
        loader: Loader,
        val: &ValidationSet,
        started: Instant,
    ) -> Result<(), NetError> {
        let steps = self.config.steps[k];
        let limit = self.config.max_seconds[k];
        self.progress
            .start(&format!("network {}", k + 1), steps as u64);
        self.progress.advance(self.state.step as u64);
        let mut last_checkpoint = Instant::now();
        let seconds_before = self.state.seconds;
        let mut batch = SampleBatch::with_capacity(self.voxel.side(), self.config.batch);
        for b in loader {
            let lr = self.config.lr_at(k, self.state.step);
            batch.len = b.len();
            batch.grids = b.grids;
            batch.targets = b.targets;
            let loss = learner.step(&batch, lr)?;
            self.state
                .after_step(loss, seconds_before + started.elapsed().as_secs_f64());
            self.progress.advance(1);
            let time_up = limit > 0.0 && self.state.seconds >= limit;
            let step = self.state.step;
            let error =
                if step.is_multiple_of(self.config.validate_every) || step == steps || time_up {
                    self.validate(k, learner, val)?
                } else {
                    f64::NAN
                };
            self.progress.message(&format!(
                "net {} step {step} loss {loss:.4} val {:.2}° (best {:.2}°, input {:.2}°)",
                k + 1,
                if error.is_nan() {
                    self.state.best_val
                } else {
                    error
                },
                self.state.best_val,
                val.baseline_deg
            ));
            self.log(k, lr, loss, error)?;
            if last_checkpoint.elapsed().as_secs_f64() >= self.config.checkpoint_seconds {
                self.checkpoint(learner)?;
                last_checkpoint = Instant::now();
            }
            if time_up {
                break;
            }
        }
        self.progress.finish();
        Ok(())
    }

    /// The learner's validation error; its weights saved when the best.
    fn validate(
        &mut self,
        k: usize,
        learner: &Learner,
        val: &ValidationSet,
    ) -> Result<f64, NetError> {
        let error = validation_error(&self.compiled(&learner.network(&self.model)?)?, val);
        if error < self.state.best_val {
            self.state.best_val = error;
            learner.save(&self.network_path(k), &self.model)?;
        }
        Ok(error)
    }

    /// The learner's state of step s in `checkpoint/step-s`, then the run
    /// state naming s, then the older folders go: a run killed anywhere in
    /// between resumes from a matching pair.
    fn checkpoint(&self, learner: &mut Learner) -> Result<(), NetError> {
        let dir = checkpoint_dir(self.out, self.state.step);
        std::fs::create_dir_all(&dir).map_err(|e| NetError::io(&dir, e))?;
        learner.checkpoint(&dir)?;
        self.state.save(self.out)?;
        remove_checkpoints(&self.out.join("checkpoint"), Some(&dir));
        Ok(())
    }

    /// Network `k` done: recorded with its best weights, the meshes moved
    /// on through them for the next network.
    fn finish_network(
        &mut self,
        k: usize,
        pool_faces: usize,
        baseline_deg: f64,
    ) -> Result<(), NetError> {
        let best = self.load(&self.network_path(k))?;
        let info = self.network_info(k, pool_faces, baseline_deg);
        if k + 1 < self.networks_to_train() {
            self.advance_meshes(&best, k)?;
        }
        self.state.finish_network(k, info);
        self.state.start_network();
        self.state.save(self.out)?;
        remove_checkpoints(&self.out.join("checkpoint"), None);
        Ok(())
    }

    /// The manifest entry of network `k` as it stands.
    fn network_info(&self, k: usize, pool_faces: usize, baseline_deg: f64) -> NetworkInfo {
        let (prior_samples, prior_seconds) = self.init.as_ref().map_or((0, 0.0), |(_, m)| {
            (m.networks[k].samples_seen, m.networks[k].train_seconds)
        });
        let samples = self.state.step * self.config.batch;
        NetworkInfo {
            file: network_file(k),
            interval: Manifest::default_intervals()[k],
            steps: self.state.step,
            samples_seen: prior_samples + samples,
            pool_faces,
            epochs: samples as f64 / pool_faces.max(1) as f64,
            train_seconds: prior_seconds + self.state.seconds,
            train_loss: mean(&self.state.loss_tail),
            validation_error_deg: self.state.best_val,
            validation_baseline_deg: baseline_deg,
            residual: self.config.residual(k),
        }
    }

    /// `net` compiled for validation ([`TrainConfig::inference_engine`]).
    fn compiled(&self, net: &NetWeights) -> Result<Cnn, NetError> {
        self.config
            .inference_engine(net)
            .map_err(|e| NetError::Record {
                path: PathBuf::from("<model>"),
                message: e.to_string(),
            })
    }

    /// Moves the training and validation meshes from the state network `k`
    /// (0-based) meets to the next network's (`regenerate` for the passes
    /// of network `k`'s interval), saving each in `OUT/states/` as soon as
    /// it is done: a run stopped in between takes the saved ones back and
    /// regenerates only the others (a pass of the CNN over a few million
    /// faces takes hours on two cores).
    fn advance_meshes(&mut self, net: &NetWeights, k: usize) -> Result<(), NetError> {
        let engine = self
            .config
            .inference_engine(net)
            .map_err(|e| NetError::Record {
                path: self.network_path(k),
                message: e.to_string(),
            })?;
        let passes = INTERVALS[k + 1].0 - INTERVALS[k].0;
        self.progress
            .message(&format!("regenerating meshes with network {}", k + 1));
        let states = self.out.join("states");
        // the states saved for stage k + 1 are taken back only if this very
        // network made them (a resumed run may retrain network k, and stop
        // at another step, before it moves the meshes on)
        let marker = states.join(format!("stage{}.network", k + 1));
        let network = self.network_path(k);
        let bytes = std::fs::read(&network).map_err(|e| NetError::io(&network, e))?;
        let made_by = format!("{:016x}", fnv1a(&bytes));
        if std::fs::read_to_string(&marker).ok().as_deref() != Some(made_by.as_str()) {
            remove_states_of(&states, k + 1)?;
            write_atomically(&marker, made_by.as_bytes())?;
        }
        for (i, p) in self.pairs.iter_mut().chain(&mut self.val_pairs).enumerate() {
            let file = state_file(&states, k + 1, i);
            if let Some(saved) = saved_state(&file, &p.state)? {
                p.state = saved;
                continue;
            }
            regenerate(
                std::slice::from_mut(p),
                &engine,
                self.config.residual(k),
                self.voxel,
                passes,
                self.config.inference_batch,
                self.progress,
            )?;
            normalnet_mesh::write_mesh(&file, &p.state)?;
        }
        Ok(())
    }

    /// One line of `train_log.csv` at the current step.
    fn log(&self, k: usize, lr: f64, loss: f64, val_deg: f64) -> Result<(), NetError> {
        append_log(
            &self.log_path,
            k,
            self.state.step,
            lr,
            loss,
            val_deg,
            self.state.seconds,
        )
    }

    /// The bundle's manifest once all six networks are done (else an error
    /// saying how many are), and the loss curve.
    fn finish(self, pool_faces: usize, started: Instant) -> Result<Manifest, NetError> {
        crate::plot::loss_curve_png(&self.log_path, &self.out.join("loss.png"))?;
        if self.state.finished < INTERVALS.len() {
            return Err(NetError::BadConfig {
                path: self.out.join("config.toml"),
                message: format!(
                    "stop_after = {}: trained {} of 6 networks, no bundle written",
                    self.config.stop_after, self.state.finished
                ),
            });
        }
        let mut manifest = new_manifest(&self.config.preset)?;
        manifest.voxel = self.voxel;
        manifest.int8_range = self.config.int8_range;
        manifest.networks = self.state.networks.clone();
        manifest.training = self.training_info(pool_faces, started);
        manifest.write(&self.out.join(MANIFEST))?;
        Ok(manifest)
    }

    /// The manifest's account of the training.
    fn training_info(&self, pool_faces: usize, started: Instant) -> TrainingInfo {
        let config = self.config;
        let all = || self.pairs.iter().chain(&self.val_pairs);
        let continued = self.init.as_ref().map_or(String::new(), |(dir, _)| {
            format!(
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
            )
        });
        TrainingInfo {
            sources: self.pairs.iter().map(|p| p.name.clone()).collect(),
            validation: self.val_pairs.iter().map(|p| p.name.clone()).collect(),
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
                names(all().filter(|p| p.regen)),
                names(all().filter(|p| !p.regen))
            ),
            notes: format!(
                "{continued}steps per network {:?}, wall-clock limits {:?} s, warm start {}, validation = mean angle (deg) of the μ_g 0.35 output vs its target on {} balanced faces (yaw 0); last sample pool {} faces; total run {:.0} s",
                config.steps,
                config.max_seconds,
                config.warm_start,
                config.validation_faces,
                pool_faces,
                started.elapsed().as_secs_f64()
            ),
        }
    }
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

/// The state saved in `file` for a mesh now at `state`, if there is one
/// of the same mesh (the same faces and vertex count; files are written
/// whole, so a stop never leaves half of one).
fn saved_state(file: &Path, state: &Mesh) -> Result<Option<Mesh>, NetError> {
    if !file.is_file() {
        return Ok(None);
    }
    let saved = normalnet_mesh::read_mesh(file)?;
    let same = saved.faces == state.faces && saved.num_vertices() == state.num_vertices();
    Ok(same.then_some(saved))
}

/// Removes the mesh states (`*.obj`) and their markers of an earlier run
/// from `states`.
fn remove_states(states: &Path) -> Result<(), NetError> {
    remove_files(states, |name| {
        name.ends_with(".obj") || name.ends_with(".network")
    })
}

/// Removes the mesh states of stage `stage` (`stageK_I.obj`) from `states`.
fn remove_states_of(states: &Path, stage: usize) -> Result<(), NetError> {
    let prefix = format!("stage{stage}_");
    remove_files(states, |name| {
        name.starts_with(&prefix) && name.ends_with(".obj")
    })
}

/// Removes the files of `folder` whose names `chosen` picks.
fn remove_files(folder: &Path, chosen: impl Fn(&str) -> bool) -> Result<(), NetError> {
    let entries = std::fs::read_dir(folder).map_err(|e| NetError::io(folder, e))?;
    for entry in entries {
        let path = entry.map_err(|e| NetError::io(folder, e))?.path();
        if path
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(&chosen)
        {
            std::fs::remove_file(&path).map_err(|e| NetError::io(&path, e))?;
        }
    }
    Ok(())
}

/// `states/stage{stage}_{i}.obj`: mesh `i`'s state as network `stage`
/// (1-based) leaves it.
fn state_file(states: &Path, stage: usize, i: usize) -> PathBuf {
    states.join(format!("stage{stage}_{i}.obj"))
}
