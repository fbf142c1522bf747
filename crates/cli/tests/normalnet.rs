//! `normalnet denoise --method normalnet` and `normalnet train` end to end:
//! the shipped bundle (models/lite) on a small generated noisy shape, the
//! bundle lookup (--model, NORMALNET_MODEL) and its error messages.

use normalnet_mesh::{read_mesh, write_mesh};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn normalnet() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_normalnet"));
    c.env_remove("NORMALNET_MODEL");
    c
}

fn noisy_shape(dir: &Path) -> PathBuf {
    let (clean, noisy) = normalnet_voxel::shapes::noisy_pair(4, 300, 0.3, 9).unwrap();
    let path = dir.join("noisy.obj");
    write_mesh(&path, &noisy).unwrap();
    write_mesh(dir.join("clean.obj"), &clean).unwrap();
    path
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn shipped_bundle_denoises_a_small_mesh() {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite/manifest.toml");
    if !shipped.is_file() {
        println!("SKIP: no shipped bundle at {}", shipped.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = noisy_shape(dir.path());
    let output = dir.path().join("out.obj");
    let o = normalnet()
        .args([
            "denoise",
            "-q",
            "--json",
            "--iterations",
            "2",
            "--vertex-iterations",
            "3",
        ])
        .arg(&input)
        .arg(&output)
        .arg("--gt")
        .arg(dir.path().join("clean.obj"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let result = read_mesh(&output).unwrap();
    let noisy = read_mesh(&input).unwrap();
    assert_eq!(result.faces, noisy.faces);
    assert!(result.positions.iter().flatten().all(|x| x.is_finite()));
    assert_ne!(result.positions, noisy.positions);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["method"], "normalnet");
    assert!(
        json["metrics"]["e_a_deg"]
            .as_f64()
            .is_some_and(f64::is_finite)
    );
}

/// Issue 11: the default model travels with the binary. A copy of the
/// binary in an empty folder, run from there, denoises with the built-in
/// bundle and describes it; the built-in bundle is the shipped folder.
#[test]
fn the_default_model_is_built_into_the_binary() {
    let dir = tempfile::tempdir().unwrap();
    let input = noisy_shape(dir.path());
    let bin = dir.path().join("normalnet-copy");
    std::fs::copy(env!("CARGO_BIN_EXE_normalnet"), &bin).unwrap();
    let run = |args: &[&str]| {
        let mut c = Command::new(&bin);
        c.env_remove("NORMALNET_MODEL")
            .current_dir(dir.path())
            .args(args);
        c.output().unwrap()
    };
    let o = run(&["denoise", "-q", "--iterations", "1", "noisy.obj", "out.obj"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("out.obj").is_file());
    let o = run(&["models"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("<built-in models/lite>") && text.contains("preset      lite"),
        "{text}"
    );
    // the shipped switch and its late table for runs past 10 iterations
    assert!(
        text.contains("switch      learned") && text.contains("after iteration 10: a late table"),
        "{text}"
    );
    assert_eq!(
        text.lines().filter(|l| l.contains("°")).count(),
        6,
        "{text}"
    );
    assert!(text.contains("int8        full ranges"), "{text}");
    let o = run(&["models", "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["int8_range"], "full");
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite/manifest.toml");
    let shipped: toml::Value = toml::from_str(&std::fs::read_to_string(shipped).unwrap()).unwrap();
    assert_eq!(json["format"].as_i64(), shipped["format"].as_integer());
    assert_eq!(
        json["code_version"].as_str(),
        shipped["code_version"].as_str()
    );
    let _ = input;
}

/// A format-1 bundle (burn records) is refused before any work, with the
/// command that converts it.
#[test]
fn a_format_1_bundle_names_the_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let input = noisy_shape(dir.path());
    let old = dir.path().join("old-bundle");
    std::fs::create_dir_all(&old).unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite/manifest.toml");
    let text = std::fs::read_to_string(shipped).unwrap();
    std::fs::write(
        old.join("manifest.toml"),
        text.replace("format = 2", "format = 1"),
    )
    .unwrap();
    let output = dir.path().join("out.obj");
    let o = normalnet()
        .args(["denoise", "-q", "--model"])
        .arg(&old)
        .arg(&input)
        .arg(&output)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("format 1") && e.contains("normalnet models convert"),
        "{e}"
    );
    assert!(!output.exists());
}

#[test]
fn a_missing_bundle_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let input = noisy_shape(dir.path());
    let output = dir.path().join("out.obj");
    let missing = dir.path().join("no-such-bundle");
    let o = normalnet()
        .args(["denoise", "-q", "--model"])
        .arg(&missing)
        .arg(&input)
        .arg(&output)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no-such-bundle"), "{}", stderr(&o));
    assert!(!output.exists());
    // the environment variable is used when --model is absent
    std::fs::create_dir_all(dir.path().join("empty-bundle")).unwrap();
    let o = normalnet()
        .env("NORMALNET_MODEL", dir.path().join("empty-bundle"))
        .args(["denoise", "-q"])
        .arg(&input)
        .arg(&output)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("empty-bundle") && e.contains("manifest.toml"),
        "{e}"
    );
}

#[test]
fn train_refuses_test_models() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("bad.toml");
    std::fs::write(
        &config,
        "preset = \"tiny\"\n[[sources]]\nmesh = \"gd/Block0.4/Original.obj\"\ngaussian = [0.3]\n",
    )
    .unwrap();
    let o = normalnet()
        .args(["train", "-q", "--out"])
        .arg(dir.path().join("out"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("Block0.4"), "{}", stderr(&o));
}

/// `NORMALNET_ISA` forces the kernel path: `denoise --json` and `models`
/// say which one ran; every path this CPU runs gives a finite mesh; a name
/// that is no path, or one the CPU lacks, is refused before any work.
#[test]
fn the_kernel_path_is_forced_by_normalnet_isa_and_reported() {
    use normalnet_denoise::isa::Isa;
    let dir = tempfile::tempdir().unwrap();
    let input = noisy_shape(dir.path());
    let output = dir.path().join("out.obj");
    for isa in Isa::all_here() {
        let o = normalnet()
            .env("NORMALNET_ISA", isa.name())
            .args(["denoise", input.to_str().unwrap(), output.to_str().unwrap()])
            .args(["--iterations", "2", "--json"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{isa}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["isa"], isa.name());
        assert_eq!(v["parameters"]["isa"], isa.name());
        assert_eq!(v["parameters"]["int8"], isa.has_avx2(), "int8 needs AVX2");
        assert_eq!(
            v["parameters"]["int8_stem"],
            isa.has_avx2(),
            "the int8 stem runs where the blocks do (VNNI or AVX2)"
        );
        // the shipped (full-range) networks run narrow ranges where plain
        // AVX2 sums the bytes
        let range = match (isa.has_avx2(), isa.has_vnni() || isa.uses_avx_vnni()) {
            (false, _) => serde_json::Value::Null,
            (true, true) => "full".into(),
            (true, false) => "narrow".into(),
        };
        assert_eq!(v["parameters"]["int8_range"], range, "{isa}");
        let out = read_mesh(&output).unwrap();
        assert!(out.positions.iter().flatten().all(|c| c.is_finite()));
        let m = normalnet()
            .env("NORMALNET_ISA", isa.name())
            .args(["models"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&m.stdout);
        assert!(
            text.contains(&format!("kernels     {isa} (forced by NORMALNET_ISA")),
            "{text}"
        );
    }
    let o = normalnet()
        .env("NORMALNET_ISA", "neon")
        .args(["denoise", input.to_str().unwrap(), output.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("NORMALNET_ISA=\"neon\" is no kernel path (expected one of scalar, avx2, avxvnni, avx512, avx512vnni)"),
        "{}",
        stderr(&o)
    );
    if let Some(missing) = Isa::ALL.into_iter().find(|isa| !isa.runs_here()) {
        let o = normalnet()
            .env("NORMALNET_ISA", missing.name())
            .args(["models"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains("this CPU does not run it"),
            "{}",
            stderr(&o)
        );
    }
}
