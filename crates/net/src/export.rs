//! Export a trained network to the burn-free CPU engine of `normalnet-cnn`:
//! every float tensor is read by its module path (`blocks.1.conv_a.weight`,
//! `bn_in.running_var`, ...) and laid out as [`NetWeights`].

use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::Tensor;
use normalnet_cnn::{BatchNormWeights, BlockWeights, Cnn, ConvWeights, LinearWeights, NetWeights};
use std::collections::HashMap;

use crate::model::{ModelConfig, NormalNet};

/// A network that cannot be exported (a tensor missing or misshapen).
#[derive(Debug, thiserror::Error)]
#[error("exporting the network to the CPU engine: {0}")]
pub struct ExportError(pub String);

use crate::arch::BN_EPSILON;

/// Collects float tensors by their dotted module path.
#[derive(Default)]
struct Collector {
    path: Vec<String>,
    tensors: HashMap<String, (Vec<usize>, Vec<f32>)>,
    failed: Option<String>,
}

impl ModuleVisitor for Collector {
    fn enter_module(&mut self, name: &str, _container: &str) {
        self.path.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container: &str) {
        self.path.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let tensor = param.val();
        let dims = tensor.dims().to_vec();
        match tensor.into_data().convert::<f32>().try_to_vec::<f32>() {
            Ok(values) => {
                self.tensors.insert(self.path.join("."), (dims, values));
            }
            Err(e) => self.failed = Some(format!("{}: {e:?}", self.path.join("."))),
        }
    }
}

impl Collector {
    fn take(&mut self, path: &str, dims: &[usize]) -> Result<Vec<f32>, ExportError> {
        let (found, values) = self
            .tensors
            .remove(path)
            .ok_or_else(|| ExportError(format!("tensor {path} missing")))?;
        if found != dims {
            return Err(ExportError(format!(
                "tensor {path} has shape {found:?}, expected {dims:?}"
            )));
        }
        Ok(values)
    }

    fn batch_norm(&mut self, prefix: &str, c: usize) -> Result<BatchNormWeights, ExportError> {
        Ok(BatchNormWeights {
            gamma: self.take(&format!("{prefix}.gamma"), &[c])?,
            beta: self.take(&format!("{prefix}.beta"), &[c])?,
            mean: self.take(&format!("{prefix}.running_mean"), &[c])?,
            var: self.take(&format!("{prefix}.running_var"), &[c])?,
            epsilon: BN_EPSILON,
        })
    }

    fn conv(
        &mut self,
        prefix: &str,
        cin: usize,
        cout: usize,
        k: usize,
        stride: usize,
        padding: usize,
    ) -> Result<ConvWeights, ExportError> {
        Ok(ConvWeights {
            weight: self.take(&format!("{prefix}.weight"), &[cout, cin, k, k, k])?,
            bias: None,
            in_channels: cin,
            out_channels: cout,
            kernel: k,
            stride,
            padding,
        })
    }

    fn linear(&mut self, prefix: &str, i: usize, o: usize) -> Result<LinearWeights, ExportError> {
        Ok(LinearWeights {
            weight: self.take(&format!("{prefix}.weight"), &[i, o])?,
            bias: Some(self.take(&format!("{prefix}.bias"), &[o])?),
            in_features: i,
            out_features: o,
        })
    }
}

/// The weights of `net` (built with `config`) as plain arrays.
///
/// # Errors
/// [`ExportError`] when a tensor is missing or has an unexpected shape.
pub fn net_weights(net: &NormalNet, config: &ModelConfig) -> Result<NetWeights, ExportError> {
    let mut c = Collector::default();
    net.visit(&mut c);
    if let Some(e) = c.failed.take() {
        return Err(ExportError(e));
    }
    let ch = config.channels;
    let stem = c.conv("conv_in", 3, ch[0], 5, 1, 2)?;
    let stem_bn = c.batch_norm("bn_in", ch[0])?;
    let mut blocks = Vec::new();
    let mut cin = ch[0];
    for (i, &cout) in ch.iter().enumerate() {
        let p = format!("blocks.{i}");
        blocks.push(BlockWeights {
            conv_a: c.conv(&format!("{p}.conv_a"), cin, cout, 3, 2, 1)?,
            bn_a: c.batch_norm(&format!("{p}.bn_a"), cout)?,
            conv_b: c.conv(&format!("{p}.conv_b"), cout, cout, 3, 1, 1)?,
            bn_b: c.batch_norm(&format!("{p}.bn_b"), cout)?,
            shortcut: c.conv(&format!("{p}.shortcut"), cin, cout, 1, 2, 0)?,
            bn_shortcut: c.batch_norm(&format!("{p}.bn_shortcut"), cout)?,
        });
        cin = cout;
    }
    let mut hidden = Vec::new();
    for (i, &h) in config.hidden.iter().enumerate() {
        hidden.push((
            c.linear(&format!("fc.{i}"), cin, h)?,
            c.batch_norm(&format!("bn_fc.{i}"), h)?,
        ));
        cin = h;
    }
    let output = c.linear("out", cin, config.outputs)?;
    if let Some(extra) = c.tensors.keys().next() {
        return Err(ExportError(format!("unexpected tensor {extra}")));
    }
    Ok(NetWeights {
        grid: config.grid,
        stem,
        stem_bn,
        blocks,
        hidden,
        output,
    })
}

/// The architecture numbers of `net`, read from its tensor shapes, for
/// grids of side `grid`.
///
/// # Errors
/// [`ExportError`] when the network lacks a tensor of the SPEC §6 layout.
pub fn config_of(net: &NormalNet, grid: usize) -> Result<ModelConfig, ExportError> {
    let mut c = Collector::default();
    net.visit(&mut c);
    let first = |c: &Collector, path: &str| {
        c.tensors
            .get(path)
            .map(|(dims, _)| dims[0])
            .ok_or_else(|| ExportError(format!("tensor {path} missing")))
    };
    Ok(ModelConfig {
        grid,
        channels: [
            first(&c, "blocks.0.conv_a.weight")?,
            first(&c, "blocks.1.conv_a.weight")?,
            first(&c, "blocks.2.conv_a.weight")?,
        ],
        hidden: [
            first(&c, "fc.0.bias")?,
            first(&c, "fc.1.bias")?,
            first(&c, "fc.2.bias")?,
        ],
        outputs: first(&c, "out.bias")?,
    })
}

/// `net` compiled for the fast CPU engine, for grids of side `grid`.
///
/// # Errors
/// As [`net_weights`].
pub fn compile_for_grid(net: &NormalNet, grid: usize) -> Result<Cnn, ExportError> {
    compile(net, &config_of(net, grid)?)
}

/// `net` compiled for the fast CPU engine.
///
/// # Errors
/// As [`net_weights`], and shapes the engine does not support.
pub fn compile(net: &NormalNet, config: &ModelConfig) -> Result<Cnn, ExportError> {
    Cnn::new(&net_weights(net, config)?).map_err(|e| ExportError(e.to_string()))
}
