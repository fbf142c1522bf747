//! Issue 39: no method adds folds. On cow and spot (`../shared/data/c3d`,
//! Gaussian noise level 0.3, seed 1: `normalnet noise MESH --level 0.3
//! --seed 1`), Fandisk0.3 (`../shared/data/gd`) and the shipped example
//! (`examples/noisy-part.obj`, `clean-part.obj`), every registered method
//! with its defaults (the oracle with the ground truth) leaves no more faces
//! flipped against the ground truth, and no more folded faces
//! (`normalnet_filters::fold_repair`), than the noisy input had. Skipped
//! with a message when the data is absent. Figures: docs/robustness.md
//! ("Folds").

use std::path::{Path, PathBuf};

use normalnet_denoise::{Denoiser, METHODS};
use normalnet_filters::FoldCheck;
use normalnet_mesh::geometry::face_normals;
use normalnet_mesh::{Mesh, NoProgress, NoiseParams, Topology, add_noise, read_mesh, vec3};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

/// Faces of `result` whose normal opposes the ground truth's.
fn flipped(result: &Mesh, gt: &Mesh) -> usize {
    face_normals(result)
        .iter()
        .zip(&face_normals(gt))
        .filter(|(a, b)| vec3::dot(**a, **b) < 0.0)
        .count()
}

/// (name, noisy, clean) of the test meshes present.
fn meshes() -> Vec<(&'static str, Mesh, Mesh)> {
    let data = Path::new(DATA);
    let mut out = Vec::new();
    for name in ["cow", "spot"] {
        let path: PathBuf = data.join("c3d").join(format!("{name}.obj"));
        if !path.exists() {
            eprintln!("skipping {name}: {} is absent", path.display());
            continue;
        }
        let clean = read_mesh(&path).unwrap();
        let params = NoiseParams {
            level: 0.3,
            seed: 1,
            ..NoiseParams::default()
        };
        out.push((name, add_noise(&clean, &params).unwrap(), clean));
    }
    let fandisk = data.join("gd/Fandisk0.3");
    if fandisk.join("Noisy.obj").exists() {
        out.push((
            "Fandisk0.3",
            read_mesh(fandisk.join("Noisy.obj")).unwrap(),
            read_mesh(fandisk.join("Original.obj")).unwrap(),
        ));
    } else {
        eprintln!("skipping Fandisk0.3: {} is absent", fandisk.display());
    }
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    out.push((
        "part",
        read_mesh(examples.join("noisy-part.obj")).unwrap(),
        read_mesh(examples.join("clean-part.obj")).unwrap(),
    ));
    out
}

#[test]
fn issue_39_no_method_adds_folds() {
    let mut failures = Vec::new();
    for (name, noisy, clean) in meshes() {
        let topology = Topology::new(noisy.num_vertices(), &noisy.faces);
        let check = FoldCheck::new(&noisy.positions, &noisy.faces, &topology);
        let (flipped_in, folded_in) = (flipped(&noisy, &clean), check.count(&noisy.positions));
        eprintln!("{name}: noisy input {flipped_in} flipped, {folded_in} folded");
        for info in METHODS {
            let outcome = Denoiser::with_defaults(info.name)
                .unwrap()
                .run(&noisy, Some(&clean), &NoProgress)
                .unwrap();
            let out = &outcome.mesh;
            let (f, g) = (flipped(out, &clean), check.count(&out.positions));
            let report = outcome.folds.expect("the repair runs by default");
            eprintln!("  {}: {f} flipped, {g} folded, {report:?}", info.name);
            assert_eq!(report.after, g, "{name} {}: the report counts", info.name);
            assert_eq!(report.input, folded_in);
            if f > flipped_in || g > folded_in {
                failures.push(format!(
                    "{name} {}: {f} flipped (input {flipped_in}), {g} folded (input {folded_in})",
                    info.name
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
