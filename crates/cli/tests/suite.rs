//! `normalnet bench --suite` end to end on a tiny suite of two procedural
//! pairs (issue 35): generation is deterministic (two caches, same bytes),
//! a current cache is reused, the table has the per-group means, and a bad
//! suite is refused before anything is generated, naming the pair.

use std::path::Path;
use std::process::{Command, Output};

const TINY: &str = r#"
shape_faces = 300
groups = ["cad", "heavy", "scanner"]

[[pair]]
name = "box900-g0.3"
source = "shape:900"
groups = ["cad"]
noise = [{ level = 0.3, seed = 1 }]

[[pair]]
name = "cyl901-view+i"
source = "shape:901"
groups = ["cad", "heavy", "scanner"]
noise = [
    { level = 0.6, direction = "view", depth_gain = 1.0, seed = 2 },
    { level = 1.0, impulsive_fraction = 0.1, seed = 3 },
]
"#;

fn bench(suite: &Path, cache: &Path, out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_normalnet"))
        .arg("bench")
        .arg("--suite")
        .arg(suite)
        .arg("--cache")
        .arg(cache)
        .arg("--out")
        .arg(out)
        .args(["--methods", "gnf"])
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn bench_suite_generates_deterministically_and_writes_group_means() {
    let dir = tempfile::tempdir().unwrap();
    let suite = dir.path().join("tiny.toml");
    std::fs::write(&suite, TINY).unwrap();
    let (cache_a, cache_b) = (dir.path().join("cache-a"), dir.path().join("cache-b"));
    let out = dir.path().join("out");
    let first = bench(&suite, &cache_a, &out);
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(
        stderr(&first).contains("2 pairs, 2 generated"),
        "{}",
        stderr(&first)
    );
    let again = bench(&suite, &cache_a, &dir.path().join("out2"));
    assert!(
        stderr(&again).contains("2 pairs, 0 generated"),
        "{}",
        stderr(&again)
    );
    let other = bench(&suite, &cache_b, &dir.path().join("out3"));
    assert!(other.status.success(), "{}", stderr(&other));
    for pair in ["box900-g0.3", "cyl901-view+i"] {
        for file in ["Noisy.obj", "Original.obj", "key.json"] {
            let a = std::fs::read(cache_a.join(pair).join(file)).unwrap();
            let b = std::fs::read(cache_b.join(pair).join(file)).unwrap();
            assert!(a == b, "{pair}/{file} differs between two generations");
        }
    }
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("| box900-g0.3 | gaussian L=0.3 | E_a (deg) |"),
        "{table}"
    );
    assert!(
        table.contains("| cyl901-view+i | view L=0.6 k=1 + impulsive L=1 p=0.1 | E_a (deg) |"),
        "{table}"
    );
    let groups = table.split("## Group means").nth(1).expect("group means");
    for g in [
        "| cad | 2 | E_a (deg) |",
        "| heavy | 1 | E_a (deg) |",
        "| scanner | 1 |",
    ] {
        assert!(groups.contains(g), "{g}: {groups}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let means = json["group_means"].as_array().unwrap();
    let gnf_cad = means
        .iter()
        .find(|m| m["group"] == "cad" && m["method"] == "gnf")
        .expect("gnf mean over cad");
    let e_a = gnf_cad["e_a_deg"].as_f64().unwrap();
    let noisy_cad = means
        .iter()
        .find(|m| m["group"] == "cad" && m["method"] == "noisy")
        .unwrap()["e_a_deg"]
        .as_f64()
        .unwrap();
    assert!(
        e_a > 0.0 && e_a < noisy_cad,
        "gnf {e_a} vs noisy {noisy_cad}"
    );
}

#[test]
fn a_bad_suite_is_refused_before_any_generation() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    for (edit, needle) in [
        (("shape:901", "c3d/nosuch.obj"), "nosuch.obj does not exist"),
        (("depth_gain", "depth_gian"), "unknown field `depth_gian`"),
        (("shape:901", "cnr/cube_n1/Noisy.obj"), "test data"),
    ] {
        let suite = dir.path().join("bad.toml");
        std::fs::write(&suite, TINY.replace(edit.0, edit.1)).unwrap();
        let o = bench(&suite, &cache, &dir.path().join("out"));
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(e.contains(needle) && e.contains("bad.toml"), "{e}");
        if needle != "unknown field `depth_gian`" {
            assert!(e.contains("cyl901-view+i"), "names the pair: {e}");
        }
        assert!(!cache.exists(), "nothing generated for a bad suite");
    }
}

#[test]
fn noise_command_writes_scanner_like_noise_reproducibly() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean.obj");
    let shape = normalnet_voxel::shapes::generate_seeded(900, 300).unwrap();
    normalnet_mesh::write_mesh(&clean, &shape).unwrap();
    let noise = |out: &str, extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_normalnet"))
            .arg("noise")
            .arg(&clean)
            .arg(dir.path().join(out))
            .args(["--seed", "7", "--level", "0.3"])
            .args(extra)
            .output()
            .unwrap();
        (o.status.success(), stderr(&o))
    };
    let scanner = [
        "--direction",
        "view",
        "--view-dir",
        "0,0,-1",
        "--depth-gain",
        "2",
        "--mix",
        "correlation=5,level=0.2",
        "--mix",
        "impulsive=0.1,level=1",
    ];
    let (ok, e) = noise("a.obj", &scanner);
    assert!(ok, "{e}");
    assert!(noise("b.obj", &scanner).0);
    assert!(noise("plain.obj", &[]).0);
    let read = |f: &str| std::fs::read(dir.path().join(f)).unwrap();
    assert_eq!(read("a.obj"), read("b.obj"), "same seed, same bytes");
    assert_ne!(read("a.obj"), read("plain.obj"));
    // the command's mesh is the library's mixture
    let components = [
        normalnet_mesh::NoiseParams {
            level: 0.3,
            seed: 7,
            direction: normalnet_mesh::NoiseDirection::View,
            view_direction: Some([0.0, 0.0, -1.0]),
            depth_gain: 2.0,
            ..Default::default()
        },
        normalnet_mesh::NoiseParams {
            level: 0.2,
            seed: 8,
            correlation_length: Some(5.0),
            ..Default::default()
        },
        normalnet_mesh::NoiseParams {
            level: 1.0,
            seed: 9,
            impulsive_fraction: Some(0.1),
            ..Default::default()
        },
    ];
    let (expected, _) = normalnet_mesh::noise::add_noise_mixture(&shape, &components).unwrap();
    let written = normalnet_mesh::read_mesh(dir.path().join("a.obj")).unwrap();
    assert_eq!(written.positions, expected.positions);
    let (ok, e) = noise("bad.obj", &["--depth-gain", "2"]);
    assert!(!ok && e.contains("depth_gain"), "{e}");
    let (ok, e) = noise("bad.obj", &["--mix", "levle=1"]);
    assert!(!ok && e.contains("levle"), "{e}");
}
