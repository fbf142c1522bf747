//! End to end on generated shapes (no data folder needed): the iterative
//! training of all six `tiny` networks for a few steps each, then the bundle
//! loads and denoises without NaN.

use normalnet_mesh::NoProgress;
use normalnet_net::training::{SourceSpec, TrainConfig, train};
use normalnet_net::{Bundle, DenoiseParams, Int8Range, denoise};

/// A training source: `mesh` with Gaussian noise of `level`.
fn source(mesh: &str, level: f64) -> SourceSpec {
    SourceSpec {
        mesh: mesh.into(),
        gaussian: vec![level],
        impulsive: vec![],
        noise: vec![],
        regen: false,
    }
}

/// Procedural shape `seed` with Gaussian noise 0.4, its noisy copy drawn
/// anew each epoch where `regen`.
fn shape(seed: u64, regen: bool) -> SourceSpec {
    SourceSpec {
        regen,
        ..source(&format!("shape:{seed}"), 0.4)
    }
}

/// The `tiny` networks two steps each on two small shapes, validated on a
/// third, one worker.
fn tiny_config() -> TrainConfig {
    TrainConfig {
        preset: "tiny".into(),
        batch: 8,
        lr: 1e-3,
        steps: [2; 6],
        validate_every: 2,
        validation_faces: 8,
        shape_faces: 120,
        workers: 1,
        sources: vec![shape(1, true), shape(2, false)],
        validation: vec![shape(1001, false)],
        ..TrainConfig::default()
    }
}

#[test]
fn tiny_training_writes_a_bundle_that_denoises() {
    let dir = tempfile::tempdir().unwrap();
    let config = TrainConfig {
        steps: [4, 2, 2, 2, 2, 2],
        validation_faces: 16,
        shape_faces: 150,
        ..tiny_config()
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
    for f in [
        "manifest.toml",
        "net6.safetensors",
        "train_log.csv",
        "loss.png",
    ] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    let bundle = Bundle::load(dir.path()).unwrap();
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

/// Quantization-aware training (`int8_range = "narrow"`): the bundle says
/// so, its networks run the narrow ranges, and it denoises; the burn
/// engine cannot train it.
#[test]
fn narrow_int8_training_writes_a_narrow_bundle() {
    let dir = tempfile::tempdir().unwrap();
    let config = TrainConfig {
        int8_range: Int8Range::Narrow,
        ..tiny_config()
    };
    assert_eq!(config.fake_quant(), Some(Int8Range::Narrow));
    let manifest = train(&config, dir.path(), false, &NoProgress).unwrap();
    assert_eq!(manifest.int8_range, Int8Range::Narrow);
    let bundle = Bundle::load(dir.path()).unwrap();
    assert!(
        bundle
            .engines
            .iter()
            .all(|e| e.int8_range() == Int8Range::Narrow)
    );
    let mesh = normalnet_voxel::shapes::generate_seeded(7, 150).unwrap();
    let params = DenoiseParams {
        iterations: 2,
        vertex_iterations: 5,
        ..DenoiseParams::default()
    };
    let (out, _) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
    assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
    let burn = TrainConfig {
        engine: "burn".into(),
        ..config
    };
    assert!(burn.validate(std::path::Path::new("narrow.toml")).is_err());
}

#[test]
fn a_run_stopped_between_networks_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = TrainConfig {
        lr_warm: 3e-4,
        stop_after: 2,
        ..tiny_config()
    };
    // the first two networks only: no bundle yet
    assert!(train(&config, dir.path(), false, &NoProgress).is_err());
    assert!(dir.path().join("net2.safetensors").is_file());
    assert!(!dir.path().join("manifest.toml").exists());
    let net1 = std::fs::read(dir.path().join("net1.safetensors")).unwrap();
    config.stop_after = 6;
    assert!(!dir.path().join("states/stage2_0.obj").exists());
    let manifest = train(&config, dir.path(), true, &NoProgress).unwrap();
    assert_eq!(manifest.networks.len(), 6);
    assert_eq!(manifest.networks[0].steps, 2);
    // the meshes moved on through network 2 before network 3 trained on
    // them (the run that stopped after it had not)
    assert!(dir.path().join("states/stage2_0.obj").is_file());
    // finished networks are kept as they were
    assert_eq!(
        std::fs::read(dir.path().join("net1.safetensors")).unwrap(),
        net1
    );
    let log = std::fs::read_to_string(dir.path().join("train_log.csv")).unwrap();
    assert!(log.lines().any(|l| l.starts_with("6,")));
    assert!(log.lines().any(|l| l.starts_with("1,")));
    assert!(
        log.contains("3.000e-4"),
        "warm-started networks use lr_warm"
    );
}

#[test]
fn configs_with_test_models_or_a_non_positive_voxel_scale_are_refused() {
    let test_model = TrainConfig {
        sources: vec![source("gd/Fandisk0.3/Original.obj", 0.3)],
        ..TrainConfig::default()
    };
    let no_scale = TrainConfig {
        voxel_scale: 0.0,
        sources: vec![source("shape:1", 0.3)],
        ..TrainConfig::default()
    };
    for (config, named) in [(test_model, "Fandisk0.3"), (no_scale, "voxel_scale")] {
        let err = config.validate(std::path::Path::new("x.toml")).unwrap_err();
        assert!(err.to_string().contains(named), "{err}");
    }
}

#[test]
fn a_run_continues_a_bundle_and_counts_its_samples() {
    let first = tempfile::tempdir().unwrap();
    let config = TrainConfig {
        residual_from: 3,
        voxel_scale: 1.5,
        ..tiny_config()
    };
    let base = train(&config, first.path(), false, &NoProgress).unwrap();
    // κ is recorded as the grid's α_c
    let tiny = normalnet_voxel::VoxelParams::tiny();
    assert!((base.voxel.alpha_c - tiny.alpha_c / 1.5).abs() < 1e-12);

    let second = tempfile::tempdir().unwrap();
    let more = TrainConfig {
        seed: 2,
        steps: [3, 1, 1, 1, 1, 1],
        init_from: first.path().to_string_lossy().into_owned(),
        ..config.clone()
    };
    let continued = train(&more, second.path(), false, &NoProgress).unwrap();
    for (k, (a, b)) in base.networks.iter().zip(&continued.networks).enumerate() {
        assert_eq!(
            b.samples_seen,
            a.samples_seen + more.steps[k] * more.batch,
            "network {}",
            k + 1
        );
        assert_eq!(a.residual, b.residual);
    }
    assert!(
        continued
            .training
            .notes
            .contains("continued from the bundle")
    );

    // only the last networks: the earlier ones are the bundle's own
    let fourth = tempfile::tempdir().unwrap();
    let tail = TrainConfig {
        first_network: 5,
        ..more.clone()
    };
    let tail_manifest = train(&tail, fourth.path(), false, &NoProgress).unwrap();
    assert_eq!(tail_manifest.networks[..4], base.networks[..4]);
    for k in 0..4 {
        let file = normalnet_net::bundle::network_file(k);
        assert_eq!(
            std::fs::read(first.path().join(&file)).unwrap(),
            std::fs::read(fourth.path().join(&file)).unwrap(),
            "network {}",
            k + 1
        );
    }
    for k in 4..6 {
        assert_eq!(
            tail_manifest.networks[k].samples_seen,
            base.networks[k].samples_seen + tail.steps[k] * tail.batch
        );
    }
    assert!(tail_manifest.training.notes.contains("1..4 are its own"));
    assert!(fourth.path().join("states/stage4_0.obj").is_file());
    let log = std::fs::read_to_string(fourth.path().join("train_log.csv")).unwrap();
    assert!(!log.lines().any(|l| l.starts_with("4,")));
    assert!(log.lines().any(|l| l.starts_with("5,")));
    let no_bundle = TrainConfig {
        first_network: 2,
        init_from: String::new(),
        ..more.clone()
    };
    let err = no_bundle
        .validate(std::path::Path::new("x.toml"))
        .unwrap_err();
    assert!(err.to_string().contains("init_from"), "{err}");

    // a bundle of another residual form or voxel grid is refused before any training
    let third = tempfile::tempdir().unwrap();
    let other_form = TrainConfig {
        residual_from: 2,
        ..more.clone()
    };
    let err = train(&other_form, third.path(), false, &NoProgress).unwrap_err();
    assert!(err.to_string().contains("residual"), "{err}");
    let other_grid = TrainConfig {
        voxel_scale: 1.0,
        ..more
    };
    let err = train(&other_grid, third.path(), false, &NoProgress).unwrap_err();
    assert!(err.to_string().contains("voxel grid"), "{err}");
    assert!(!third.path().join("net1.safetensors").exists());

    // the continued bundle denoises in both output forms, with the fold guard
    let bundle = Bundle::load(second.path()).unwrap();
    let mesh = normalnet_voxel::shapes::generate_seeded(7, 150).unwrap();
    for guided_from in [0, 1] {
        let params = DenoiseParams {
            iterations: 2,
            vertex_iterations: 5,
            guided_from,
            fold_guard: true,
            ..DenoiseParams::default()
        };
        let (out, _) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
        assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
        assert_ne!(out.positions, mesh.positions);
    }
}

#[test]
fn the_shipped_training_configs_are_valid() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let mut read = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("train-") && name.ends_with(".toml") {
            let config = TrainConfig::read(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(!config.sources.is_empty(), "{name}");
            read += 1;
        }
    }
    assert!(
        read >= 5,
        "found {read} training configs in {}",
        dir.display()
    );
}

/// Progress that keeps its messages and, with `stop_at = n`, panics at the
/// n-th mesh regeneration it is told of (a stop in the middle of moving the
/// meshes on to the next network's state).
#[derive(Default)]
struct Recorder {
    messages: std::sync::Mutex<Vec<String>>,
    stop_at: Option<usize>,
}

impl normalnet_mesh::Progress for Recorder {
    fn message(&self, text: &str) {
        let mut m = self.messages.lock().unwrap();
        m.push(text.to_string());
        let regenerations = m.iter().filter(|t| is_regeneration(t)).count();
        if self.stop_at == Some(regenerations) {
            drop(m);
            panic!("stopped while regenerating");
        }
    }
}

/// A message of one mesh's regeneration ("regenerating NAME (N passes)").
fn is_regeneration(text: &str) -> bool {
    text.starts_with("regenerating ") && text.ends_with("passes)")
}

impl Recorder {
    /// How many mesh regenerations it was told of.
    fn regenerations(&self) -> usize {
        let messages = self.messages.lock().unwrap();
        messages.iter().filter(|t| is_regeneration(t)).count()
    }
}

#[test]
fn a_run_stopped_while_regenerating_keeps_the_meshes_it_had_moved_on() {
    let config = tiny_config();
    let reference = tempfile::tempdir().unwrap();
    let all = Recorder::default();
    let want = train(&config, reference.path(), false, &all).unwrap();
    let regenerated = all.regenerations();
    // three meshes (two sources, one validation) moved on after each of
    // networks 1..5
    assert_eq!(regenerated, 3 * 5);

    // stopped at the second mesh after network 1: the first one's state is saved
    let stopped = tempfile::tempdir().unwrap();
    let stop_again = || Recorder {
        stop_at: Some(2),
        ..Recorder::default()
    };
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&config, stopped.path(), false, &stop_again())
    }));
    assert!(run.is_err(), "the run went on past the stop");
    let states = stopped.path().join("states");
    assert!(states.join("stage1_0.obj").is_file());
    assert!(!states.join("stage1_1.obj").is_file());
    assert!(stopped.path().join("state.toml").is_file());

    // the same stop in a second folder, whose saved states claim another
    // network: resumed, it takes none back
    let other = tempfile::tempdir().unwrap();
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        train(&config, other.path(), false, &stop_again())
    }));
    assert!(run.is_err());
    std::fs::write(other.path().join("states/stage1.network"), "another").unwrap();
    let distrusted = Recorder::default();
    train(&config, other.path(), true, &distrusted).unwrap();
    assert_eq!(distrusted.regenerations(), regenerated);

    // resumed: the saved mesh is taken back, not regenerated, and the
    // bundle is the uninterrupted run's
    let resumed = Recorder::default();
    let got = train(&config, stopped.path(), true, &resumed).unwrap();
    let again = resumed.regenerations();
    assert_eq!(again, regenerated - 1);
    let without_clock = |m: &normalnet_net::bundle::Manifest| {
        let mut n = m.networks.clone();
        n.iter_mut().for_each(|n| n.train_seconds = 0.0);
        n
    };
    assert_eq!(without_clock(&got), without_clock(&want));
    for k in 0..6 {
        let file = normalnet_net::bundle::network_file(k);
        assert_eq!(
            std::fs::read(reference.path().join(&file)).unwrap(),
            std::fs::read(stopped.path().join(&file)).unwrap(),
            "network {}",
            k + 1
        );
    }

    // a new run in the same folder takes nothing back
    let fresh = Recorder::default();
    train(&config, stopped.path(), false, &fresh).unwrap();
    let anew = fresh.regenerations();
    assert_eq!(anew, regenerated);
}
