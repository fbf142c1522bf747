//! Research tool for the learned switch (`normalnet_net::switch`, issue
//! 10): runs the NormalNet pipeline on a noisy/clean pair, computes the four
//! candidates and the features of every face in every iteration, and moves
//! the vertices with the normals a MODE picks. Prints E_a after each
//! iteration and how often each candidate had the largest weight.
//!
//! `switch_trace MODE NOISY GT [ITERATIONS] [OUT|SWITCH.toml]`, MODE:
//! - `paper` / `guided` / `gnf`: always that candidate
//! - `oracle`: per face the candidate closest to the ground truth (a ceiling)
//! - `dump OUT`: the paper's path; appends one row per face and iteration
//!   (features, then the candidates' angles to the ground truth, radians;
//!   f32 little endian) — the input of `switch_fit`
//! - `learned SWITCH.toml`: the switch of that file's `[switch]` table
//!   (env `DUMP=OUT` also appends rows along its path)
//!
//! Env `STATS=1`: after each iteration print E_a/stay share/mean turn of
//! the network outputs since the previous iteration/mean turn of the
//! chosen normals from the current ones (degrees).
//!
//! Env `INT8=1`: the residual blocks in 8-bit integers (the denoiser's
//! default where the CPU has AVX-512 VNNI); otherwise f32.
//!
//! Env `MU_G=X` (default 0.35) and `NV=N` (default 20): the run's μ_g and
//! vertex iterations (the bench's Table 2 settings run 20–25 iterations at
//! μ_g 0.3 with N_v 10 or 30).
//!
//! Env `AUTO_STOP=DEG` (default 0: all ITERATIONS): stop after an
//! iteration whose network outputs turned less than DEG on average.
//!
//! Env `FLAT=DEG` (default 0: off): from iteration 2 on, faces whose 2-ring
//! is flat within DEG take the 2-ring mean as their network output, as the
//! denoiser's `flat_skip_deg` does (the network still runs on every face
//! here, so the rows match the denoiser's, not its speed).

use std::io::Write;

use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{NoProgress, Topology, compare, read_mesh};
use normalnet_net::bundle::network_for_iteration;
use normalnet_net::inference::{filtered_normals, take_flat_means};
use normalnet_net::switch::{self, NUM_CANDIDATES, SwitchState, SwitchWeights};

#[derive(serde::Deserialize)]
struct Table {
    switch: SwitchWeights,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args[1].as_str();
    let noisy = read_mesh(&args[2])?;
    let gt = read_mesh(&args[3])?;
    let iterations: usize = args.get(4).map_or(Ok(10), |s| s.parse())?;
    let extra = args.get(5).cloned();
    let auto_stop: f64 = std::env::var("AUTO_STOP").map_or(0.0, |s| s.parse().expect("AUTO_STOP"));
    let stats = std::env::var_os("STATS").is_some();
    let weights = match mode {
        "learned" => {
            let text = std::fs::read_to_string(extra.as_deref().expect("SWITCH.toml"))?;
            Some(toml::from_str::<Table>(&text)?.switch)
        }
        _ => None,
    };
    let dump_path = match mode {
        "dump" => extra.clone(),
        _ => std::env::var("DUMP").ok(),
    };
    let mut dump = match dump_path {
        Some(p) => Some(
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(p)?,
        ),
        None => None,
    };
    let mut bundle = match std::env::var_os("NORMALNET_MODEL") {
        Some(p) => normalnet_net::Bundle::load(p)?,
        None => normalnet_net::embedded::lite()?,
    };
    if std::env::var_os("INT8").is_some() {
        let got = bundle.set_precision(normalnet_cnn::Precision::Int8);
        eprintln!("precision: {got:?}");
    }
    let mu_g: f64 = std::env::var("MU_G").map_or(0.35, |s| s.parse().expect("MU_G"));
    let vertex_iterations: usize = std::env::var("NV").map_or(20, |s| s.parse().expect("NV"));
    let flat_skip: f64 = std::env::var("FLAT").map_or(0.0, |s| s.parse().expect("FLAT"));
    let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
    let gt_normals = face_normals(&gt);
    let n = noisy.num_faces();
    let mut positions = noisy.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let mut previous: Option<Vec<Vec3>> = None;
    let mut state = SwitchState::new(&noisy, &topology, mu_g);
    let mut chosen = [0usize; NUM_CANDIDATES];
    print!("{mode}:");
    for k in 1..=iterations {
        let stay_before = chosen[NUM_CANDIDATES - 1];
        let current = noisy.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let (mut net, _) = filtered_normals(
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
        if flat_skip > 0.0 && k > 1 {
            take_flat_means(&current, &topology, flat_skip, &mut net);
        }
        let change = previous.as_ref().map_or(f64::INFINITY, |p| {
            p.iter()
                .zip(&net)
                .map(|(a, b)| vec3::angle(*a, *b).to_degrees())
                .sum::<f64>()
                / n as f64
        });
        previous = Some(net.clone());
        let c = state.candidates(&current, &topology, net);
        let features = switch::features(&topology, &c, k);
        let errors: Vec<[f64; NUM_CANDIDATES]> = (0..n)
            .map(|f| std::array::from_fn(|j| vec3::angle(c.normals[j][f], gt_normals[f])))
            .collect();
        if let Some(out) = dump.as_mut() {
            let mut bytes = Vec::with_capacity(n * switch::NUM_FEATURES * 8);
            for (r, e) in features.iter().zip(&errors) {
                for x in r.iter().chain(e.iter()) {
                    bytes.extend_from_slice(&(*x as f32).to_le_bytes());
                }
            }
            out.write_all(&bytes)?;
        }
        let always = |j: usize, chosen: &mut [usize; NUM_CANDIDATES]| {
            chosen[j] += n;
            c.normals[j].clone()
        };
        let filtered = match mode {
            "paper" | "dump" => always(0, &mut chosen),
            "guided" => always(1, &mut chosen),
            "gnf" => always(2, &mut chosen),
            "oracle" => (0..n)
                .map(|f| {
                    let best = (0..NUM_CANDIDATES)
                        .min_by(|&a, &b| errors[f][a].total_cmp(&errors[f][b]))
                        .unwrap_or(0);
                    chosen[best] += 1;
                    c.normals[best][f]
                })
                .collect(),
            "learned" => {
                let w = weights.as_ref().expect("weights");
                for x in &features {
                    let p = w.probabilities(x);
                    let best = (0..NUM_CANDIDATES)
                        .max_by(|&a, &b| p[a].total_cmp(&p[b]))
                        .unwrap_or(0);
                    chosen[best] += 1;
                }
                switch::blend(w, &c, &features).0
            }
            _ => return Err(format!("unknown mode {mode}").into()),
        };
        // with STATS: how far the chosen normals turned from the current ones
        let turn = stats.then(|| {
            filtered
                .iter()
                .zip(&c.normals[NUM_CANDIDATES - 1])
                .map(|(a, b)| vec3::angle(*a, *b).to_degrees())
                .sum::<f64>()
                / n as f64
        });
        vertex_update_with(
            &mut positions,
            &noisy.faces,
            &topology,
            &filtered,
            &VertexUpdate {
                iterations: vertex_iterations,
                fixed: None,
                fold_guard: Some(FOLD_GUARD_COS),
            },
            &mut buffers,
        );
        let e_a = compare(&gt, &noisy.with_positions(positions.clone()))?.e_a_deg;
        if let Some(turn) = turn {
            let stay = (chosen[NUM_CANDIDATES - 1] - stay_before) as f64 / n as f64;
            print!(" {e_a:.3}/{stay:.3}/{change:.3}/{turn:.3}");
        } else {
            print!(" {e_a:.3}");
        }
        std::io::stdout().flush().ok();
        if k > 1 && change < auto_stop {
            break;
        }
    }
    println!("  chosen {chosen:?}");
    Ok(())
}
