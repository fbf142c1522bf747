//! How far the int8 arithmetic moves the network's normals from f32: angle
//! between the filtered normals (μ_g 0.35 output; residual networks added
//! to the face normal) of f32 and int8 engines on every face of a mesh —
//! int8 residual blocks with the f32 stem (the default int8 form), and the
//! row stem in int8 too (`Arithmetic::int8_stem`).
//!
//! `cargo run --release -p normalnet-net --example int8_error -- MESH [NETWORK 1..6 | all] [BUNDLE]`
//! (bundle: `models/lite` by default)
//! Prints mean / 99th percentile / largest angle (degrees) per network.

use normalnet_mesh::{NoProgress, Topology, read_mesh};
use normalnet_net::pipeline::filtered_normals;
use normalnet_net::{Arithmetic, Bundle};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let mesh = read_mesh(a.get(1).ok_or("usage: int8_error MESH [NETWORK]")?)?;
    let networks: Vec<usize> = match a.get(2).map(String::as_str) {
        Some("all") | None => (0..6).collect(),
        Some(k) => vec![k.parse::<usize>()? - 1],
    };
    let bundle = a.get(3).map_or("models/lite", String::as_str);
    let exact = Bundle::load(bundle)?;
    let mut int8 = Bundle::load(bundle)?;
    if !int8.set_arithmetic(Arithmetic::INT8_BLOCKS).int8 {
        return Err("this CPU has no int8 kernels".into());
    }
    let blocks_only = int8.clone();
    int8.set_arithmetic(Arithmetic {
        int8_stem: true,
        ..Arithmetic::INT8_BLOCKS
    });
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let slot = exact.output_for_mu_g(0.35);
    for k in networks {
        let pass = |b: &Bundle| {
            filtered_normals(
                &mesh,
                &topology,
                &b.engines[k],
                b.manifest.networks[k].residual,
                b.voxel_params(),
                slot,
                256,
                None,
                &NoProgress,
            )
        };
        let (a, _) = pass(&exact)?;
        for (name, engine) in [("int8 blocks", &blocks_only), ("int8 with the stem", &int8)] {
            let (b, _) = pass(engine)?;
            let mut angles: Vec<f64> = a
                .iter()
                .zip(&b)
                .map(|(x, y)| {
                    let dot: f64 = x.iter().zip(y).map(|(p, q)| p * q).sum();
                    dot.clamp(-1.0, 1.0).acos().to_degrees()
                })
                .collect();
            angles.sort_by(f64::total_cmp);
            let mean = angles.iter().sum::<f64>() / angles.len() as f64;
            let p99 = angles[(angles.len() * 99 / 100).min(angles.len() - 1)];
            println!(
                "network {}: {} faces, angle f32 vs {name} mean {mean:.3}°, p99 {p99:.3}°, max {:.3}°",
                k + 1,
                angles.len(),
                angles[angles.len() - 1]
            );
        }
    }
    Ok(())
}
