//! A trained CNR model: per cascade stage, a PCA of the descriptors to 3
//! components, K cluster centres in that space, and one single-hidden-layer
//! regressor per cluster (27 → H tanh → 3). Stored as JSON (small: about
//! 25k numbers for 3 stages × 4 clusters × H 64).

use serde::{Deserialize, Serialize};

use super::descriptor::FND_LEN;

/// The `format` field of a model file.
pub const CNR_FORMAT: &str = "normalnet-cnr-1";

/// One regressor: `y = x_own + W2 tanh(W1 x + b1) + b2`, where `x_own` is
/// the face's own normal (the descriptor's first 3 numbers): it predicts
/// the correction of the current normal (our choice; a mesh that is already
/// clean then needs a zero output, and a fresh regressor starts near "keep
/// the normal").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mlp {
    /// hidden width H
    pub hidden: usize,
    /// `[H, 27]`, row-major
    pub w1: Vec<f64>,
    /// `[H]`
    pub b1: Vec<f64>,
    /// `[3, H]`, row-major
    pub w2: Vec<f64>,
    /// `[3]`
    pub b2: Vec<f64>,
}

impl Mlp {
    /// The output for descriptor `x`, and the hidden activations into `h`.
    pub fn forward_into(&self, x: &[f64; FND_LEN], h: &mut [f64]) -> [f64; 3] {
        for (k, hk) in h.iter_mut().enumerate().take(self.hidden) {
            let row = &self.w1[k * FND_LEN..(k + 1) * FND_LEN];
            let z: f64 = row.iter().zip(x).map(|(w, v)| w * v).sum::<f64>() + self.b1[k];
            *hk = z.tanh();
        }
        let mut y = [0.0; 3];
        for (o, yo) in y.iter_mut().enumerate() {
            let row = &self.w2[o * self.hidden..(o + 1) * self.hidden];
            *yo = x[o] + row.iter().zip(h.iter()).map(|(w, v)| w * v).sum::<f64>() + self.b2[o];
        }
        y
    }

    /// The output for descriptor `x`.
    pub fn forward(&self, x: &[f64; FND_LEN]) -> [f64; 3] {
        let mut h = vec![0.0; self.hidden];
        self.forward_into(x, &mut h)
    }

    fn check(&self) -> Result<(), String> {
        let h = self.hidden;
        if h == 0
            || self.w1.len() != h * FND_LEN
            || self.b1.len() != h
            || self.w2.len() != 3 * h
            || self.b2.len() != 3
        {
            return Err(format!("a regressor's arrays do not fit hidden = {h}"));
        }
        if self
            .w1
            .iter()
            .chain(&self.b1)
            .chain(&self.w2)
            .chain(&self.b2)
            .any(|v| !v.is_finite())
        {
            return Err("a regressor holds a non-finite weight".into());
        }
        Ok(())
    }
}

/// One cascade stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    /// mean descriptor of the training faces
    pub pca_mean: Vec<f64>,
    /// 3 principal directions, each 27 numbers
    pub pca: Vec<Vec<f64>>,
    /// cluster centres in PCA space
    pub centres: Vec<[f64; 3]>,
    /// one regressor per cluster
    pub nets: Vec<Mlp>,
}

impl Stage {
    /// The descriptor in PCA space.
    pub fn project(&self, x: &[f64; FND_LEN]) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (c, dir) in self.pca.iter().enumerate().take(3) {
            p[c] = dir
                .iter()
                .zip(x.iter().zip(&self.pca_mean))
                .map(|(d, (v, m))| d * (v - m))
                .sum();
        }
        p
    }

    /// The cluster of descriptor `x` (nearest centre).
    pub fn cluster(&self, x: &[f64; FND_LEN]) -> usize {
        nearest(&self.centres, self.project(x))
    }

    /// The regressed (unnormalised, frame-local) normal of descriptor `x`:
    /// the mean over the 4 reflections of the frame's x and y axes (the
    /// frame fixes those axes only up to sign; regressors train on random
    /// reflections, and the mean makes the answer exactly symmetric).
    pub fn predict(&self, x: &[f64; FND_LEN]) -> [f64; 3] {
        let net = &self.nets[self.cluster(x)];
        let mut h = vec![0.0; net.hidden];
        let mut sum = [0.0; 3];
        for signs in REFLECTIONS {
            let y = net.forward_into(&reflect(x, signs), &mut h);
            for k in 0..3 {
                sum[k] += signs[k] * y[k] / 4.0;
            }
        }
        sum
    }

    fn check(&self) -> Result<(), String> {
        if self.pca_mean.len() != FND_LEN
            || self.pca.len() != 3
            || self.pca.iter().any(|d| d.len() != FND_LEN)
        {
            return Err("PCA arrays do not have 27 × 3 numbers".into());
        }
        if self.centres.is_empty() || self.centres.len() != self.nets.len() {
            return Err(format!(
                "{} cluster centres for {} regressors",
                self.centres.len(),
                self.nets.len()
            ));
        }
        self.nets.iter().try_for_each(Mlp::check)
    }
}

/// The sign patterns of the x and y axes.
pub const REFLECTIONS: [[f64; 3]; 4] = [
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [1.0, -1.0, 1.0],
    [-1.0, -1.0, 1.0],
];

/// Descriptor `x` with its axes scaled by `signs`.
pub fn reflect(x: &[f64; FND_LEN], signs: [f64; 3]) -> [f64; FND_LEN] {
    std::array::from_fn(|i| x[i] * signs[i % 3])
}

/// Index of the centre nearest to `p`.
pub fn nearest(centres: &[[f64; 3]], p: [f64; 3]) -> usize {
    let d = |c: &[f64; 3]| (0..3).map(|k| (c[k] - p[k]).powi(2)).sum::<f64>();
    (0..centres.len())
        .min_by(|&a, &b| d(&centres[a]).total_cmp(&d(&centres[b])))
        .unwrap_or(0)
}

fn one() -> usize {
    1
}

/// A whole model and how it was made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CnrModel {
    /// [`CNR_FORMAT`]
    pub format: String,
    /// the cascade, in order
    pub stages: Vec<Stage>,
    /// vertex-update passes after each stage the model was trained with
    pub vertex_iterations: usize,
    /// the descriptor's neighbourhood: faces within this many vertex rings
    /// (SPEC §9.1: 1, the faces sharing a vertex)
    #[serde(default = "one")]
    pub ring: usize,
    /// training data, settings and validation errors, in words
    pub training: Vec<String>,
}

impl CnrModel {
    /// Writes the model file (JSON, as [`CnrModel::parse`] reads it) to
    /// `path`, whole or not at all.
    ///
    /// # Errors
    /// The file cannot be written (naming it).
    pub fn write(&self, path: &std::path::Path) -> Result<(), normalnet_mesh::MeshError> {
        let text = serde_json::to_string(self).expect("a CNR model serializes");
        normalnet_mesh::io::write_atomically(path, |w| w.write_all(text.as_bytes()))
    }

    /// Parses and checks a model file's text; `label` names it in errors.
    pub fn parse(text: &str, label: &str) -> Result<CnrModel, String> {
        let m: CnrModel =
            serde_json::from_str(text).map_err(|e| format!("{label}: not a CNR model: {e}"))?;
        if m.format != CNR_FORMAT {
            return Err(format!(
                "{label}: format {:?}, expected {CNR_FORMAT:?}",
                m.format
            ));
        }
        if m.ring == 0 || m.ring > 3 {
            return Err(format!("{label}: ring {} (expected 1..=3)", m.ring));
        }
        if m.stages.is_empty() {
            return Err(format!("{label}: no stages"));
        }
        for (i, s) in m.stages.iter().enumerate() {
            s.check()
                .map_err(|e| format!("{label}: stage {}: {e}", i + 1))?;
        }
        Ok(m)
    }
}
