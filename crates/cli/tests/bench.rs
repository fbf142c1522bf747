//! `normalnet bench` and `normalnet render` end to end on a small generated
//! pair: a subdivided cube (sharp edges, flat faces) and a noisy copy with
//! every vertex moved along its normal by a seeded pseudo-random amount
//! (σ = 0.3 l_e, the SPEC §2 model hand-rolled here), written as
//! `Cube0.3/Noisy.obj` + `Cube0.3/Original.obj` in a temp folder.

use normalnet_mesh::{Mesh, write_mesh};
use normalnet_render::Image;
use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// Unit cube with `n × n` quads per side, two triangles each, outward normals.
fn cube(n: u32) -> Mesh {
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let mut vertex = |p: [u32; 3]| -> u32 {
        *index.entry(p).or_insert_with(|| {
            positions.push(p.map(|c| c as f64 / n as f64));
            (positions.len() - 1) as u32
        })
    };
    // each side: fixed axis `a` at value 0 or n, spanning axes u, v
    for a in 0..3 {
        for side in [0, n] {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = [0; 3];
                        p[a] = side;
                        p[u] = i + di;
                        p[v] = j + dj;
                        p
                    };
                    let q =
                        [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)].map(&mut vertex);
                    if side == n {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh::new(positions, faces).unwrap()
}

/// Moves every vertex along its (unweighted) vertex normal by a seeded
/// pseudo-Gaussian amount with standard deviation `sigma`.
fn add_noise(mesh: &Mesh, sigma: f64, mut seed: u64) -> Mesh {
    let mut normals = vec![[0.0f64; 3]; mesh.num_vertices()];
    for f in &mesh.faces {
        let [a, b, c] = f.map(|i| mesh.positions[i as usize]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for &i in f {
            for k in 0..3 {
                normals[i as usize][k] += n[k] / len;
            }
        }
    }
    let mut uniform = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let positions = mesh
        .positions
        .iter()
        .zip(&normals)
        .map(|(p, n)| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            // Box–Muller
            let t = sigma
                * (-2.0 * uniform().ln()).sqrt()
                * (2.0 * std::f64::consts::PI * uniform()).cos();
            [
                p[0] + t * n[0] / len,
                p[1] + t * n[1] / len,
                p[2] + t * n[2] / len,
            ]
        })
        .collect();
    mesh.with_positions(positions)
}

fn write_pair(data: &Path) {
    let clean = cube(6);
    let noisy = add_noise(&clean, 0.3 / 6.0, 7);
    let dir = data.join("Cube0.3");
    std::fs::create_dir_all(&dir).unwrap();
    write_mesh(dir.join("Original.obj"), &clean).unwrap();
    write_mesh(dir.join("Noisy.obj"), &noisy).unwrap();
}

fn normalnet() -> Command {
    Command::new(env!("CARGO_BIN_EXE_normalnet"))
}

#[test]
fn bench_writes_table_results_and_pictures_and_survives_a_failing_method() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    write_pair(&data);
    let settings = tmp.path().join("bench.toml");
    std::fs::write(
        &settings,
        "[defaults.gnf]\nnormal_iterations = 5\nvertex_iterations = 5\n\n\
         [defaults.normalnet]\niterations = 1\nmodel = \"/nonexistent/normalnet-bundle\"\n\n\
         [models.\"Cube0.3\"]\nskip = [\"sun07\"]\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    let status = normalnet()
        .args(["--quiet", "bench", "--data"])
        .arg(&data)
        .args(["--methods", "gnf,normalnet,sun07,oracle", "--settings"])
        .arg(&settings)
        .args(["--render", "--panel-size", "160x120", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());

    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("| model | noise | metric | noisy | gnf | normalnet | sun07 | oracle |"),
        "{table}"
    );
    assert!(table.contains("| Cube | 0.3 | E_a (deg) |"), "{table}");
    assert!(
        table.contains("failed"),
        "normalnet with a missing bundle must fail: {table}"
    );
    assert!(table.contains("[Cube0.3](Cube0.3.png)"), "{table}");
    assert!(table.contains("| failed | skipped |"), "{table}");

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let records = json["records"].as_array().unwrap();
    let get = |method: &str| records.iter().find(|r| r["method"] == method).unwrap();
    let noisy_ea = get("noisy")["e_a_deg"].as_f64().unwrap();
    let gnf_ea = get("gnf")["e_a_deg"].as_f64().unwrap();
    assert!(noisy_ea > 5.0, "noisy E_a {noisy_ea}");
    assert!(
        gnf_ea < noisy_ea / 2.0,
        "GNF should clean a noisy cube: {gnf_ea} vs {noisy_ea}"
    );
    assert!(get("gnf")["e_v_over_le"].as_f64().unwrap() > 0.0);
    assert!(get("gnf")["denoise_seconds"].as_f64().unwrap() >= 0.0);
    assert!(
        get("gnf")["params"]
            .as_str()
            .unwrap()
            .contains("normal_iterations=5")
    );
    assert!(get("normalnet")["error"].as_str().is_some());
    assert!(get("normalnet")["e_a_deg"].is_null());

    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 6, "{csv}");
    // the oracle (GT-guided GNF) runs and is never bold
    let oracle_ea = get("oracle")["e_a_deg"].as_f64().unwrap();
    assert!(
        oracle_ea < noisy_ea / 2.0,
        "oracle {oracle_ea} vs noisy {noisy_ea}"
    );
    let row = table
        .lines()
        .find(|l| l.starts_with("| Cube | 0.3 | E_a"))
        .unwrap();
    assert!(
        !row.trim_end_matches(" |")
            .rsplit(" | ")
            .next()
            .unwrap()
            .contains("**"),
        "{row}"
    );
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("<img src=\"Cube0.3.png\""));

    let png = Image::decode_png(&std::fs::read(out.join("Cube0.3.png")).unwrap()).unwrap();
    // noisy, gnf, ground truth (the failed method has no panel) side by side
    assert!(
        png.width() > 3 * 160 && png.height() > 120,
        "{}x{}",
        png.width(),
        png.height()
    );
}

#[test]
fn bench_rejects_unknown_methods_and_missing_models() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    write_pair(&data);
    let out = tmp.path().join("out");
    let output = normalnet()
        .args(["--quiet", "bench", "--data"])
        .arg(&data)
        .args(["--methods", "nosuch", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("unknown method `nosuch`"));
    let output = normalnet()
        .args(["--quiet", "bench", "--data"])
        .arg(&data)
        .args(["--models", "Nope0.1", "--methods", "gnf", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("Nope0.1"));
}

#[test]
fn render_with_gt_writes_a_png_of_the_requested_size() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    write_pair(&data);
    let png = tmp.path().join("noisy.png");
    let status = normalnet()
        .args(["--quiet", "render"])
        .arg(data.join("Cube0.3/Noisy.obj"))
        .arg("--gt")
        .arg(data.join("Cube0.3/Original.obj"))
        .args(["--size", "320x200", "--view", "40,-30", "--out"])
        .arg(&png)
        .status()
        .unwrap();
    assert!(status.success());
    let img = Image::decode_png(&std::fs::read(&png).unwrap()).unwrap();
    assert_eq!((img.width(), img.height()), (320, 200));
    let non_white = img
        .pixels()
        .chunks(3)
        .filter(|p| *p != [255, 255, 255])
        .count();
    assert!(non_white > 320 * 200 / 10, "{non_white}");
}

#[test]
fn merge_keeps_earlier_runs_and_their_saved_meshes() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    write_pair(&data);
    let settings = tmp.path().join("bench.toml");
    std::fs::write(
        &settings,
        "[defaults.gnf]\nnormal_iterations = 3\nvertex_iterations = 3\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    let bench = |methods: &str, merge: bool| {
        let mut cmd = normalnet();
        cmd.args(["--quiet", "bench", "--data"])
            .arg(&data)
            .args(["--methods", methods, "--settings"])
            .arg(&settings)
            .args([
                "--render",
                "--save-meshes",
                "--panel-size",
                "160x120",
                "--out",
            ])
            .arg(&out);
        if merge {
            cmd.arg("--merge");
        }
        assert!(cmd.status().unwrap().success());
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap())
                .unwrap();
        json
    };
    let first = bench("gnf", false);
    assert!(out.join("Cube0.3/gnf.obj").is_file());
    let gnf_ea = |j: &serde_json::Value| {
        j["records"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["method"] == "gnf")
            .unwrap()["e_a_deg"]
            .as_f64()
            .unwrap()
    };
    let second = bench("sun07", true);
    assert_eq!(second["methods"], serde_json::json!(["gnf", "sun07"]));
    assert_eq!(
        gnf_ea(&first),
        gnf_ea(&second),
        "the earlier gnf run is kept"
    );
    assert_eq!(
        second["records"].as_array().unwrap().len(),
        3,
        "noisy, gnf, sun07"
    );
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("| noisy | gnf | sun07 |"), "{table}");
    // the picture has noisy, gnf (from the saved mesh), sun07 and the ground truth
    let png = Image::decode_png(&std::fs::read(out.join("Cube0.3.png")).unwrap()).unwrap();
    assert!(png.width() > 4 * 160, "{}", png.width());
    // without --merge the earlier runs are dropped
    let third = bench("sun07", false);
    assert_eq!(third["methods"], serde_json::json!(["sun07"]));
}
