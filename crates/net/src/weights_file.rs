//! One network's weights in a `safetensors` file (bundle format 2): the
//! de-facto standard container, readable from numpy (`safetensors.numpy`)
//! and PyTorch without this program.
//!
//! Names and layouts follow PyTorch's modules (little-endian f32):
//!
//! | tensor | shape |
//! |---|---|
//! | `stem.conv.weight` | `[c0, 3, 5, 5, 5]` |
//! | `stem.bn.{weight,bias,running_mean,running_var}` | `[c0]` |
//! | `blocks.{i}.{conv_a,conv_b,shortcut}.weight` | `[c, c_in, k, k, k]` |
//! | `blocks.{i}.{bn_a,bn_b,bn_shortcut}.*` | `[c]` |
//! | `fc.{i}.weight`, `fc.{i}.bias` | `[out, in]`, `[out]` |
//! | `bn_fc.{i}.*` | `[out]` |
//! | `out.weight`, `out.bias` | `[18, in]`, `[18]` |
//!
//! Batch norm ε is [`crate::arch::BN_EPSILON`]; convolutions have no bias.
//! The architecture comes from the bundle's manifest ([`ModelConfig`]): a
//! file is read against it, and every missing, extra or misshapen tensor is
//! an error naming the tensor.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use normalnet_cnn::{BatchNormWeights, ConvWeights, LinearWeights, NetWeights};
use safetensors::tensor::{Dtype, SafeTensors, TensorView};

use crate::NetError;
use crate::arch::ModelConfig;

/// Value of the `format` metadata entry of a weight file.
pub const WEIGHTS_FORMAT: &str = "normalnet-weights-2";

/// Flat arrays and PyTorch shapes of every tensor of `w`, by name.
pub fn tensors_by_name(w: &NetWeights) -> BTreeMap<String, (Vec<usize>, Vec<f32>)> {
    let mut t = BTreeMap::new();
    visit_layers(w, ["stem.conv", "stem.bn"], |name, layer| match layer {
        Layer::Conv(c) => put_conv(&mut t, name, c),
        Layer::BatchNorm(bn) => put_bn(&mut t, name, bn),
        Layer::Linear(l) => put_linear(&mut t, name, l),
    });
    t
}

/// One layer's weights, as [`visit_layers`] gives them.
pub(crate) enum Layer<'a> {
    /// a convolution
    Conv(&'a ConvWeights),
    /// a batch normalization
    BatchNorm(&'a BatchNormWeights),
    /// a dense layer
    Linear(&'a LinearWeights),
}

/// Every layer of `w` in order with its module path: the stem's convolution
/// and batch norm named `stem`, then `blocks.{i}.{conv_a, bn_a, conv_b, bn_b,
/// shortcut, bn_shortcut}`, the head's `fc.{i}` and `bn_fc.{i}`, and `out`.
pub(crate) fn visit_layers(w: &NetWeights, stem: [&str; 2], mut visit: impl FnMut(&str, Layer)) {
    visit(stem[0], Layer::Conv(&w.stem));
    visit(stem[1], Layer::BatchNorm(&w.stem_bn));
    for (i, b) in w.blocks.iter().enumerate() {
        let p = format!("blocks.{i}");
        visit(&format!("{p}.conv_a"), Layer::Conv(&b.conv_a));
        visit(&format!("{p}.bn_a"), Layer::BatchNorm(&b.bn_a));
        visit(&format!("{p}.conv_b"), Layer::Conv(&b.conv_b));
        visit(&format!("{p}.bn_b"), Layer::BatchNorm(&b.bn_b));
        visit(&format!("{p}.shortcut"), Layer::Conv(&b.shortcut));
        visit(
            &format!("{p}.bn_shortcut"),
            Layer::BatchNorm(&b.bn_shortcut),
        );
    }
    for (i, (l, bn)) in w.hidden.iter().enumerate() {
        visit(&format!("fc.{i}"), Layer::Linear(l));
        visit(&format!("bn_fc.{i}"), Layer::BatchNorm(bn));
    }
    visit("out", Layer::Linear(&w.output));
}

type Table = BTreeMap<String, (Vec<usize>, Vec<f32>)>;

fn put_conv(t: &mut Table, prefix: &str, c: &ConvWeights) {
    let k = c.kernel;
    let shape = vec![c.out_channels, c.in_channels, k, k, k];
    t.insert(format!("{prefix}.weight"), (shape, c.weight.clone()));
}

fn put_bn(t: &mut Table, prefix: &str, b: &BatchNormWeights) {
    let n = vec![b.gamma.len()];
    t.insert(format!("{prefix}.weight"), (n.clone(), b.gamma.clone()));
    t.insert(format!("{prefix}.bias"), (n.clone(), b.beta.clone()));
    t.insert(
        format!("{prefix}.running_mean"),
        (n.clone(), b.mean.clone()),
    );
    t.insert(format!("{prefix}.running_var"), (n, b.var.clone()));
}

fn put_linear(t: &mut Table, prefix: &str, l: &LinearWeights) {
    // ours is [in, out] row-major; PyTorch's [out, in]
    let (i_n, o_n) = (l.in_features, l.out_features);
    let mut transposed = vec![0.0f32; i_n * o_n];
    for i in 0..i_n {
        for o in 0..o_n {
            transposed[o * i_n + i] = l.weight[i * o_n + o];
        }
    }
    t.insert(format!("{prefix}.weight"), (vec![o_n, i_n], transposed));
    let bias = l.bias.clone().unwrap_or_else(|| vec![0.0; o_n]);
    t.insert(format!("{prefix}.bias"), (vec![o_n], bias));
}

/// The file bytes of `w`.
pub fn to_bytes(w: &NetWeights) -> Result<Vec<u8>, String> {
    let table = tensors_by_name(w);
    let bytes: Vec<(String, Vec<usize>, Vec<u8>)> = table
        .into_iter()
        .map(|(name, (shape, values))| {
            let b = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            (name, shape, b)
        })
        .collect();
    let mut views = Vec::with_capacity(bytes.len());
    for (name, shape, b) in &bytes {
        let view = TensorView::new(Dtype::F32, shape.clone(), b).map_err(|e| e.to_string())?;
        views.push((name.clone(), view));
    }
    let meta = HashMap::from([("format".to_string(), WEIGHTS_FORMAT.to_string())]);
    safetensors::serialize(views, Some(meta)).map_err(|e| e.to_string())
}

/// Reads the weights of a `config` network from file bytes; `label` names
/// the file in errors.
pub fn from_bytes(config: &ModelConfig, bytes: &[u8]) -> Result<NetWeights, String> {
    let file =
        SafeTensors::deserialize(bytes).map_err(|e| format!("not a safetensors file: {e}"))?;
    // the expected tensors: those of a network of this architecture
    let mut w = config.zero_weights();
    let expected = tensors_by_name(&w);
    let mut read: Table = BTreeMap::new();
    for (name, (shape, _)) in &expected {
        let view = file
            .tensor(name)
            .map_err(|_| format!("tensor {name} is missing"))?;
        if view.dtype() != Dtype::F32 {
            return Err(format!("tensor {name} is {:?}, expected F32", view.dtype()));
        }
        if view.shape() != shape.as_slice() {
            return Err(format!(
                "tensor {name} has shape {:?}, the {}-grid network needs {shape:?}",
                view.shape(),
                config.grid
            ));
        }
        let values: Vec<f32> = view
            .data()
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "tensor {name} holds a non-finite value at index {i}"
            ));
        }
        read.insert(name.clone(), (shape.clone(), values));
    }
    if let Some(extra) = file
        .names()
        .into_iter()
        .find(|n| !expected.contains_key(*n))
    {
        return Err(format!("unexpected tensor {extra}"));
    }
    let mut take = |name: String| read.remove(&name).expect("checked above").1;
    fn fill_conv(take: &mut dyn FnMut(String) -> Vec<f32>, p: &str, c: &mut ConvWeights) {
        c.weight = take(format!("{p}.weight"));
    }
    fn fill_bn(take: &mut dyn FnMut(String) -> Vec<f32>, p: &str, b: &mut BatchNormWeights) {
        b.gamma = take(format!("{p}.weight"));
        b.beta = take(format!("{p}.bias"));
        b.mean = take(format!("{p}.running_mean"));
        b.var = take(format!("{p}.running_var"));
    }
    fn fill_linear(take: &mut dyn FnMut(String) -> Vec<f32>, p: &str, l: &mut LinearWeights) {
        let t = take(format!("{p}.weight")); // [out, in]
        let (i_n, o_n) = (l.in_features, l.out_features);
        for i in 0..i_n {
            for o in 0..o_n {
                l.weight[i * o_n + o] = t[o * i_n + i];
            }
        }
        l.bias = Some(take(format!("{p}.bias")));
    }
    fill_conv(&mut take, "stem.conv", &mut w.stem);
    fill_bn(&mut take, "stem.bn", &mut w.stem_bn);
    for (i, b) in w.blocks.iter_mut().enumerate() {
        let p = format!("blocks.{i}");
        fill_conv(&mut take, &format!("{p}.conv_a"), &mut b.conv_a);
        fill_bn(&mut take, &format!("{p}.bn_a"), &mut b.bn_a);
        fill_conv(&mut take, &format!("{p}.conv_b"), &mut b.conv_b);
        fill_bn(&mut take, &format!("{p}.bn_b"), &mut b.bn_b);
        fill_conv(&mut take, &format!("{p}.shortcut"), &mut b.shortcut);
        fill_bn(&mut take, &format!("{p}.bn_shortcut"), &mut b.bn_shortcut);
    }
    for (i, (l, bn)) in w.hidden.iter_mut().enumerate() {
        fill_linear(&mut take, &format!("fc.{i}"), l);
        fill_bn(&mut take, &format!("bn_fc.{i}"), bn);
    }
    fill_linear(&mut take, "out", &mut w.output);
    Ok(w)
}

/// Writes `w` to `file` atomically.
pub fn save(w: &NetWeights, file: &Path) -> Result<(), NetError> {
    let bytes = to_bytes(w).map_err(|message| NetError::Record {
        path: file.to_path_buf(),
        message,
    })?;
    crate::bundle::write_atomically(file, &bytes)
}

/// Reads the weights of a `config` network (preset `preset`, for messages)
/// from `file`.
pub fn load(config: &ModelConfig, preset: &str, file: &Path) -> Result<NetWeights, NetError> {
    let bytes = std::fs::read(file).map_err(|e| NetError::io(file, e))?;
    from_bytes(config, &bytes).map_err(|message| NetError::WeightMismatch {
        path: file.to_path_buf(),
        preset: preset.to_string(),
        message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trained_looking(config: &ModelConfig) -> NetWeights {
        let mut w = config.init_weights(3);
        // distinct values everywhere, so a transposition or swap shows
        w.stem_bn
            .mean
            .iter_mut()
            .enumerate()
            .for_each(|(i, m)| *m = i as f32 * 0.1);
        w.output.bias = Some((0..w.output.out_features).map(|i| i as f32).collect());
        w.hidden[1]
            .1
            .var
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = 1.0 + i as f32);
        w
    }

    #[test]
    fn round_trip_is_exact() {
        let config = ModelConfig::tiny();
        let w = trained_looking(&config);
        let bytes = to_bytes(&w).unwrap();
        assert_eq!(from_bytes(&config, &bytes).unwrap(), w);
    }

    #[test]
    fn pytorch_layout_of_linear_weights() {
        let config = ModelConfig::tiny();
        let w = trained_looking(&config);
        let t = tensors_by_name(&w);
        let (shape, values) = &t["out.weight"];
        assert_eq!(shape, &vec![18, 128]);
        // element [o = 2, i = 5] is ours [i = 5, o = 2]
        assert_eq!(values[2 * 128 + 5], w.output.weight[5 * 18 + 2]);
        assert_eq!(t.len(), 1 + 4 + 3 * (3 + 12) + 3 * 6 + 2);
    }

    #[test]
    fn wrong_architecture_and_broken_files_are_named() {
        let w = trained_looking(&ModelConfig::tiny());
        let bytes = to_bytes(&w).unwrap();
        let e = from_bytes(&ModelConfig::lite(), &bytes).unwrap_err();
        assert!(e.contains("stem.conv.weight") || e.contains("shape"), "{e}");
        let e = from_bytes(&ModelConfig::tiny(), &bytes[..bytes.len() / 2]).unwrap_err();
        assert!(e.contains("safetensors"), "{e}");
        let e = from_bytes(&ModelConfig::tiny(), b"not at all").unwrap_err();
        assert!(e.contains("safetensors"), "{e}");
        // a NaN weight is refused
        let mut bad = w.clone();
        bad.blocks[0].conv_b.weight[7] = f32::NAN;
        let e = from_bytes(&ModelConfig::tiny(), &to_bytes(&bad).unwrap()).unwrap_err();
        assert!(
            e.contains("blocks.0.conv_b.weight") && e.contains("non-finite"),
            "{e}"
        );
    }
}
