//! Per-iteration trace of the exact NormalNet pipeline (research tool for
//! the "do less" shortcuts): for each filtering iteration, E_a against the
//! ground truth, how far the network's outputs moved since the previous
//! iteration, and how far each face's voxel region moved.
//!
//! `cargo run --release -p normalnet-net --example trace_iterations -- NOISY GT [ITERATIONS]`
//! (built-in bundle, or `$NORMALNET_MODEL`).

use normalnet_filters::{FOLD_GUARD_COS, VertexUpdate, VertexUpdateBuffers, vertex_update_with};
use normalnet_mesh::geometry::mean_edge_length;
use normalnet_mesh::vec3::{self, Vec3};
use normalnet_mesh::{NoProgress, Topology, compare, read_mesh};
use normalnet_net::bundle::network_for_iteration;
use normalnet_net::pipeline::filtered_normals;
use std::time::Instant;

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let noisy = read_mesh(&args[1])?;
    let gt = read_mesh(&args[2])?;
    let iterations: usize = args.get(3).map_or(Ok(10), |s| s.parse())?;
    let bundle = match std::env::var_os("NORMALNET_MODEL") {
        Some(p) => normalnet_net::Bundle::load(p)?,
        None => normalnet_net::embedded::lite()?,
    };
    let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
    let l_e = mean_edge_length(&noisy, &topology);
    let voxel = bundle.voxel_params();
    let mut positions = noisy.positions.clone();
    let mut buffers = VertexUpdateBuffers::default();
    let mut previous: Option<Vec<Vec3>> = None;
    println!(
        "l_e {l_e:.5}  noisy E_a {:.3}",
        compare(&gt, &noisy)?.e_a_deg
    );
    println!("k net  E_a    out_change_mean  p50   p90   p99 | disp/l_e mean p50 p90 max | s");
    for k in 1..=iterations {
        let t = Instant::now();
        let current = noisy.with_positions(positions.clone());
        let i = network_for_iteration(k);
        let (normals, _) = filtered_normals(
            &current,
            &topology,
            &bundle.engines[i],
            bundle.manifest.networks[i].residual,
            voxel,
            bundle.output_for_mu_g(0.35),
            256,
            None,
            &NoProgress,
        )?;
        let before = positions.clone();
        vertex_update_with(
            &mut positions,
            &noisy.faces,
            &topology,
            &normals,
            &VertexUpdate {
                iterations: 20,
                fixed: None,
                fold_guard: Some(FOLD_GUARD_COS),
            },
            &mut buffers,
        );
        let secs = t.elapsed().as_secs_f64();
        let e_a = compare(&gt, &noisy.with_positions(positions.clone()))?.e_a_deg;
        let (mut ch, m) = match &previous {
            Some(p) => {
                let c: Vec<f64> = p
                    .iter()
                    .zip(&normals)
                    .map(|(a, b)| vec3::angle(*a, *b).to_degrees())
                    .collect();
                let m = c.iter().sum::<f64>() / c.len() as f64;
                (c, m)
            }
            None => (vec![0.0], 0.0),
        };
        // per face: the largest vertex displacement within the face's 1-ring
        // vertices (a proxy; the voxel region is larger)
        let disp: Vec<f64> = before
            .iter()
            .zip(&positions)
            .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)) / l_e)
            .collect();
        let mut fd: Vec<f64> = noisy
            .faces
            .iter()
            .map(|f| f.iter().map(|&v| disp[v as usize]).fold(0.0, f64::max))
            .collect();
        let dm = fd.iter().sum::<f64>() / fd.len() as f64;
        println!(
            "{k:2} {}  {e_a:6.3}  {m:7.3}  {:6.3} {:6.3} {:6.3} | {dm:.4} {:.4} {:.4} {:.4} | {secs:.1}",
            i + 1,
            percentile(&mut ch, 0.5),
            percentile(&mut ch, 0.9),
            percentile(&mut ch, 0.99),
            percentile(&mut fd, 0.5),
            percentile(&mut fd, 0.9),
            percentile(&mut fd, 1.0),
        );
        previous = Some(normals);
    }
    Ok(())
}
