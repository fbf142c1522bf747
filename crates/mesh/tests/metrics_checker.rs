//! `compare()` against the independent Python checker
//! (`shared/tools/eval/metrics.py`) on real noisy/clean pairs. Skipped when
//! the data or python3 with numpy + scipy is absent.

use normalnet_mesh::io::read_mesh;
use normalnet_mesh::metrics::compare;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

fn shared() -> Option<PathBuf> {
    let d = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"));
    if d.join("data/gd").is_dir() && d.join("tools/eval/metrics.py").is_file() {
        Some(d)
    } else {
        eprintln!(
            "SKIP: {} has no data/gd or tools/eval/metrics.py",
            d.display()
        );
        None
    }
}

fn python_ok() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import numpy, scipy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIP: python3 with numpy and scipy is not available");
    }
    ok
}

/// Runs the checker and returns (its JSON, its wall time in seconds).
fn checker(shared: &std::path::Path, gt: &PathBuf, res: &PathBuf) -> (serde_json::Value, f64) {
    let t = Instant::now();
    let out = Command::new("python3")
        .arg(shared.join("tools/eval/metrics.py"))
        .arg(gt)
        .arg(res)
        .output()
        .expect("python3 runs");
    let secs = t.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (
        serde_json::from_slice(&out.stdout).expect("checker prints JSON"),
        secs,
    )
}

fn check_pair(shared: &std::path::Path, name: &str) {
    let dir = shared.join("data/gd").join(name);
    let (gt_p, res_p) = (dir.join("Original.obj"), dir.join("Noisy.obj"));
    let (py, py_secs) = checker(shared, &gt_p, &res_p);
    let gt = read_mesh(&gt_p).unwrap();
    let res = read_mesh(&res_p).unwrap();
    let t = Instant::now();
    let m = compare(&gt, &res).unwrap();
    let rs_secs = t.elapsed().as_secs_f64();
    let pairs = [
        ("E_a_deg", m.e_a_deg),
        ("MSAE_rad2", m.msae_rad2),
        ("RMS_angle_deg", m.rms_angle_deg),
        ("median_angle_deg", m.median_angle_deg),
        ("max_angle_deg", m.max_angle_deg),
        ("frac_faces_over_30deg", m.frac_faces_over_30deg),
        ("E_v", m.e_v),
        ("E_v_over_avg_edge", m.e_v_over_le),
        ("E_v_over_bbox_diag", m.e_v_over_bbox_diag),
        ("mean_dist", m.mean_dist),
        ("max_dist_result_to_gt", m.max_dist_result_to_gt),
        ("max_dist_gt_to_result", m.max_dist_gt_to_result),
        ("hausdorff_vertices", m.hausdorff),
        ("gt_avg_edge_length", m.gt_mean_edge_length),
        ("gt_bbox_diag", m.gt_bbox_diag),
    ];
    let mut worst: f64 = 0.0;
    for (key, ours) in pairs {
        let theirs = py[key]
            .as_f64()
            .unwrap_or_else(|| panic!("checker has no {key}"));
        let rel = (ours - theirs).abs() / theirs.abs().max(1e-300);
        worst = worst.max(rel);
        eprintln!("{name:20} {key:24} rust {ours:.12e} python {theirs:.12e} rel {rel:.1e}");
        assert!(rel <= 1e-6, "{name} {key}: rust {ours} python {theirs}");
    }
    assert_eq!(
        m.degenerate_faces_result as u64,
        py["n_degenerate_faces_result"].as_u64().unwrap()
    );
    eprintln!(
        "{name}: worst relative difference {worst:.1e}; rust compare {rs_secs:.4} s, python checker {py_secs:.2} s (whole process)"
    );
}

#[test]
fn fandisk_and_twelve_match_the_python_checker() {
    let Some(s) = shared() else { return };
    if !python_ok() {
        return;
    }
    for name in ["Fandisk0.3", "Twelve0.5Impulsive"] {
        check_pair(&s, name);
    }
}

/// All eight pairs; slow-ish (the checker takes ~1–2 s each):
/// `cargo test -p normalnet-mesh --test metrics_checker -- --ignored --nocapture`.
#[test]
#[ignore]
fn all_gd_pairs_match_the_python_checker() {
    let Some(s) = shared() else { return };
    if !python_ok() {
        return;
    }
    for name in [
        "Block0.4",
        "Bunny0.2",
        "Fandisk0.3",
        "Fandisk0.7",
        "Julius0.2",
        "Nicolo0.2",
        "SharpSphere0.3",
        "Twelve0.5Impulsive",
    ] {
        check_pair(&s, name);
    }
}
