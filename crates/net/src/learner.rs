//! The network being trained, on one of two engines: the CPU engine of
//! `normalnet-cnn` (`Trainer`: sparse first layer, hand-written backward
//! pass; the default) or burn's autodiff (the reference it was checked
//! against; only in a build with the `burn` feature). Both start from and
//! save plain [`NetWeights`], so bundles do not depend on the engine.

use std::path::Path;

#[cfg(feature = "burn")]
use burn::{module::Module, optim::ModuleOptimizer, tensor::Device};
use normalnet_cnn::{Int8Range, Loss, NetWeights, Trainer};

use crate::NetError;
use crate::arch::ModelConfig;
use crate::data::SampleBatch;
#[cfg(feature = "burn")]
use crate::model::NormalNet;
#[cfg(feature = "burn")]
use crate::step::{adam, train_step};

/// Which engine trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// `normalnet_cnn::Trainer` (CPU, f32)
    Cnn,
    /// burn autodiff on the Flex backend (MSE only; a build with the `burn`
    /// feature)
    Burn,
}

impl Engine {
    /// `cnn` or `burn`.
    pub fn parse(name: &str) -> Option<Engine> {
        match name {
            "cnn" => Some(Engine::Cnn),
            "burn" => Some(Engine::Burn),
            _ => None,
        }
    }

    /// Whether this build can train with the engine.
    pub fn available(self) -> bool {
        match self {
            Engine::Cnn => true,
            Engine::Burn => cfg!(feature = "burn"),
        }
    }
}

/// A network being trained and its optimiser state (one learner per
/// network, so the variants' size difference does not matter).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Learner {
    Cnn {
        trainer: Box<Trainer>,
        loss: Loss,
    },
    #[cfg(feature = "burn")]
    Burn {
        model: Option<NormalNet>,
        optim: ModuleOptimizer,
        device: Device,
    },
}

fn record(path: &Path, e: impl ToString) -> NetError {
    NetError::Record {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

impl Learner {
    /// Starts from the weights `w` of a `config` network; with `quant`,
    /// trains on those int8 steps ([`Trainer::set_fake_quant`]; the cnn
    /// engine only, as the training config checks).
    pub(crate) fn new(
        engine: Engine,
        w: &NetWeights,
        config: &ModelConfig,
        loss: Loss,
        quant: Option<Int8Range>,
    ) -> Result<Learner, NetError> {
        let _ = config;
        Ok(match engine {
            Engine::Cnn => {
                let mut trainer =
                    Box::new(Trainer::new(w).map_err(|e| record(Path::new("<model>"), e))?);
                trainer.set_fake_quant(quant);
                Learner::Cnn { trainer, loss }
            }
            #[cfg(feature = "burn")]
            Engine::Burn => {
                let net = crate::import::normal_net(config, w, &Device::flex())
                    .map_err(|e| record(Path::new("<model>"), e))?;
                let device = Device::flex().autodiff();
                Learner::Burn {
                    model: Some(net.fork(&device).train()),
                    optim: adam(),
                    device,
                }
            }
            #[cfg(not(feature = "burn"))]
            Engine::Burn => {
                return Err(NetError::InvalidParameter {
                    name: "engine",
                    message: "this build has no burn engine (build with --features burn)".into(),
                });
            }
        })
    }

    /// One optimisation step; the batch loss before it.
    pub(crate) fn step(&mut self, batch: &SampleBatch, lr: f64) -> Result<f64, NetError> {
        match self {
            Learner::Cnn { trainer, loss, .. } => trainer
                .train_step(&batch.grids, &batch.targets, *loss, lr)
                .map_err(|e| record(Path::new("<batch>"), e)),
            #[cfg(feature = "burn")]
            Learner::Burn {
                model,
                optim,
                device,
            } => {
                let m = model.take().expect("model present between steps");
                let (m, l) = train_step(m, optim, batch, lr, device);
                *model = Some(m);
                Ok(l)
            }
        }
    }

    /// The current network's weights (running statistics for batch norm).
    pub(crate) fn network(&self, config: &ModelConfig) -> Result<NetWeights, NetError> {
        let _ = config;
        match self {
            Learner::Cnn { trainer, .. } => Ok(trainer.weights()),
            #[cfg(feature = "burn")]
            Learner::Burn { model, .. } => {
                crate::export::net_weights(&model.as_ref().expect("model").valid(), config)
                    .map_err(|e| record(Path::new("<model>"), e))
            }
        }
    }

    /// Saves the network as a bundle file.
    pub(crate) fn save(&self, file: &Path, config: &ModelConfig) -> Result<(), NetError> {
        crate::weights_file::save(&self.network(config)?, file)
    }

    /// Writes a resumable checkpoint into `dir`.
    pub(crate) fn checkpoint(&mut self, dir: &Path) -> Result<(), NetError> {
        match self {
            Learner::Cnn { trainer, .. } => {
                crate::bundle::write_atomically(&dir.join("trainer.state"), &trainer.state_bytes())
            }
            #[cfg(feature = "burn")]
            Learner::Burn { model, optim, .. } => {
                let tmp = dir.join("model.tmp.bpk");
                model
                    .as_ref()
                    .expect("model")
                    .clone()
                    .save_file(&tmp)
                    .map_err(|e| record(&tmp, e))?;
                std::fs::rename(&tmp, dir.join("model.bpk")).map_err(|e| NetError::io(dir, e))?;
                let tmp = dir.join("optim.tmp.bpk");
                optim.save(&tmp).map_err(|e| record(&tmp, e))?;
                std::fs::rename(&tmp, dir.join("optim.bpk")).map_err(|e| NetError::io(dir, e))
            }
        }
    }

    /// Restores a checkpoint of `dir`; false when there is none.
    pub(crate) fn restore(&mut self, dir: &Path, config: &ModelConfig) -> Result<bool, NetError> {
        let _ = config;
        match self {
            Learner::Cnn { trainer, .. } => {
                let file = dir.join("trainer.state");
                if !file.is_file() {
                    return Ok(false);
                }
                let bytes = std::fs::read(&file).map_err(|e| NetError::io(&file, e))?;
                trainer
                    .load_state_bytes(&bytes)
                    .map_err(|e| record(&file, e))?;
                Ok(true)
            }
            #[cfg(feature = "burn")]
            Learner::Burn {
                model,
                optim,
                device,
            } => {
                let file = dir.join("model.bpk");
                if !file.is_file() {
                    return Ok(false);
                }
                let m = config
                    .init(device, 0)
                    .try_load_file(&file)
                    .map_err(|e| record(&file, e))?;
                *model = Some(m);
                let file = dir.join("optim.bpk");
                if file.is_file() {
                    let o = std::mem::replace(optim, adam());
                    *optim = o.load(&file).map_err(|e| record(&file, e))?;
                }
                Ok(true)
            }
        }
    }

    /// Removes the checkpoint files of `dir`.
    pub(crate) fn clear_checkpoint(dir: &Path) {
        for f in ["trainer.state", "model.bpk", "optim.bpk"] {
            let _ = std::fs::remove_file(dir.join(f));
        }
    }
}
