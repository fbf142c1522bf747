//! Fitting the learned switch ([`crate::switch`]): from rows of face
//! features and the candidates' angles to the ground truth (collected
//! by running the pipeline on training pairs, see
//! `examples/switch_trace.rs`), a one-hidden-layer perceptron whose softmax
//! minimises the expected angle `Σ_c p_c · e_c` (degrees), by Adam over
//! shuffled mini-batches. Deterministic for a seed; parallel over the
//! batch with a fixed reduction order, so the result does not depend on the
//! thread count.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::switch::{
    DEFAULT_MAX_ITERATION, NUM_CANDIDATES, NUM_FEATURES, SwitchWeights, feature_as_read, table_dims,
};

/// One training row: features, then each candidate's angle to the ground
/// truth in radians (the layout of the dump files).
pub const ROW_LEN: usize = NUM_FEATURES + NUM_CANDIDATES;

/// Settings of [`fit`].
#[derive(Clone, Debug)]
pub struct FitParams {
    /// hidden units (32)
    pub hidden: usize,
    /// passes over the rows (40)
    pub epochs: usize,
    /// rows per Adam step (4096)
    pub batch: usize,
    /// Adam's step size (3e-3)
    pub learning_rate: f64,
    /// shuffling and initialisation
    pub seed: u64,
    /// the iteration feature is clamped to this (10; the longest runs
    /// among the rows)
    pub max_iteration: usize,
    /// a table with the CNR candidate (reading all [`NUM_FEATURES`]); its
    /// rows must have been traced with it
    pub cnr: bool,
}

impl Default for FitParams {
    fn default() -> Self {
        FitParams {
            hidden: 32,
            epochs: 40,
            batch: 4096,
            learning_rate: 3e-3,
            seed: 1,
            max_iteration: DEFAULT_MAX_ITERATION,
            cnr: false,
        }
    }
}

impl FitParams {
    /// The features and candidates of the table it fits.
    pub fn dims(&self) -> (usize, usize) {
        table_dims(self.cnr)
    }
}

/// The parameters as one flat vector: w1, b1, w2, b2; `nf` features, `nc`
/// candidates.
struct Layout {
    h: usize,
    nf: usize,
    nc: usize,
}

impl Layout {
    fn len(&self) -> usize {
        self.h * self.nf + self.h + self.nc * self.h + self.nc
    }
    fn split<'a>(&self, p: &'a [f64]) -> (&'a [f64], &'a [f64], &'a [f64], &'a [f64]) {
        let (w1, rest) = p.split_at(self.h * self.nf);
        let (b1, rest) = rest.split_at(self.h);
        let (w2, b2) = rest.split_at(self.nc * self.h);
        (w1, b1, w2, b2)
    }
}

/// Expected error (degrees) of one row and, when `grad` is given, its
/// gradient added into `grad`.
fn row_loss(layout: &Layout, p: &[f64], z: &[f64], e_deg: &[f64], grad: Option<&mut [f64]>) -> f64 {
    let (h, nf, nc) = (layout.h, layout.nf, layout.nc);
    let (w1, b1, w2, b2) = layout.split(p);
    let hidden: Vec<f64> = w1
        .chunks_exact(nf)
        .zip(b1)
        .map(|(w, b)| (w.iter().zip(z).map(|(a, b)| a * b).sum::<f64>() + b).tanh())
        .collect();
    let mut logits = [0.0; NUM_CANDIDATES];
    let logits = &mut logits[..nc];
    for (c, l) in logits.iter_mut().enumerate() {
        *l = b2[c]
            + w2[c * h..(c + 1) * h]
                .iter()
                .zip(&hidden)
                .map(|(a, b)| a * b)
                .sum::<f64>();
    }
    let max = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut prob = [0.0; NUM_CANDIDATES];
    let prob = &mut prob[..nc];
    for (q, l) in prob.iter_mut().zip(logits.iter()) {
        *q = (l - max).exp();
    }
    let sum: f64 = prob.iter().sum();
    prob.iter_mut().for_each(|q| *q /= sum);
    let loss: f64 = prob.iter().zip(e_deg).map(|(q, e)| q * e).sum();
    if let Some(g) = grad {
        let (gw1, rest) = g.split_at_mut(h * nf);
        let (gb1, rest) = rest.split_at_mut(h);
        let (gw2, gb2) = rest.split_at_mut(nc * h);
        let mut dhidden = vec![0.0; h];
        for c in 0..nc {
            let dl = prob[c] * (e_deg[c] - loss);
            gb2[c] += dl;
            for j in 0..h {
                gw2[c * h + j] += dl * hidden[j];
                dhidden[j] += dl * w2[c * h + j];
            }
        }
        for j in 0..h {
            let da = dhidden[j] * (1.0 - hidden[j] * hidden[j]);
            gb1[j] += da;
            for (g, x) in gw1[j * nf..(j + 1) * nf].iter_mut().zip(z) {
                *g += da * x;
            }
        }
    }
    loss
}

/// What [`fit`] reports besides the weights.
#[derive(Clone, Debug, PartialEq)]
pub struct FitReport {
    /// mean expected error (degrees) after each epoch, on all rows
    pub epoch_loss: Vec<f64>,
    /// mean angle (degrees) of each candidate of the table alone
    pub candidate_mean_deg: Vec<f64>,
    /// mean angle (degrees) of the per-row best candidate (the ceiling)
    pub best_mean_deg: f64,
}

/// Fits a switch to `rows` (each [`ROW_LEN`] values; a table with the CNR
/// candidate where `params.cnr`). `allowed` lists the candidates it may
/// choose (the others get a bias of −10⁹).
///
/// # Errors
/// No rows, a row of the wrong length, non-finite values the table reads
/// (CNR's angle in rows traced without it), or an empty `allowed`.
pub fn fit(
    rows: &[f32],
    allowed: &[usize],
    params: &FitParams,
) -> Result<(SwitchWeights, FitReport), String> {
    check_fit_inputs(rows, allowed, params)?;
    let (nf, nc) = params.dims();
    let data = Standardized::new(rows, params.max_iteration, nf, nc);
    let mask = candidate_mask(allowed, nc);
    let (candidate_mean_deg, best_mean_deg) = candidate_means(&data.e, allowed, nc);
    let layout = Layout {
        h: params.hidden.max(1),
        nf,
        nc,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let mut p = initial_parameters(&layout, &mask, &mut rng);
    let b2_start = layout.len() - nc;
    let mut adam = Adam::new(p.len());
    let mut order: Vec<usize> = (0..data.n).collect();
    let mut epoch_loss = Vec::with_capacity(params.epochs);
    for _ in 0..params.epochs {
        order.shuffle(&mut rng);
        for idx in order.chunks(params.batch.max(1)) {
            let mut g = batch_gradient(&layout, &p, &data, idx);
            // the masked biases stay where they are
            for c in 0..nc {
                if mask[c] != 0.0 {
                    g[b2_start + c] = 0.0;
                }
            }
            adam.step(&mut p, &g, params.learning_rate);
        }
        epoch_loss.push(mean_loss(&layout, &p, &data));
    }
    let (w1, b1, w2, b2) = layout.split(&p);
    let weights = SwitchWeights {
        hidden: layout.h,
        mean: data.mean,
        std: data.std,
        w1: w1.to_vec(),
        b1: b1.to_vec(),
        w2: w2.to_vec(),
        b2: b2.to_vec(),
        max_iteration: params.max_iteration,
        notes: String::new(),
        network_on_folds: false,
        late: None,
        heavy: None,
    };
    weights.validate()?;
    Ok((
        weights,
        FitReport {
            epoch_loss,
            candidate_mean_deg,
            best_mean_deg,
        },
    ))
}

/// Gradients and losses are summed over fixed chunks of rows, so that the
/// sum order does not depend on the threads.
const CHUNK: usize = 256;

fn check_fit_inputs(rows: &[f32], allowed: &[usize], params: &FitParams) -> Result<(), String> {
    if rows.is_empty() || !rows.len().is_multiple_of(ROW_LEN) {
        return Err(format!(
            "{} values do not make rows of {ROW_LEN}",
            rows.len()
        ));
    }
    let (nf, nc) = params.dims();
    for r in rows.chunks_exact(ROW_LEN) {
        if r[..nf].iter().any(|x| !x.is_finite()) {
            return Err("a row holds a non-finite feature".into());
        }
        let angles = &r[NUM_FEATURES..NUM_FEATURES + nc];
        if angles.iter().any(|x| !x.is_finite()) {
            return Err(
                if nc == NUM_CANDIDATES && r[NUM_FEATURES + nc - 1].is_nan() {
                    "a row has no CNR candidate (rows traced without it: give their stage `cnr = true`)"
                    .into()
                } else {
                    "a row holds a non-finite angle".into()
                },
            );
        }
    }
    if allowed.is_empty() || allowed.iter().any(|&c| c >= nc) {
        return Err(format!("allowed candidates {allowed:?}"));
    }
    if params.max_iteration == 0 {
        return Err("max_iteration = 0".into());
    }
    Ok(())
}

/// The rows as the fit reads them: features standardised (as the switch
/// reads them, the iteration clamped), candidate errors in degrees.
struct Standardized {
    n: usize,
    mean: Vec<f64>,
    std: Vec<f64>,
    /// `n × nf` standardised features
    z: Vec<f64>,
    /// `n × nc` errors (degrees)
    e: Vec<f64>,
    nf: usize,
    nc: usize,
}

impl Standardized {
    /// The first `nf` features and `nc` angles of the rows.
    fn new(rows: &[f32], max_iteration: usize, nf: usize, nc: usize) -> Standardized {
        let n = rows.len() / ROW_LEN;
        let feature = |j: usize, x: f32| feature_as_read(j, f64::from(x), max_iteration);
        let mut mean = vec![0.0; nf];
        let mut var = vec![0.0; nf];
        for r in rows.chunks_exact(ROW_LEN) {
            for (j, (m, x)) in mean.iter_mut().zip(r).enumerate() {
                *m += feature(j, *x) / n as f64;
            }
        }
        for r in rows.chunks_exact(ROW_LEN) {
            for (j, ((v, m), x)) in var.iter_mut().zip(&mean).zip(r).enumerate() {
                *v += (feature(j, *x) - m).powi(2) / n as f64;
            }
        }
        // a (nearly) constant feature is left unscaled rather than blown up
        let std: Vec<f64> = var
            .iter()
            .map(|v| if v.sqrt() < 1e-6 { 1.0 } else { v.sqrt() })
            .collect();
        let z: Vec<f64> = rows
            .chunks_exact(ROW_LEN)
            .flat_map(|r| {
                r[..nf]
                    .iter()
                    .zip(&mean)
                    .zip(&std)
                    .enumerate()
                    .map(|(j, ((x, m), s))| (feature(j, *x) - m) / s)
            })
            .collect();
        let e: Vec<f64> = rows
            .chunks_exact(ROW_LEN)
            .flat_map(|r| {
                r[NUM_FEATURES..NUM_FEATURES + nc]
                    .iter()
                    .map(|x| f64::from(*x).to_degrees())
            })
            .collect();
        Standardized {
            n,
            mean,
            std,
            z,
            e,
            nf,
            nc,
        }
    }

    fn features(&self, i: usize) -> &[f64] {
        &self.z[i * self.nf..(i + 1) * self.nf]
    }

    fn errors(&self, i: usize) -> &[f64] {
        &self.e[i * self.nc..(i + 1) * self.nc]
    }
}

/// 0 for an allowed candidate, −10⁹ (added to its bias) for the others.
fn candidate_mask(allowed: &[usize], nc: usize) -> Vec<f64> {
    let mut mask = vec![-1e9; nc];
    for &c in allowed {
        mask[c] = 0.0;
    }
    mask
}

/// The mean error of each of the `nc` candidates alone, and of the best
/// allowed one per row (the ceiling of any switch).
fn candidate_means(e: &[f64], allowed: &[usize], nc: usize) -> (Vec<f64>, f64) {
    let n = e.len() / nc;
    let mut candidate_mean_deg = vec![0.0; nc];
    let mut best = 0.0;
    for ei in e.chunks_exact(nc) {
        for (m, x) in candidate_mean_deg.iter_mut().zip(ei) {
            *m += x / n as f64;
        }
        best += allowed.iter().map(|&c| ei[c]).fold(f64::INFINITY, f64::min) / n as f64;
    }
    (candidate_mean_deg, best)
}

/// Uniform ±1/√fan-in weights, zero biases, the mask on the output biases.
fn initial_parameters(layout: &Layout, mask: &[f64], rng: &mut ChaCha8Rng) -> Vec<f64> {
    use rand::Rng;
    let (h, nf, nc) = (layout.h, layout.nf, layout.nc);
    let mut p = vec![0.0; layout.len()];
    let s1 = 1.0 / (nf as f64).sqrt();
    let s2 = 1.0 / (h as f64).sqrt();
    for x in &mut p[..h * nf] {
        *x = rng.random_range(-s1..s1);
    }
    let w2_start = h * nf + h;
    for x in &mut p[w2_start..w2_start + nc * h] {
        *x = rng.random_range(-s2..s2);
    }
    let b2_start = layout.len() - nc;
    for (b, m) in p[b2_start..].iter_mut().zip(mask) {
        *b += m;
    }
    p
}

/// The mean gradient of the expected error over the rows `idx`.
fn batch_gradient(layout: &Layout, p: &[f64], data: &Standardized, idx: &[usize]) -> Vec<f64> {
    let grads: Vec<Vec<f64>> = idx
        .par_chunks(CHUNK)
        .map(|part| {
            let mut g = vec![0.0; p.len()];
            for &i in part {
                row_loss(layout, p, data.features(i), data.errors(i), Some(&mut g));
            }
            g
        })
        .collect();
    let mut g = vec![0.0; p.len()];
    for part in &grads {
        for (a, b) in g.iter_mut().zip(part) {
            *a += b / idx.len() as f64;
        }
    }
    g
}

/// The mean expected error (degrees) over all rows.
fn mean_loss(layout: &Layout, p: &[f64], data: &Standardized) -> f64 {
    (0..data.n)
        .collect::<Vec<_>>()
        .par_chunks(CHUNK)
        .map(|part| {
            part.iter()
                .map(|&i| row_loss(layout, p, data.features(i), data.errors(i), None))
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum::<f64>()
        / data.n as f64
}

/// Adam (β₁ 0.9, β₂ 0.999, ε 1e-8) with its bias correction in the step.
struct Adam {
    m1: Vec<f64>,
    m2: Vec<f64>,
    t: i32,
}

impl Adam {
    fn new(len: usize) -> Adam {
        Adam {
            m1: vec![0.0; len],
            m2: vec![0.0; len],
            t: 0,
        }
    }

    fn step(&mut self, p: &mut [f64], g: &[f64], learning_rate: f64) {
        let (beta1, beta2, eps): (f64, f64, f64) = (0.9, 0.999, 1e-8);
        self.t += 1;
        let t = self.t;
        let lr = learning_rate * (1.0 - beta2.powi(t)).sqrt() / (1.0 - beta1.powi(t));
        for (((x, g), a), b) in p.iter_mut().zip(g).zip(&mut self.m1).zip(&mut self.m2) {
            *a = beta1 * *a + (1.0 - beta1) * g;
            *b = beta2 * *b + (1.0 - beta2) * g * g;
            *x -= lr * *a / (b.sqrt() + eps);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::switch::{BASE_FEATURES, ITERATION_FEATURE};

    /// Rows where feature 0 says which candidate is right: below 0.5 the
    /// network (0) is exact and the guided pass (1) is 10° off, above it
    /// the other way round; candidates 2 and 3 are always 20° off; no CNR
    /// candidate (traced without it).
    fn rows(n: usize) -> Vec<f32> {
        let mut out = Vec::with_capacity(n * ROW_LEN);
        for i in 0..n {
            let x0 = (i * 37 % 100) as f32 / 100.0;
            let mut r = [0.1f32; ROW_LEN];
            r[0] = x0;
            r[1] = (i % 7) as f32;
            let ten = 10f32.to_radians();
            let (e0, e1) = if x0 < 0.5 { (0.0, ten) } else { (ten, 0.0) };
            r[NUM_FEATURES..].copy_from_slice(&[e0, e1, 2.0 * ten, 2.0 * ten, f32::NAN]);
            out.extend(r);
        }
        out
    }

    #[test]
    fn the_fit_learns_which_candidate_is_right() {
        let data = rows(2000);
        let params = FitParams {
            epochs: 30,
            batch: 256,
            learning_rate: 1e-2,
            ..FitParams::default()
        };
        let (w, report) = fit(&data, &[0, 1, 2, 3], &params).unwrap();
        assert!((report.best_mean_deg - 0.0).abs() < 1e-9);
        assert!((report.candidate_mean_deg[2] - 20.0).abs() < 1e-4);
        let first = report.epoch_loss[0];
        let last = *report.epoch_loss.last().unwrap();
        assert!(last < 1.0 && last < first, "loss {first} -> {last}");
        let mut x = [0.1; NUM_FEATURES];
        x[0] = 0.2;
        assert!(
            w.probabilities(&x)[0] > 0.9,
            "{:?} {:?}",
            w.probabilities(&x),
            report
        );
        x[0] = 0.8;
        assert!(w.probabilities(&x)[1] > 0.9);
    }

    #[test]
    fn the_fit_sees_the_iteration_clamped() {
        // iterations 1..=25; the network is right in the first 15, the
        // guided pass after
        let mut data = rows(2500);
        let ten = 10f32.to_radians();
        for (i, r) in data.chunks_exact_mut(ROW_LEN).enumerate() {
            let k = (i % 25 + 1) as f32;
            r[ITERATION_FEATURE] = k;
            let (e0, e1) = if k <= 15.0 { (0.0, ten) } else { (ten, 0.0) };
            r[NUM_FEATURES..NUM_FEATURES + 2].copy_from_slice(&[e0, e1]);
        }
        let params = FitParams {
            epochs: 30,
            batch: 256,
            learning_rate: 1e-2,
            ..FitParams::default()
        };
        let at = |w: &SwitchWeights, k: f64| {
            let mut x = [0.1; NUM_FEATURES];
            x[ITERATION_FEATURE] = k;
            w.probabilities(&x)
        };
        // clamped at 10, iterations 16-25 look like 10-15: no way to tell
        let (w, _) = fit(&data, &[0, 1], &params).unwrap();
        assert_eq!(w.max_iteration, 10);
        assert!(w.mean[ITERATION_FEATURE] <= 10.0);
        assert_eq!(at(&w, 12.0), at(&w, 20.0));
        // clamped at 25 it learns the switch-over
        let params = FitParams {
            max_iteration: 25,
            ..params
        };
        let (w, _) = fit(&data, &[0, 1], &params).unwrap();
        assert_eq!(w.max_iteration, 25);
        assert!(
            at(&w, 8.0)[0] > 0.9 && at(&w, 22.0)[1] > 0.9,
            "{:?} {:?}",
            at(&w, 8.0),
            at(&w, 22.0)
        );
        let params = FitParams {
            max_iteration: 0,
            ..params
        };
        assert!(fit(&data, &[0, 1], &params).is_err());
    }

    #[test]
    fn disallowed_candidates_are_never_chosen_and_bad_rows_are_refused() {
        let data = rows(500);
        let params = FitParams {
            epochs: 3,
            ..FitParams::default()
        };
        let (w, report) = fit(&data, &[1, 2], &params).unwrap();
        assert!((report.best_mean_deg - 5.0).abs() < 0.5);
        let x = [0.1; NUM_FEATURES];
        let p = w.probabilities(&x);
        assert_eq!(p[0], 0.0);
        assert_eq!(p[3], 0.0);
        assert!(fit(&data[..ROW_LEN * 3 + 1], &[0], &params).is_err());
        assert!(fit(&data, &[], &params).is_err());
        assert!(fit(&data, &[4], &params).is_err());
        let mut bad = data.clone();
        bad[5] = f32::NAN;
        assert!(fit(&bad, &[0], &params).unwrap_err().contains("non-finite"));
    }

    #[test]
    fn a_table_with_the_cnr_candidate_reads_its_features() {
        // feature 12, ∠(net, CNR), says when CNR is exact (below 0.5) or
        // 30° off; the other candidates are 10-20° off
        let ten = 10f32.to_radians();
        let mut data = rows(2000);
        for (i, r) in data.chunks_exact_mut(ROW_LEN).enumerate() {
            let x = (i * 53 % 100) as f32 / 100.0;
            r[BASE_FEATURES] = x;
            let cnr = if x < 0.5 { 0.0 } else { 3.0 * ten };
            r[NUM_FEATURES..].copy_from_slice(&[ten, ten, 2.0 * ten, 2.0 * ten, cnr]);
        }
        let params = FitParams {
            epochs: 30,
            batch: 256,
            learning_rate: 1e-2,
            cnr: true,
            ..FitParams::default()
        };
        let (w, report) = fit(&data, &[0, 1, 2, 3, 4], &params).unwrap();
        assert!(w.reads_cnr() && w.validate().is_ok());
        assert_eq!(report.candidate_mean_deg.len(), NUM_CANDIDATES);
        let mut x = [0.1; NUM_FEATURES];
        x[BASE_FEATURES] = 0.2;
        assert!(w.probabilities(&x)[4] > 0.9, "{:?}", w.probabilities(&x));
        x[BASE_FEATURES] = 0.8;
        assert!(w.probabilities(&x)[4] < 0.1, "{:?}", w.probabilities(&x));
        // without the candidate the same rows fit a table of four, which
        // reads neither CNR feature
        let (w4, _) = fit(
            &data,
            &[0, 1, 2, 3],
            &FitParams {
                cnr: false,
                ..params.clone()
            },
        )
        .unwrap();
        assert!(!w4.reads_cnr() && w4.mean.len() == BASE_FEATURES);
        assert!(
            fit(
                &data,
                &[4],
                &FitParams {
                    cnr: false,
                    ..params.clone()
                }
            )
            .is_err()
        );
        // rows traced without CNR cannot fit a table with it
        let err = fit(&rows(500), &[0, 1, 2, 3, 4], &params).unwrap_err();
        assert!(err.contains("no CNR candidate"), "{err}");
    }
}
