//! Training sources' noisy copies (`SourceSpec`): the `noise` lists of
//! mixture components make the same meshes as `add_noise_mixture` with the
//! documented seeds, the classic Gaussian copies are unchanged by them, and
//! bad lists are refused with the source named.

use normalnet_mesh::noise::add_noise_mixture;
use normalnet_mesh::{NoProgress, NoiseDirection, NoiseParams};
use normalnet_net::training::{MIXTURE_SEED, SourceSpec, TrainConfig, noisy_pairs};

fn config(sources: Vec<SourceSpec>) -> TrainConfig {
    TrainConfig {
        shape_faces: 300,
        sources,
        ..TrainConfig::default()
    }
}

fn shape(gaussian: Vec<f64>, noise: Vec<Vec<NoiseParams>>) -> SourceSpec {
    SourceSpec {
        mesh: "shape:5".into(),
        gaussian,
        impulsive: vec![],
        noise,
        regen: false,
    }
}

#[test]
fn mixture_copies_use_the_documented_seeds_and_leave_gaussian_copies_alone() {
    let random = NoiseParams {
        level: 0.3,
        direction: NoiseDirection::Random,
        ..NoiseParams::default()
    };
    let outliers = NoiseParams {
        level: 1.0,
        impulsive_fraction: Some(0.1),
        seed: 7,
        ..NoiseParams::default()
    };
    let spec = shape(vec![0.2], vec![vec![random], vec![random, outliers]]);
    let seed = 40;
    let pairs = noisy_pairs(&config(vec![spec.clone()]), &[spec], seed, &NoProgress).unwrap();
    assert_eq!(pairs.len(), 3);
    let clean = &pairs[0].1;
    // the Gaussian copy is what it was without `noise`
    let alone = shape(vec![0.2], vec![]);
    let plain = noisy_pairs(&config(vec![alone.clone()]), &[alone], seed, &NoProgress).unwrap();
    assert_eq!(pairs[0].2.positions, plain[0].2.positions);
    // copy j, component k: seed + MIXTURE_SEED + 10 j + k + its own seed
    let base = seed + MIXTURE_SEED;
    let first = add_noise_mixture(
        clean,
        &[NoiseParams {
            seed: base,
            ..random
        }],
    )
    .unwrap()
    .0;
    assert_eq!(pairs[1].2.positions, first.positions);
    let second = add_noise_mixture(
        clean,
        &[
            NoiseParams {
                seed: base + 10,
                ..random
            },
            NoiseParams {
                seed: base + 11 + 7,
                ..outliers
            },
        ],
    )
    .unwrap()
    .0;
    assert_eq!(pairs[2].2.positions, second.positions);
    assert_ne!(pairs[1].2.positions, pairs[2].2.positions);
    assert!(pairs[2].0.contains("noise 2"), "{}", pairs[2].0);
}

#[test]
fn bad_noise_lists_are_refused_naming_the_source() {
    let path = std::path::Path::new("t.toml");
    let empty_copy = config(vec![shape(vec![], vec![vec![]])]);
    let e = empty_copy.validate(path).unwrap_err().to_string();
    assert!(e.contains("shape:5") && e.contains("noise copy 1"), "{e}");
    let bad_level = config(vec![shape(
        vec![],
        vec![vec![NoiseParams {
            level: -1.0,
            ..NoiseParams::default()
        }]],
    )]);
    let e = bad_level.validate(path).unwrap_err().to_string();
    assert!(e.contains("component 1") && e.contains("level"), "{e}");
    // a source with only mixture copies is valid
    let only = config(vec![shape(vec![], vec![vec![NoiseParams::default()]])]);
    only.validate(path).unwrap();
    // and TOML reads the suite's component format
    let text = "[[sources]]\nmesh = \"shape:5\"\nnoise = [[{ level = 0.2, direction = \"view\", depth_gain = 2.0 }]]\n";
    let parsed: TrainConfig = toml::from_str(text).unwrap();
    assert_eq!(
        parsed.sources[0].noise[0][0].direction,
        NoiseDirection::View
    );
}
