//! Runs one classical method over `data/gd` pairs and prints E_a (degrees),
//! E_v/l_e (when the mesh crate's metrics are available) and the time of the
//! denoising call.
//!
//! `cargo run --release -p normalnet-filters --example eval -- gnf [Model ...]`

use normalnet_filters::Method;
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::{NoProgress, read_mesh, vec3};
use std::time::Instant;

fn mean_angle_degrees(a: &normalnet_mesh::Mesh, b: &normalnet_mesh::Mesh) -> f64 {
    let na = face_normals(a);
    let nb = face_normals(b);
    na.iter()
        .zip(&nb)
        .map(|(x, y)| vec3::angle(*x, *y).to_degrees())
        .sum::<f64>()
        / na.len() as f64
}

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "gnf".into());
    let mut models: Vec<String> = args.collect();
    if models.is_empty() {
        models = [
            "Fandisk0.3",
            "Fandisk0.7",
            "Twelve0.5Impulsive",
            "Block0.4",
            "Bunny0.2",
            "SharpSphere0.3",
            "Nicolo0.2",
            "Julius0.2",
        ]
        .map(String::from)
        .to_vec();
    }
    let method = Method::from_name(&name).expect("method");
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/gd");
    for model in models {
        let noisy = read_mesh(format!("{data}/{model}/Noisy.obj")).expect("noisy");
        let clean = read_mesh(format!("{data}/{model}/Original.obj")).expect("clean");
        let t0 = Instant::now();
        let out = method.denoise(&noisy, &NoProgress).expect("denoise");
        let secs = t0.elapsed().as_secs_f64();
        println!(
            "{model:20} {name:6} noisy E_a {:6.2}  E_a {:6.3}  time {secs:.3} s",
            mean_angle_degrees(&noisy, &clean),
            mean_angle_degrees(&out, &clean)
        );
    }
}
