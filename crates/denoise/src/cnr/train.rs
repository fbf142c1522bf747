//! Training CNR (SPEC §9.1) on noisy/clean pairs — the training sources of
//! NormalNet, never the test models. Standard cascaded regression: stage t
//! learns on the meshes as stages 1..t−1 left them. Per stage: descriptors
//! and frame-rotated targets of every training face (a seeded subsample
//! when there are more than `max_samples`), PCA to 3 components, k-means
//! (k-means++ start, Lloyd), one regressor per cluster trained with Adam on
//! the mean squared error; then every mesh, validation included, takes the
//! stage and the vertex update. Deterministic for a seed (clusters train in
//! parallel, each with its own seeded generator).

use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::{face_normals, mean_edge_length};
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{Csr, FaceGeometry, Mesh, Progress, Topology};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::descriptor::{FND_LEN, apply, descriptors};
use super::model::{CNR_FORMAT, CnrModel, Mlp, REFLECTIONS, Stage, nearest, reflect};
use super::stage_normals;

/// Training settings (defaults: SPEC §9.1's choices, measured in the
/// closing note of issue 13; written here once: `normalnet train --method
/// cnr` and a recipe's `cnr` stage lay their values over them).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CnrTrainSettings {
    /// hidden width H of every regressor
    pub hidden: usize,
    /// clusters K per stage
    pub clusters: usize,
    /// cascade stages
    pub stages: usize,
    /// passes over a cluster's samples
    pub epochs: usize,
    /// minibatch size
    pub batch: usize,
    /// Adam step size
    pub lr: f64,
    /// seed of subsampling, k-means and initialisation
    pub seed: u64,
    /// vertex-update passes after each stage
    pub vertex_iterations: usize,
    /// training faces per stage at most (seeded subsample)
    pub max_samples: usize,
    /// the descriptor's neighbourhood in vertex rings (SPEC: 1)
    pub ring: usize,
}

impl CnrTrainSettings {
    /// Checks every field; the message names it.
    ///
    /// # Errors
    /// A count that is zero, a ring outside 1..=3, a step size that is not
    /// positive and finite.
    pub fn validate(&self) -> Result<(), String> {
        for (name, value) in [
            ("hidden", self.hidden),
            ("clusters", self.clusters),
            ("stages", self.stages),
            ("epochs", self.epochs),
            ("batch", self.batch),
            ("max_samples", self.max_samples),
        ] {
            if value == 0 {
                return Err(format!("{name} must be positive"));
            }
        }
        if !(1..=3).contains(&self.ring) {
            return Err(format!("ring must be 1, 2 or 3, not {}", self.ring));
        }
        if !(self.lr > 0.0 && self.lr.is_finite()) {
            return Err(format!("lr must be positive, not {}", self.lr));
        }
        Ok(())
    }
}

/// A CNR model trained on a training config's sources, its validation
/// meshes checking each stage (noisy copies made as NormalNet's training
/// makes them: `normalnet_net::training::noisy_pairs`, the config's seed;
/// validation copies at seed + 777). What `normalnet train --method cnr`
/// and a recipe's `cnr` stage run. `settings.seed` is used as given.
///
/// # Errors
/// Invalid settings ([`DenoiseError::Parameter`]), unreadable sources.
pub fn train_from_config(
    config: &normalnet_net::training::TrainConfig,
    settings: &CnrTrainSettings,
    progress: &dyn Progress,
) -> Result<CnrModel, crate::DenoiseError> {
    use normalnet_net::training::noisy_pairs;
    settings
        .validate()
        .map_err(|message| crate::DenoiseError::Parameter {
            method: "cnr",
            message,
        })?;
    let meshes = |specs, seed| -> Result<Vec<TrainMesh>, crate::DenoiseError> {
        Ok(noisy_pairs(config, specs, seed, progress)?
            .into_iter()
            .map(|(name, clean, noisy)| TrainMesh::new(name, &clean, noisy))
            .collect())
    };
    let train_meshes = meshes(&config.sources, config.seed)?;
    let validation = meshes(&config.validation, config.seed + 777)?;
    Ok(train(train_meshes, validation, settings, progress))
}

impl Default for CnrTrainSettings {
    fn default() -> Self {
        CnrTrainSettings {
            hidden: 64,
            clusters: 4,
            stages: 3,
            epochs: 20,
            batch: 128,
            lr: 1e-3,
            seed: 2016,
            vertex_iterations: 20,
            max_samples: 200_000,
            ring: 1,
        }
    }
}

/// A mesh being carried through the cascade, with its ground truth.
pub struct TrainMesh {
    /// name for the report
    pub name: String,
    /// the ground truth's face normals
    pub gt: Vec<Vec3>,
    /// the current (noisy, then partly denoised) mesh
    pub state: Mesh,
    /// its connectivity (the faces never change)
    pub topology: Topology,
}

impl TrainMesh {
    /// A pair `(name, clean, noisy)`.
    pub fn new(name: String, clean: &Mesh, noisy: Mesh) -> TrainMesh {
        TrainMesh {
            name,
            gt: face_normals(clean),
            topology: Topology::new(noisy.num_vertices(), &noisy.faces),
            state: noisy,
        }
    }
}

/// Descriptors and rotated targets of every face of `meshes`.
fn samples(meshes: &[TrainMesh], rings: &[Csr]) -> (Vec<[f64; FND_LEN]>, Vec<[f64; 3]>) {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for (m, rings) in meshes.iter().zip(rings) {
        let geometry = FaceGeometry::new(&m.state);
        let l_e = mean_edge_length(&m.state, &m.topology);
        for ((d, r), gt) in descriptors(&geometry, rings, l_e).into_iter().zip(&m.gt) {
            if *gt == [0.0; 3] {
                continue;
            }
            xs.push(d);
            ys.push(apply(&r, *gt));
        }
    }
    (xs, ys)
}

/// Mean angle (degrees) between `normals` and the ground truth.
fn mean_angle(normals: &[Vec3], gt: &[Vec3]) -> f64 {
    let (sum, n) = normals
        .iter()
        .zip(gt)
        .filter(|(_, g)| **g != [0.0; 3])
        .fold((0.0, 0usize), |(s, n), (a, b)| {
            (s + vec3::angle(*a, *b).to_degrees(), n + 1)
        });
    sum / n.max(1) as f64
}

/// Mean, and the top 3 principal directions (power iteration with
/// deflation on the 27×27 covariance).
fn pca(xs: &[[f64; FND_LEN]]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = xs.len().max(1) as f64;
    let mut mean = vec![0.0; FND_LEN];
    for x in xs {
        for (m, v) in mean.iter_mut().zip(x) {
            *m += v / n;
        }
    }
    let mut cov = vec![0.0; FND_LEN * FND_LEN];
    for x in xs {
        for i in 0..FND_LEN {
            let a = x[i] - mean[i];
            for j in 0..FND_LEN {
                cov[i * FND_LEN + j] += a * (x[j] - mean[j]) / n;
            }
        }
    }
    let mut dirs = Vec::new();
    for c in 0..3 {
        let mut v: Vec<f64> = (0..FND_LEN)
            .map(|i| 1.0 + (i * (c + 3)) as f64 * 0.01)
            .collect();
        for _ in 0..500 {
            let mut w = vec![0.0; FND_LEN];
            for i in 0..FND_LEN {
                w[i] = (0..FND_LEN).map(|j| cov[i * FND_LEN + j] * v[j]).sum();
            }
            let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm < 1e-300 {
                break;
            }
            v = w.iter().map(|x| x / norm).collect();
        }
        let lambda: f64 = (0..FND_LEN)
            .map(|i| {
                v[i] * (0..FND_LEN)
                    .map(|j| cov[i * FND_LEN + j] * v[j])
                    .sum::<f64>()
            })
            .sum();
        for i in 0..FND_LEN {
            for j in 0..FND_LEN {
                cov[i * FND_LEN + j] -= lambda * v[i] * v[j];
            }
        }
        dirs.push(v);
    }
    (mean, dirs)
}

/// k-means++ start, then Lloyd iterations.
fn kmeans(points: &[[f64; 3]], k: usize, rng: &mut ChaCha8Rng) -> Vec<[f64; 3]> {
    let d2 = |a: &[f64; 3], b: &[f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let mut centres = vec![points[rng.random_range(0..points.len())]];
    while centres.len() < k {
        let dist: Vec<f64> = points
            .iter()
            .map(|p| {
                centres
                    .iter()
                    .map(|c| d2(p, c))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let total: f64 = dist.iter().sum();
        let mut pick = rng.random::<f64>() * total;
        let mut chosen = points.len() - 1;
        for (i, d) in dist.iter().enumerate() {
            pick -= d;
            if pick <= 0.0 {
                chosen = i;
                break;
            }
        }
        centres.push(points[chosen]);
    }
    for _ in 0..60 {
        let mut sums = vec![[0.0; 3]; k];
        let mut counts = vec![0usize; k];
        for p in points {
            let c = nearest(&centres, *p);
            counts[c] += 1;
            for i in 0..3 {
                sums[c][i] += p[i];
            }
        }
        for c in 0..k {
            if counts[c] > 0 {
                centres[c] = sums[c].map(|s| s / counts[c] as f64);
            }
        }
    }
    centres
}

/// Trains one regressor on `(x, y)` pairs; returns it and its final mean
/// squared error.
fn train_mlp(
    xs: &[[f64; FND_LEN]],
    ys: &[[f64; 3]],
    s: &CnrTrainSettings,
    seed: u64,
) -> (Mlp, f64) {
    let h = s.hidden;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a1 = (6.0 / (FND_LEN + h) as f64).sqrt();
    // the residual form starts near the identity: a small output layer
    let a2 = 0.1 * (6.0 / (h + 3) as f64).sqrt();
    let mut net = Mlp {
        hidden: h,
        w1: (0..h * FND_LEN)
            .map(|_| rng.random_range(-a1..a1))
            .collect(),
        b1: vec![0.0; h],
        w2: (0..3 * h).map(|_| rng.random_range(-a2..a2)).collect(),
        b2: vec![0.0; 3],
    };
    let sizes = [h * FND_LEN, h, 3 * h, 3];
    let mut m: Vec<Vec<f64>> = sizes.iter().map(|&n| vec![0.0; n]).collect();
    let mut v: Vec<Vec<f64>> = sizes.iter().map(|&n| vec![0.0; n]).collect();
    let mut g: Vec<Vec<f64>> = sizes.iter().map(|&n| vec![0.0; n]).collect();
    let (b1, b2, eps) = (0.9f64, 0.999f64, 1e-8);
    let mut order: Vec<usize> = (0..xs.len()).collect();
    let mut hid = vec![0.0; h];
    let mut t = 0i32;
    let mut last = f64::NAN;
    for _ in 0..s.epochs {
        order.shuffle(&mut rng);
        let mut epoch_loss = 0.0;
        for chunk in order.chunks(s.batch) {
            g.iter_mut().for_each(|a| a.fill(0.0));
            let scale = 2.0 / (3.0 * chunk.len() as f64);
            for &i in chunk {
                // a random reflection of the frame's x and y axes (see Stage::predict)
                let signs = REFLECTIONS[rng.random_range(0..4)];
                let x = &reflect(&xs[i], signs);
                let target: [f64; 3] = std::array::from_fn(|o| ys[i][o] * signs[o]);
                let y = net.forward_into(x, &mut hid);
                let dy: [f64; 3] = std::array::from_fn(|o| (y[o] - target[o]) * scale);
                epoch_loss += (0..3).map(|o| (y[o] - target[o]).powi(2)).sum::<f64>() / 3.0;
                for o in 0..3 {
                    g[3][o] += dy[o];
                    for k in 0..h {
                        g[2][o * h + k] += dy[o] * hid[k];
                    }
                }
                for k in 0..h {
                    let dh: f64 = (0..3).map(|o| net.w2[o * h + k] * dy[o]).sum();
                    let dz = dh * (1.0 - hid[k] * hid[k]);
                    g[1][k] += dz;
                    let row = &mut g[0][k * FND_LEN..(k + 1) * FND_LEN];
                    for (gw, xv) in row.iter_mut().zip(x) {
                        *gw += dz * xv;
                    }
                }
            }
            t += 1;
            let (c1, c2) = (1.0 - b1.powi(t), 1.0 - b2.powi(t));
            let params: [&mut Vec<f64>; 4] = [&mut net.w1, &mut net.b1, &mut net.w2, &mut net.b2];
            for (p, ((mp, vp), gp)) in params
                .into_iter()
                .zip(m.iter_mut().zip(v.iter_mut()).zip(&g))
            {
                for i in 0..p.len() {
                    mp[i] = b1 * mp[i] + (1.0 - b1) * gp[i];
                    vp[i] = b2 * vp[i] + (1.0 - b2) * gp[i] * gp[i];
                    p[i] -= s.lr * (mp[i] / c1) / ((vp[i] / c2).sqrt() + eps);
                }
            }
        }
        last = epoch_loss / xs.len().max(1) as f64;
    }
    (net, last)
}

/// One stage taken by every mesh: regressed normals, then the vertex update.
fn advance(meshes: &mut [TrainMesh], rings: &[Csr], stage: &Stage, vertex_iterations: usize) {
    for (m, rings) in meshes.iter_mut().zip(rings) {
        let normals = stage_normals(stage, &m.state, &m.topology, rings);
        let mut positions = m.state.positions.clone();
        let update = VertexUpdate {
            iterations: vertex_iterations,
            fixed: None,
            fold_guard: Some(FOLD_GUARD_COS),
        };
        vertex_update_with(
            &mut positions,
            &m.state.faces,
            &m.topology,
            &normals,
            &update,
            &mut VertexUpdateBuffers::default(),
        );
        m.state = m.state.with_positions(positions);
    }
}

/// Mean angle of the current normals and of one stage's regressed normals
/// against the ground truth, over `meshes`.
fn validation(meshes: &[TrainMesh], rings: &[Csr], stage: &Stage) -> (f64, f64) {
    let (mut before, mut after, mut n) = (0.0, 0.0, 0usize);
    for (m, rings) in meshes.iter().zip(rings) {
        let faces = m.state.num_faces();
        before += mean_angle(&face_normals(&m.state), &m.gt) * faces as f64;
        after +=
            mean_angle(&stage_normals(stage, &m.state, &m.topology, rings), &m.gt) * faces as f64;
        n += faces;
    }
    (before / n.max(1) as f64, after / n.max(1) as f64)
}

/// Trains a model on `train`, reporting on `validation` (its meshes are
/// carried through the cascade too). `progress` advances once per stage.
pub fn train(
    mut train: Vec<TrainMesh>,
    mut validation_meshes: Vec<TrainMesh>,
    s: &CnrTrainSettings,
    progress: &dyn Progress,
) -> CnrModel {
    let mut report = report_header(&train, &validation_meshes, s);
    progress.start("CNR training", s.stages as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
    // the descriptors' patches, once: the faces never change
    let rings_of = |meshes: &[TrainMesh]| -> Vec<Csr> {
        meshes
            .iter()
            .map(|m| m.topology.face_rings(s.ring))
            .collect()
    };
    let (train_rings, validation_rings) = (rings_of(&train), rings_of(&validation_meshes));
    let mut stages = Vec::new();
    for t in 0..s.stages {
        progress.message(&format!("stage {}: descriptors", t + 1));
        let (xs, ys) = samples(&train, &train_rings);
        let (xs, ys) = at_most(xs, ys, s.max_samples, &mut rng);
        let (stage, sizes) = fit_stage(t, &xs, &ys, s, &mut rng, progress);
        let (before, after) = validation(&validation_meshes, &validation_rings, &stage);
        report.push(format!(
            "stage {}: clusters [{}]; validation mean normal angle {before:.2}° -> {after:.2}° (regressed normals vs ground truth)",
            t + 1,
            sizes.join(", ")
        ));
        progress.message(&format!(
            "stage {}: validation {before:.2}° -> {after:.2}°",
            t + 1
        ));
        advance(&mut train, &train_rings, &stage, s.vertex_iterations);
        advance(
            &mut validation_meshes,
            &validation_rings,
            &stage,
            s.vertex_iterations,
        );
        stages.push(stage);
        progress.advance(1);
    }
    let final_e_a = mean_state_angle(&validation_meshes);
    report.push(format!("validation E_a after the cascade: {final_e_a:.2}°"));
    progress.finish();
    CnrModel {
        format: CNR_FORMAT.into(),
        stages,
        vertex_iterations: s.vertex_iterations,
        ring: s.ring,
        training: report,
    }
}

/// The model's training report begins with its meshes and settings.
fn report_header(
    train: &[TrainMesh],
    validation: &[TrainMesh],
    s: &CnrTrainSettings,
) -> Vec<String> {
    let names = |meshes: &[TrainMesh]| {
        meshes
            .iter()
            .map(|m| m.name.as_str())
            .collect::<Vec<_>>()
            .join("; ")
    };
    vec![
        format!("training meshes: {}", names(train)),
        format!("validation meshes: {}", names(validation)),
        format!(
            "settings: hidden {}, clusters {}, stages {}, epochs {}, batch {}, Adam lr {}, seed {}, N_v {}, at most {} faces per stage, descriptor ring {}",
            s.hidden,
            s.clusters,
            s.stages,
            s.epochs,
            s.batch,
            s.lr,
            s.seed,
            s.vertex_iterations,
            s.max_samples,
            s.ring
        ),
    ]
}

/// At most `max` of the samples, drawn with `rng` and kept in their order.
fn at_most(
    xs: Vec<[f64; FND_LEN]>,
    ys: Vec<[f64; 3]>,
    max: usize,
    rng: &mut ChaCha8Rng,
) -> (Vec<[f64; FND_LEN]>, Vec<[f64; 3]>) {
    if xs.len() <= max {
        return (xs, ys);
    }
    let mut idx: Vec<usize> = (0..xs.len()).collect();
    idx.shuffle(rng);
    idx.truncate(max);
    idx.sort_unstable();
    (
        idx.iter().map(|&i| xs[i]).collect(),
        idx.iter().map(|&i| ys[i]).collect(),
    )
}

/// Stage `t` of the cascade fitted to descriptors `xs` and target normals
/// `ys`: PCA, k-means clusters, one regressor per cluster (in parallel,
/// seeded per stage and cluster). Also each cluster's size and loss.
fn fit_stage(
    t: usize,
    xs: &[[f64; FND_LEN]],
    ys: &[[f64; 3]],
    s: &CnrTrainSettings,
    rng: &mut ChaCha8Rng,
    progress: &dyn Progress,
) -> (Stage, Vec<String>) {
    let (pca_mean, pca_dirs) = pca(xs);
    let mut stage = Stage {
        pca_mean,
        pca: pca_dirs,
        centres: Vec::new(),
        nets: Vec::new(),
    };
    let projected: Vec<[f64; 3]> = xs.iter().map(|x| stage.project(x)).collect();
    stage.centres = kmeans(&projected, s.clusters, rng);
    let members: Vec<usize> = projected
        .iter()
        .map(|p| nearest(&stage.centres, *p))
        .collect();
    progress.message(&format!(
        "stage {}: {} regressors on {} faces",
        t + 1,
        s.clusters,
        xs.len()
    ));
    let trained: Vec<(Mlp, f64, usize)> = (0..s.clusters)
        .into_par_iter()
        .map(|c| {
            let of_cluster = |i: &usize| members[*i] == c;
            let cx: Vec<[f64; FND_LEN]> = (0..xs.len()).filter(of_cluster).map(|i| xs[i]).collect();
            let cy: Vec<[f64; 3]> = (0..xs.len()).filter(of_cluster).map(|i| ys[i]).collect();
            let (net, loss) = train_mlp(&cx, &cy, s, s.seed + 1000 * t as u64 + c as u64);
            (net, loss, cx.len())
        })
        .collect();
    let sizes = trained
        .iter()
        .map(|(_, l, n)| format!("{n} faces mse {l:.5}"))
        .collect();
    stage.nets = trained.into_iter().map(|(n, _, _)| n).collect();
    (stage, sizes)
}

/// Mean angle of the meshes' face normals against their ground truth,
/// weighted by face count.
fn mean_state_angle(meshes: &[TrainMesh]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for m in meshes {
        sum += mean_angle(&face_normals(&m.state), &m.gt) * m.state.num_faces() as f64;
        n += m.state.num_faces();
    }
    sum / n.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_mesh::{NoProgress, NoiseParams, add_noise};

    fn pair(seed: u64, level: f64) -> TrainMesh {
        let clean = normalnet_mesh_shape(seed);
        let noisy = add_noise(
            &clean,
            &NoiseParams {
                level,
                seed,
                ..NoiseParams::default()
            },
        )
        .unwrap();
        TrainMesh::new(format!("cube {seed}"), &clean, noisy)
    }

    /// A subdivided cube (flat faces and sharp edges: what CNR must keep).
    fn normalnet_mesh_shape(seed: u64) -> Mesh {
        let n = 6 + (seed % 3) as usize;
        let mut p: Vec<[f64; 3]> = Vec::new();
        let mut f: Vec<[u32; 3]> = Vec::new();
        let mut index = std::collections::HashMap::new();
        let mut vid = |q: [i64; 3], p: &mut Vec<[f64; 3]>| -> u32 {
            *index.entry(q).or_insert_with(|| {
                p.push(q.map(|c| c as f64 / n as f64));
                (p.len() - 1) as u32
            })
        };
        let n = n as i64;
        for axis in 0..3 {
            for side in [0, n] {
                for i in 0..n {
                    for j in 0..n {
                        let at = |a: i64, b: i64| {
                            let mut q = [0; 3];
                            q[axis] = side;
                            q[(axis + 1) % 3] = a;
                            q[(axis + 2) % 3] = b;
                            q
                        };
                        let (v00, v10, v11, v01) =
                            (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                        let ids = [v00, v10, v11, v01].map(|q| vid(q, &mut p));
                        if side == 0 {
                            f.push([ids[0], ids[2], ids[1]]);
                            f.push([ids[0], ids[3], ids[2]]);
                        } else {
                            f.push([ids[0], ids[1], ids[2]]);
                            f.push([ids[0], ids[2], ids[3]]);
                        }
                    }
                }
            }
        }
        Mesh::new(p, f).unwrap()
    }

    #[test]
    fn training_reduces_the_validation_error_and_exact_normals_stay() {
        let s = CnrTrainSettings {
            hidden: 16,
            clusters: 2,
            stages: 2,
            epochs: 15,
            ..CnrTrainSettings::default()
        };
        let train_meshes = vec![pair(1, 0.3), pair(2, 0.4), pair(4, 0.2)];
        let val = vec![pair(3, 0.3)];
        let noisy_e_a = mean_angle(&face_normals(&val[0].state), &val[0].gt);
        let model = train(train_meshes, val, &s, &NoProgress);
        assert_eq!(model.stages.len(), 2);
        // the report says how validation went; the cascade itself must help
        let val = pair(3, 0.3);
        let out =
            super::super::run_cascade(&model, &val.state, 0, 20, Some(FOLD_GUARD_COS), &NoProgress);
        let e_a = mean_angle(&face_normals(&out), &val.gt);
        assert!(e_a < 0.6 * noisy_e_a, "E_a {noisy_e_a:.2} -> {e_a:.2}");
        // the exact cube: the normals of its flat faces are kept
        let clean = normalnet_mesh_shape(3);
        let topology = Topology::new(clean.num_vertices(), &clean.faces);
        let normals = stage_normals(&model.stages[0], &clean, &topology, &topology.face_rings(1));
        let exact = face_normals(&clean);
        let err = mean_angle(&normals, &exact);
        let interior: Vec<usize> = (0..clean.num_faces())
            .filter(|&f| {
                topology
                    .face_ring(f, 1)
                    .iter()
                    .all(|&g| vec3::dot(exact[g as usize], exact[f]) > 0.99)
            })
            .collect();
        let flat = interior
            .iter()
            .map(|&f| vec3::angle(normals[f], exact[f]).to_degrees())
            .sum::<f64>()
            / interior.len().max(1) as f64;
        eprintln!(
            "exact cube: mean change {err:.2}°, on {} faces away from the edges {flat:.3}°",
            interior.len()
        );
        assert!(err < 3.0, "mean change of exact normals {err:.2}°");
        // and the model file round-trips
        let text = serde_json::to_string(&model).unwrap();
        assert_eq!(CnrModel::parse(&text, "t").unwrap(), model);
        assert!(CnrModel::parse("{}", "t").is_err());
    }
}
