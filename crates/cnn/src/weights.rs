//! Plain weight arrays of a trained network, in burn's layouts: what
//! `normalnet-net` exports and [`crate::Cnn::new`] compiles.

use crate::error::CnnError;

/// A 3D convolution with a cubic kernel.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvWeights {
    /// `[out_channels, in_channels, k, k, k]`, row-major (burn / PyTorch layout)
    pub weight: Vec<f32>,
    /// `[out_channels]`, or none
    pub bias: Option<Vec<f32>>,
    /// input channels
    pub in_channels: usize,
    /// output channels
    pub out_channels: usize,
    /// kernel side k
    pub kernel: usize,
    /// stride (same on all axes)
    pub stride: usize,
    /// zero padding (same on all sides)
    pub padding: usize,
}

/// Batch norm in inference mode: `γ (x − mean) / sqrt(var + ε) + β`.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchNormWeights {
    /// γ, one per channel
    pub gamma: Vec<f32>,
    /// β, one per channel
    pub beta: Vec<f32>,
    /// running mean, one per channel
    pub mean: Vec<f32>,
    /// running variance, one per channel
    pub var: Vec<f32>,
    /// ε
    pub epsilon: f64,
}

/// A fully connected layer.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearWeights {
    /// `[in_features, out_features]`, row-major (burn layout)
    pub weight: Vec<f32>,
    /// `[out_features]`, or none
    pub bias: Option<Vec<f32>>,
    /// inputs
    pub in_features: usize,
    /// outputs
    pub out_features: usize,
}

/// A residual block: `relu(bn_b(conv_b(relu(bn_a(conv_a(x))))) + bn_s(shortcut(x)))`.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockWeights {
    /// 3³ stride-2 convolution
    pub conv_a: ConvWeights,
    /// its batch norm
    pub bn_a: BatchNormWeights,
    /// 3³ stride-1 convolution
    pub conv_b: ConvWeights,
    /// its batch norm
    pub bn_b: BatchNormWeights,
    /// 1³ stride-2 projection
    pub shortcut: ConvWeights,
    /// its batch norm
    pub bn_shortcut: BatchNormWeights,
}

/// A whole network (SPEC §6): stem convolution + BN + ReLU, residual blocks,
/// global max pool, hidden linear layers (each BN + ReLU), output layer + tanh.
#[derive(Clone, Debug, PartialEq)]
pub struct NetWeights {
    /// grid side D = H = W of the `[3, D, H, W]` input
    pub grid: usize,
    /// the first convolution (3 input channels)
    pub stem: ConvWeights,
    /// its batch norm
    pub stem_bn: BatchNormWeights,
    /// the residual blocks, in order
    pub blocks: Vec<BlockWeights>,
    /// hidden layers, each followed by batch norm and ReLU
    pub hidden: Vec<(LinearWeights, BatchNormWeights)>,
    /// the output layer, followed by tanh
    pub output: LinearWeights,
}

fn check_len(
    layer: &str,
    what: &'static str,
    actual: usize,
    expected: usize,
) -> Result<(), CnnError> {
    if actual == expected {
        Ok(())
    } else {
        Err(CnnError::WeightShape {
            layer: layer.to_string(),
            what,
            actual,
            expected,
        })
    }
}

impl ConvWeights {
    pub(crate) fn check(&self, layer: &str) -> Result<(), CnnError> {
        let k3 = self.kernel * self.kernel * self.kernel;
        check_len(
            layer,
            "weight",
            self.weight.len(),
            self.out_channels * self.in_channels * k3,
        )?;
        if let Some(b) = &self.bias {
            check_len(layer, "bias", b.len(), self.out_channels)?;
        }
        if self.kernel == 0 || self.stride == 0 || self.out_channels == 0 || self.in_channels == 0 {
            return Err(CnnError::Mismatch {
                layer: layer.to_string(),
                message: "kernel, stride and channel counts must be positive".into(),
            });
        }
        Ok(())
    }

    /// Output side for an input of side `n`.
    pub fn output_side(&self, n: usize) -> usize {
        (n + 2 * self.padding).saturating_sub(self.kernel) / self.stride + 1
    }
}

impl BatchNormWeights {
    /// A batch norm that changes nothing (γ 1, β 0, mean 0, variance 1, ε 0).
    #[cfg(test)]
    pub(crate) fn identity(channels: usize) -> BatchNormWeights {
        BatchNormWeights {
            gamma: vec![1.0; channels],
            beta: vec![0.0; channels],
            mean: vec![0.0; channels],
            var: vec![1.0; channels],
            epsilon: 0.0,
        }
    }

    pub(crate) fn check(&self, layer: &str, channels: usize) -> Result<(), CnnError> {
        check_len(layer, "gamma", self.gamma.len(), channels)?;
        check_len(layer, "beta", self.beta.len(), channels)?;
        check_len(layer, "running mean", self.mean.len(), channels)?;
        check_len(layer, "running var", self.var.len(), channels)
    }

    /// Per-channel `(scale, shift)` with `bn(x) = scale·x + shift`.
    pub(crate) fn affine(&self) -> (Vec<f32>, Vec<f32>) {
        let scale: Vec<f32> = self
            .gamma
            .iter()
            .zip(&self.var)
            .map(|(&g, &v)| (g as f64 / (v as f64 + self.epsilon).sqrt()) as f32)
            .collect();
        let shift = self
            .beta
            .iter()
            .zip(&self.mean)
            .zip(&scale)
            .map(|((&b, &m), &s)| b - m * s)
            .collect();
        (scale, shift)
    }
}

impl LinearWeights {
    pub(crate) fn check(&self, layer: &str) -> Result<(), CnnError> {
        check_len(
            layer,
            "weight",
            self.weight.len(),
            self.in_features * self.out_features,
        )?;
        if let Some(b) = &self.bias {
            check_len(layer, "bias", b.len(), self.out_features)?;
        }
        Ok(())
    }
}
