//! A trainable array with its gradient and Adam moments, and the Adam update
//! (Kingma & Ba 2015, in the form burn uses: ε scaled by the second moment's
//! bias correction).

/// Adam's constants (SPEC §8: β₁ 0.9, β₂ 0.999, ε 1e-8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamConfig {
    /// first-moment decay
    pub beta_1: f32,
    /// second-moment decay
    pub beta_2: f32,
    /// added to the root of the second moment
    pub epsilon: f32,
}

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig {
            beta_1: 0.9,
            beta_2: 0.999,
            epsilon: 1e-8,
        }
    }
}

/// Values, gradient (summed over a batch) and Adam moments of one array.
#[derive(Clone, Debug, Default)]
pub(crate) struct Param {
    pub value: Vec<f32>,
    pub grad: Vec<f32>,
    pub m: Vec<f32>,
    pub v: Vec<f32>,
}

impl Param {
    pub(crate) fn new(value: Vec<f32>) -> Param {
        let n = value.len();
        Param {
            value,
            grad: vec![0.0; n],
            m: vec![0.0; n],
            v: vec![0.0; n],
        }
    }

    /// One Adam update at step `t` (1-based) with learning rate `lr`.
    pub(crate) fn adam(&mut self, c: &AdamConfig, lr: f32, t: i32) {
        let bc2 = (1.0 - (c.beta_2 as f64).powi(t)).sqrt();
        let factor = (bc2 / (1.0 - (c.beta_1 as f64).powi(t))) as f32;
        let eps = c.epsilon * bc2 as f32;
        for (((w, &g), m), v) in self
            .value
            .iter_mut()
            .zip(&self.grad)
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            *m = c.beta_1 * *m + (1.0 - c.beta_1) * g;
            *v = c.beta_2 * *v + (1.0 - c.beta_2) * g * g;
            *w -= lr * (*m * factor) / (v.sqrt() + eps);
        }
    }
}
