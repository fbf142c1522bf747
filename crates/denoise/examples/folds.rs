//! Fold audit (issues 14 and 39): for every registered method with its
//! defaults (the oracle with the ground truth), without and with the final
//! fold repair (`normalnet_filters::fold_repair`): the faces whose normal
//! opposes the ground truth's ("flipped"), the folded faces of the repair's
//! own test (what a user without ground truth can count) and E_a; the
//! noisy input's counts first.
//!
//! `cargo run --release -p normalnet-denoise --example folds -- NAME=NOISY,CLEAN [...]`
//!
//! Prints one markdown table row per (mesh, method); `--methods a,b` keeps
//! only those methods. A `!` marks more flipped faces than the input.

use normalnet_denoise::{Denoiser, METHODS};
use normalnet_filters::{FoldCheck, repair_mesh_folds};
use normalnet_mesh::metrics::per_face_angle_errors;
use normalnet_mesh::{Mesh, NoProgress, Topology, geometry::face_normals, read_mesh, vec3};

/// (flipped faces, folded faces, E_a in degrees) of `result` against `gt`.
fn score(result: &Mesh, gt: &Mesh, check: &FoldCheck) -> (usize, usize, f64) {
    let (a, b) = (face_normals(result), face_normals(gt));
    let flipped = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| vec3::dot(**x, **y) < 0.0)
        .count();
    let e = per_face_angle_errors(gt, result).unwrap();
    (
        flipped,
        check.count(&result.positions),
        e.iter().sum::<f64>() / e.len() as f64,
    )
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut keep: Option<Vec<String>> = None;
    if let Some(i) = args.iter().position(|a| a == "--methods") {
        keep = Some(args[i + 1].split(',').map(str::to_string).collect());
        args.drain(i..i + 2);
    }
    println!(
        "| mesh | method | flipped vs GT before | after | folded before | after | E_a before (°) | after | ΔE_a | s repair |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for arg in &args {
        let (name, paths) = arg.split_once('=').expect("NAME=NOISY,CLEAN");
        let (noisy, clean) = paths.split_once(',').expect("NAME=NOISY,CLEAN");
        let noisy = read_mesh(noisy).unwrap();
        let clean = read_mesh(clean).unwrap();
        let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
        let check = FoldCheck::new(&noisy.positions, &noisy.faces, &topology);
        let (f, g, e) = score(&noisy, &clean, &check);
        println!("| {name} | noisy input | {f} | | {g} | | {e:.3} | | | |");
        for info in METHODS {
            if keep
                .as_ref()
                .is_some_and(|k| !k.iter().any(|m| m == info.name))
            {
                continue;
            }
            // The method's result, then the repair `Denoiser::run` applies
            // to it (the same result: these meshes need no rescaling).
            let d = Denoiser::with_defaults(info.name)
                .unwrap()
                .with_fold_repair(false);
            let off = d.denoise(&noisy, Some(&clean), &NoProgress).unwrap();
            let t = std::time::Instant::now();
            let mut on = off.clone();
            repair_mesh_folds(&noisy, &mut on.positions);
            let s1 = t.elapsed().as_secs_f64();
            let (f0, g0, e0) = score(&off, &clean, &check);
            let (f1, g1, e1) = score(&on, &clean, &check);
            let mark = if f1 > f { "!" } else { "" };
            println!(
                "| {name} | {} | {f0} | {f1}{mark} | {g0} | {g1} | {e0:.3} | {e1:.3} | {:+.3} | {:.2} |",
                info.name,
                e1 - e0,
                s1
            );
        }
    }
}
