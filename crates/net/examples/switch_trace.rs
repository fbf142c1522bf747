//! Research tool for issue 10: a per-face switch between candidate filtered
//! normals in the NormalNet pipeline. Each iteration computes, from the
//! current mesh, four candidates per face — the network's normal (paper
//! form), the joint-bilateral pass guided by the network's normals (guided
//! form), one GNF pass (its own patch guidance) and the current normal — and
//! a row of features; the vertices then follow the chosen normals.
//!
//! `switch_trace MODE NOISY GT [ITERATIONS] [OUT|WEIGHTS]`, MODE:
//! - `paper` / `guided` / `gnf`: always that candidate; prints E_a per iteration
//! - `oracle`: per face the candidate closest to the ground truth (a ceiling)
//! - `dump OUT`: the paper path; appends per-face rows (features, then the
//!   four candidates' angles to the ground truth), f32 little endian
//! - `learned WEIGHTS`: an MLP of `switch_fit.py` blends the candidates
//!   (env `HARD`: takes the most likely one; env `DUMP=OUT`: rows as `dump`)
//!
//! Stops like the default pipeline: after an iteration whose network outputs
//! turned < 1° on average (0 = never), env `AUTO_STOP`.

use std::io::Write;

use normalnet_filters::gnf::Gnf;
use normalnet_filters::gt_guided::{GT_GUIDED_SIGMA_S, gt_guided_normals};
use normalnet_filters::{
    FOLD_GUARD_COS, GnfParams, NormalFilter, VertexUpdate, VertexUpdateBuffers, vertex_update_with,
};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{FaceGeometry, NoProgress, Topology, compare, read_mesh};
use normalnet_net::bundle::network_for_iteration;
use normalnet_net::inference::filtered_normals;

const NUM_FEATURES: usize = 12;
const NUM_CANDIDATES: usize = 4;

struct Mlp {
    mean: Vec<f64>,
    std: Vec<f64>,
    w1: Vec<Vec<f64>>, // hidden × features
    b1: Vec<f64>,
    w2: Vec<Vec<f64>>, // candidates × hidden
    b2: Vec<f64>,
    hard: bool,
}

impl Mlp {
    /// Text: `hidden`, then mean, std, w1 (row-major), b1, w2, b2, whitespace-separated.
    fn load(path: &str) -> Mlp {
        let text = std::fs::read_to_string(path).expect("weights");
        let v: Vec<f64> = text
            .split_whitespace()
            .map(|s| s.parse().expect("number"))
            .collect();
        let h = v[0] as usize;
        let mut at = 1;
        let mut take = |n: usize| {
            let s = v[at..at + n].to_vec();
            at += n;
            s
        };
        let mean = take(NUM_FEATURES);
        let std = take(NUM_FEATURES);
        let w1 = (0..h).map(|_| take(NUM_FEATURES)).collect();
        let b1 = take(h);
        let w2 = (0..NUM_CANDIDATES).map(|_| take(h)).collect();
        let b2 = take(NUM_CANDIDATES);
        Mlp {
            mean,
            std,
            w1,
            b1,
            w2,
            b2,
            hard: std::env::var("HARD").is_ok(),
        }
    }

    fn probabilities(&self, x: &[f64]) -> Vec<f64> {
        let z: Vec<f64> = x
            .iter()
            .zip(&self.mean)
            .zip(&self.std)
            .map(|((x, m), s)| (x - m) / s)
            .collect();
        let hidden: Vec<f64> = self
            .w1
            .iter()
            .zip(&self.b1)
            .map(|(w, b)| (w.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>() + b).tanh())
            .collect();
        let logits: Vec<f64> = self
            .w2
            .iter()
            .zip(&self.b2)
            .map(|(w, b)| w.iter().zip(&hidden).map(|(a, b)| a * b).sum::<f64>() + b)
            .collect();
        let max = logits.iter().copied().fold(f64::MIN, f64::max);
        let e: Vec<f64> = logits.iter().map(|l| (l - max).exp()).collect();
        let s: f64 = e.iter().sum();
        e.iter().map(|x| x / s).collect()
    }
}

fn ring_angles(topology: &Topology, normals: &[Vec3], f: usize) -> (f64, f64) {
    let ring = topology.face_neighbours.row(f);
    if ring.is_empty() {
        return (0.0, 0.0);
    }
    let a: Vec<f64> = ring
        .iter()
        .map(|&g| vec3::angle(normals[f], normals[g as usize]))
        .collect();
    (
        a.iter().sum::<f64>() / a.len() as f64,
        a.iter().copied().fold(0.0, f64::max),
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args[1].as_str();
    let noisy = read_mesh(&args[2])?;
    let gt = read_mesh(&args[3])?;
    let iterations: usize = args.get(4).map_or(Ok(10), |s| s.parse())?;
    let extra = args.get(5).cloned();
    let auto_stop: f64 = std::env::var("AUTO_STOP").map_or(1.0, |s| s.parse().expect("AUTO_STOP"));
    let mlp = (mode == "learned").then(|| Mlp::load(extra.as_deref().expect("WEIGHTS")));
    let dump_path = match mode {
        "dump" => extra.clone(),
        _ => std::env::var("DUMP").ok(),
    };
    let mut dump = dump_path.map(|p| {
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(p)
            .expect("dump file")
    });
    let bundle = match std::env::var_os("NORMALNET_MODEL") {
        Some(p) => normalnet_net::Bundle::load(p)?,
        None => normalnet_net::embedded::lite()?,
    };
    let mu_g = 0.35;
    let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
    let gt_normals = face_normals(&gt);
    let n = noisy.num_faces();
    let mut positions = noisy.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let mut previous: Option<Vec<Vec3>> = None;
    let gnf_params = GnfParams::default();
    let mut gnf = Gnf::new(&gnf_params, &noisy, &topology)?;
    let mut chosen_count = [0usize; NUM_CANDIDATES];
    print!("{mode}:");
    for k in 1..=iterations {
        let current = noisy.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let (net, _) = filtered_normals(
            &current,
            &topology,
            &bundle.engines[i],
            bundle.manifest.networks[i].residual,
            bundle.voxel_params(),
            bundle.output_for_mu_g(mu_g),
            256,
            None,
            &NoProgress,
        )?;
        let guided = gt_guided_normals(&current, &topology, &net, &[mu_g], GT_GUIDED_SIGMA_S);
        let geometry = FaceGeometry::new(&current);
        let cur = geometry.normals.clone();
        let mut gnf_out = vec![[0.0; 3]; n];
        gnf.pass(&topology, &geometry, &cur, &mut gnf_out);
        let candidates = [&net, &guided, &gnf_out, &cur];
        let features: Vec<[f64; NUM_FEATURES]> = (0..n)
            .map(|f| {
                let (net_mean, net_max) = ring_angles(&topology, &net, f);
                let (cur_mean, _) = ring_angles(&topology, &cur, f);
                let (_, gnf_max) = ring_angles(&topology, &gnf_out, f);
                [
                    vec3::angle(net[f], guided[f]),
                    vec3::angle(net[f], gnf_out[f]),
                    vec3::angle(guided[f], gnf_out[f]),
                    vec3::angle(net[f], cur[f]),
                    net_mean,
                    net_max,
                    cur_mean,
                    gnf_max,
                    k as f64,
                    0.0,
                    0.0,
                    0.0,
                ]
            })
            .collect();
        let noise_level = median(features.iter().map(|r| r[6]).collect());
        let net_flat = median(features.iter().map(|r| r[4]).collect());
        let cad = features
            .iter()
            .filter(|r| r[5] < 10f64.to_radians())
            .count() as f64
            / n as f64;
        let features: Vec<[f64; NUM_FEATURES]> = features
            .into_iter()
            .map(|mut r| {
                r[9] = noise_level;
                r[10] = net_flat;
                r[11] = cad;
                r
            })
            .collect();
        let errors: Vec<[f64; NUM_CANDIDATES]> = (0..n)
            .map(|f| candidates.map(|c| vec3::angle(c[f], gt_normals[f])))
            .collect();
        if let Some(out) = dump.as_mut() {
            let mut bytes = Vec::with_capacity(n * (NUM_FEATURES + NUM_CANDIDATES) * 4);
            for (r, e) in features.iter().zip(&errors) {
                for x in r.iter().chain(e.iter()) {
                    bytes.extend_from_slice(&(*x as f32).to_le_bytes());
                }
            }
            out.write_all(&bytes)?;
        }
        let picks: Vec<(usize, Vec3)> = (0..n)
            .map(|f| {
                let pick = |c: usize| (c, candidates[c][f]);
                match mode {
                    "paper" | "dump" => pick(0),
                    "guided" => pick(1),
                    "gnf" => pick(2),
                    "oracle" => pick(
                        (0..NUM_CANDIDATES)
                            .min_by(|&a, &b| errors[f][a].total_cmp(&errors[f][b]))
                            .unwrap_or(0),
                    ),
                    "learned" => {
                        let mlp = mlp.as_ref().expect("weights");
                        let p = mlp.probabilities(&features[f]);
                        let best = (0..NUM_CANDIDATES)
                            .max_by(|&a, &b| p[a].total_cmp(&p[b]))
                            .unwrap_or(0);
                        if mlp.hard {
                            pick(best)
                        } else {
                            let mut s = [0.0; 3];
                            for (c, w) in candidates.iter().zip(&p) {
                                s = vec3::add(s, vec3::scale(c[f], *w));
                            }
                            (best, vec3::normalize_or_zero(s))
                        }
                    }
                    _ => panic!("unknown mode {mode}"),
                }
            })
            .collect();
        for (c, _) in &picks {
            chosen_count[*c] += 1;
        }
        let filtered: Vec<Vec3> = picks.into_iter().map(|(_, v)| v).collect();
        vertex_update_with(
            &mut positions,
            &noisy.faces,
            &topology,
            &filtered,
            &VertexUpdate {
                iterations: 20,
                fixed: None,
                fold_guard: Some(FOLD_GUARD_COS),
            },
            &mut buffers,
        );
        let e_a = compare(&gt, &noisy.with_positions(positions.clone()))?.e_a_deg;
        print!(" {e_a:.3}");
        std::io::stdout().flush().ok();
        let watched = if std::env::var("STOP_ON_CHOSEN").is_ok() {
            filtered.clone()
        } else {
            net
        };
        let change = previous.as_ref().map_or(f64::INFINITY, |p| {
            p.iter()
                .zip(&watched)
                .map(|(a, b)| vec3::angle(*a, *b).to_degrees())
                .sum::<f64>()
                / n as f64
        });
        previous = Some(watched);
        if k > 1 && change < auto_stop {
            break;
        }
    }
    println!("  chosen {chosen_count:?}");
    Ok(())
}
