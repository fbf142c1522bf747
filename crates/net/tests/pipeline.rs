//! End to end on generated shapes (no data folder needed): the iterative
//! training of all six `tiny` networks for a few steps each, then the bundle
//! loads and denoises without NaN.

use normalnet_mesh::NoProgress;
use normalnet_net::training::{SourceSpec, TrainConfig, train};
use normalnet_net::{Bundle, DenoiseParams, denoise};

#[test]
fn tiny_training_writes_a_bundle_that_denoises() {
    let dir = tempfile::tempdir().unwrap();
    let shape = |seed: u64, regen: bool| SourceSpec {
        mesh: format!("shape:{seed}"),
        gaussian: vec![0.4],
        impulsive: vec![],
        regen,
    };
    let config = TrainConfig {
        preset: "tiny".into(),
        batch: 8,
        lr: 1e-3,
        steps: [4, 2, 2, 2, 2, 2],
        validate_every: 2,
        validation_faces: 16,
        shape_faces: 150,
        workers: 1,
        sources: vec![shape(1, true), shape(2, false)],
        validation: vec![shape(1001, false)],
        ..TrainConfig::default()
    };
    let manifest = train(&config, dir.path(), false, &NoProgress).unwrap();
    assert_eq!(manifest.networks.len(), 6);
    assert!(manifest.networks.iter().all(|n| n.steps > 0));
    assert!(
        manifest
            .networks
            .iter()
            .all(|n| n.validation_error_deg.is_finite())
    );
    for f in ["manifest.toml", "net6.bpk", "train_log.csv", "loss.png"] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    let bundle = Bundle::load(dir.path(), &normalnet_net::cpu_device()).unwrap();
    assert_eq!(bundle.manifest, manifest);
    let mesh = normalnet_voxel::shapes::generate_seeded(7, 150).unwrap();
    let params = DenoiseParams {
        iterations: 3,
        vertex_iterations: 5,
        ..DenoiseParams::default()
    };
    let (out, _) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
    assert!(out.positions.iter().flatten().all(|x| x.is_finite()));

    // a second call with --resume on a finished run changes nothing
    let again = train(&config, dir.path(), true, &NoProgress).unwrap();
    assert_eq!(again.networks, manifest.networks);
}

#[test]
fn a_run_stopped_between_networks_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let shape = |seed: u64, regen: bool| SourceSpec {
        mesh: format!("shape:{seed}"),
        gaussian: vec![0.4],
        impulsive: vec![],
        regen,
    };
    let mut config = TrainConfig {
        preset: "tiny".into(),
        batch: 8,
        lr: 1e-3,
        lr_warm: 3e-4,
        steps: [2, 2, 2, 2, 2, 2],
        validate_every: 2,
        validation_faces: 8,
        shape_faces: 120,
        workers: 1,
        stop_after: 2,
        sources: vec![shape(1, true), shape(2, false)],
        validation: vec![shape(1001, false)],
        ..TrainConfig::default()
    };
    // the first two networks only: no bundle yet
    assert!(train(&config, dir.path(), false, &NoProgress).is_err());
    assert!(dir.path().join("net2.bpk").is_file());
    assert!(!dir.path().join("manifest.toml").exists());
    let net1 = std::fs::read(dir.path().join("net1.bpk")).unwrap();
    config.stop_after = 6;
    let manifest = train(&config, dir.path(), true, &NoProgress).unwrap();
    assert_eq!(manifest.networks.len(), 6);
    assert_eq!(manifest.networks[0].steps, 2);
    // finished networks are kept as they were
    assert_eq!(std::fs::read(dir.path().join("net1.bpk")).unwrap(), net1);
    let log = std::fs::read_to_string(dir.path().join("train_log.csv")).unwrap();
    assert!(log.lines().any(|l| l.starts_with("6,")));
    assert!(log.lines().any(|l| l.starts_with("1,")));
    assert!(
        log.contains("3.000e-4"),
        "warm-started networks use lr_warm"
    );
}

#[test]
fn test_models_are_refused_as_training_sources() {
    let config = TrainConfig {
        sources: vec![SourceSpec {
            mesh: "gd/Fandisk0.3/Original.obj".into(),
            gaussian: vec![0.3],
            impulsive: vec![],
            regen: false,
        }],
        ..TrainConfig::default()
    };
    let err = config.validate(std::path::Path::new("x.toml")).unwrap_err();
    assert!(err.to_string().contains("Fandisk0.3"), "{err}");
}
