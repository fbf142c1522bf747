//! Issue 14 measurement: flipped faces (normal opposed to the ground
//! truth's) and E_a of the noisy input and of every classical method with
//! the fold guard off and on.
//!
//! `cargo run --release -p normalnet-denoise --example folds -- NOISY CLEAN [NOISY CLEAN ...]`
//! (every registered method but the oracle; NormalNet included)

use normalnet_denoise::{Denoiser, Kind, METHODS, Params};
use normalnet_mesh::metrics::per_face_angle_errors;
use normalnet_mesh::{Mesh, NoProgress, geometry::face_normals, read_mesh, vec3};

/// (flipped faces, E_a in degrees) of `result` against `gt`.
fn score(result: &Mesh, gt: &Mesh) -> (usize, f64) {
    let (a, b) = (face_normals(result), face_normals(gt));
    let flipped = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| vec3::dot(**x, **y) < 0.0)
        .count();
    let e = per_face_angle_errors(gt, result).unwrap();
    (flipped, e.iter().sum::<f64>() / e.len() as f64)
}

/// `name` with its fold guard set to `on` (methods without one: defaults).
fn with_guard(name: &str, on: bool) -> Denoiser {
    let info = normalnet_denoise::find(name).unwrap();
    let mut p = Params::new();
    if (info.defaults)().get("fold_guard").is_some() {
        p.insert("fold_guard".into(), on.into());
    }
    Denoiser::new(name, &p).unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    println!("| model | method | flipped (guard off) | flipped (guard on) | E_a off | E_a on |");
    println!("|---|---|---|---|---|---|");
    for pair in args.chunks(2) {
        let noisy = read_mesh(&pair[0]).unwrap();
        let clean = read_mesh(&pair[1]).unwrap();
        let name = std::path::Path::new(&pair[0])
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .to_string();
        let (f, e) = score(&noisy, &clean);
        println!("| {name} | noisy | {f} | {f} | {e:.3} | {e:.3} |");
        for n in METHODS
            .iter()
            .filter(|m| m.kind != Kind::Oracle)
            .map(|m| m.name)
        {
            let off = with_guard(n, false)
                .denoise(&noisy, None, &NoProgress)
                .unwrap();
            let on = with_guard(n, true)
                .denoise(&noisy, None, &NoProgress)
                .unwrap();
            let (f0, e0) = score(&off, &clean);
            let (f1, e1) = score(&on, &clean);
            println!("| {name} | {n} | {f0} | {f1} | {e0:.3} | {e1:.3} |");
        }
    }
}
