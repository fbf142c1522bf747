//! Runs one classical method over `data/gd` pairs and prints E_a (degrees),
//! E_v/l_e (when the mesh crate's metrics are available) and the time of the
//! denoising call.
//!
//! `cargo run --release -p normalnet-filters --example eval -- gnf [Model ...]`

use normalnet_filters::{GtGuidedGnfParams, Method, gt_guided_gnf};
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
    if models.is_empty() || (models.len() == 1 && models[0].starts_with('{')) {
        let patch = models.pop();
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
        if let Some(p) = patch {
            models.insert(0, p);
        }
    }
    // Optional parameter overrides as JSON: eval bnf '{"include_centre":false}' Model...
    let oracle = name == "oracle";
    let mut method = Method::from_name(if oracle { "gnf" } else { &name }).expect("method");
    // The oracle defaults to MEASURED.md's Fandisk settings.
    let mut oracle_params = GtGuidedGnfParams {
        mu_g: 0.25,
        iterations: 10,
        vertex_iterations: 20,
        ..Default::default()
    };
    if models.first().is_some_and(|m| m.starts_with('{')) {
        let patch: serde_json::Value =
            serde_json::from_str(&models.remove(0)).expect("JSON overrides");
        let mut o = serde_json::to_value(&oracle_params).unwrap();
        for (k, x) in patch.as_object().unwrap() {
            o[k] = x.clone();
        }
        if oracle {
            oracle_params = serde_json::from_value(o).expect("oracle parameters");
            println!("{}", serde_json::to_string(&oracle_params).unwrap());
        }
        let mut v = serde_json::to_value(&method).unwrap();
        let params = v.as_object_mut().unwrap().values_mut().next().unwrap();
        for (k, x) in patch.as_object().unwrap() {
            params[k] = x.clone();
        }
        if !oracle {
            method = serde_json::from_value(v).expect("overridden parameters");
            println!("{}", serde_json::to_string(&method).unwrap());
        }
    }
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/gd");
    for model in models {
        let noisy = read_mesh(format!("{data}/{model}/Noisy.obj")).expect("noisy");
        let clean = read_mesh(format!("{data}/{model}/Original.obj")).expect("clean");
        let t0 = Instant::now();
        let out = if oracle {
            let gt = face_normals(&clean);
            gt_guided_gnf(&noisy, &gt, &oracle_params, &NoProgress).expect("oracle")
        } else {
            method.denoise(&noisy, &NoProgress).expect("denoise")
        };
        let secs = t0.elapsed().as_secs_f64();
        let m = normalnet_mesh::metrics::compare(&clean, &out).expect("metrics");
        println!(
            "{model:20} {name:6} noisy E_a {:6.2}  E_a {:6.3}  E_v/l_e {:.4}  time {secs:.3} s",
            mean_angle_degrees(&noisy, &clean),
            mean_angle_degrees(&out, &clean),
            m.e_v_over_le
        );
    }
}
