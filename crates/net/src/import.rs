//! The reverse of [`crate::export`]: weights trained on the CPU engine
//! (`normalnet_cnn::Trainer`) into a burn [`NormalNet`], so bundles keep
//! their format. Tensors are matched by module path and shape.

use burn::module::{Module, ModuleMapper, Param};
use burn::tensor::{Device, Tensor, TensorData};
use normalnet_cnn::{BatchNormWeights, ConvWeights, LinearWeights, NetWeights};
use std::collections::HashMap;

use crate::export::ExportError;
use crate::model::{ModelConfig, NormalNet};
use crate::weights_file::{Layer, visit_layers};

/// Sets every float tensor from a table keyed by module path.
struct Setter {
    path: Vec<String>,
    tensors: HashMap<String, Vec<f32>>,
    device: Device,
    failed: Option<String>,
}

impl ModuleMapper for Setter {
    fn enter_module(&mut self, name: &str, _container: &str) {
        self.path.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container: &str) {
        self.path.pop();
    }

    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let path = self.path.join(".");
        let (id, tensor, _) = param.consume();
        let dims: [usize; D] = tensor.dims();
        match self.tensors.remove(&path) {
            Some(values) if values.len() == dims.iter().product::<usize>() => {
                let t = Tensor::from_data(TensorData::new(values, dims), &self.device);
                Param::initialized(
                    id,
                    if tensor.is_require_grad() {
                        t.require_grad()
                    } else {
                        t
                    },
                )
            }
            Some(values) => {
                self.failed = Some(format!(
                    "{path}: {} values for shape {dims:?}",
                    values.len()
                ));
                Param::initialized(id, tensor)
            }
            None => {
                self.failed = Some(format!("{path}: no values"));
                Param::initialized(id, tensor)
            }
        }
    }
}

fn put_conv(t: &mut HashMap<String, Vec<f32>>, prefix: &str, c: &ConvWeights) {
    t.insert(format!("{prefix}.weight"), c.weight.clone());
}

fn put_bn(t: &mut HashMap<String, Vec<f32>>, prefix: &str, b: &BatchNormWeights) {
    t.insert(format!("{prefix}.gamma"), b.gamma.clone());
    t.insert(format!("{prefix}.beta"), b.beta.clone());
    t.insert(format!("{prefix}.running_mean"), b.mean.clone());
    t.insert(format!("{prefix}.running_var"), b.var.clone());
}

fn put_linear(t: &mut HashMap<String, Vec<f32>>, prefix: &str, l: &LinearWeights) {
    t.insert(format!("{prefix}.weight"), l.weight.clone());
    t.insert(
        format!("{prefix}.bias"),
        l.bias.clone().unwrap_or_else(|| vec![0.0; l.out_features]),
    );
}

/// The arrays of `w` keyed by their burn module path (`conv_in.weight`,
/// `blocks.0.bn_a.running_var`, `fc.2.bias`, ...), in burn's layouts.
pub fn tensors_by_path(w: &NetWeights) -> HashMap<String, Vec<f32>> {
    let mut t = HashMap::new();
    visit_layers(w, ["conv_in", "bn_in"], |name, layer| match layer {
        Layer::Conv(c) => put_conv(&mut t, name, c),
        Layer::BatchNorm(bn) => put_bn(&mut t, name, bn),
        Layer::Linear(l) => put_linear(&mut t, name, l),
    });
    t
}

/// A burn network of architecture `config` holding the weights `w`.
///
/// # Errors
/// [`ExportError`] when `w` does not have the shapes of `config` (or holds
/// convolution biases, which [`NormalNet`] does not have).
pub fn normal_net(
    config: &ModelConfig,
    w: &NetWeights,
    device: &Device,
) -> Result<NormalNet, ExportError> {
    let has_bias = w.stem.bias.is_some()
        || w.blocks.iter().any(|b| {
            b.conv_a.bias.is_some() || b.conv_b.bias.is_some() || b.shortcut.bias.is_some()
        });
    if has_bias {
        return Err(ExportError(
            "convolution biases have no place in NormalNet".into(),
        ));
    }
    let t = tensors_by_path(w);
    let mut setter = Setter {
        path: Vec::new(),
        tensors: t,
        device: device.clone(),
        failed: None,
    };
    let net = config.init(device, 0).map(&mut setter);
    if let Some(e) = setter.failed {
        return Err(ExportError(e));
    }
    if let Some(extra) = setter.tensors.keys().next() {
        return Err(ExportError(format!("{extra}: not a tensor of the network")));
    }
    Ok(net)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::net_weights;

    #[test]
    fn import_then_export_is_the_identity() {
        let device = Device::flex();
        let config = ModelConfig::tiny();
        let mut w = net_weights(&config.init(&device, 3), &config).unwrap();
        w.stem_bn.mean[0] = 0.25;
        w.blocks[1].bn_b.var[2] = 1.5;
        let net = normal_net(&config, &w, &device).unwrap();
        assert!(net_weights(&net, &config).unwrap() == w);
        let mut bad = w.clone();
        bad.output.weight.pop();
        assert!(normal_net(&config, &bad, &device).is_err());
    }
}
