//! `normalnet compare` on two hand-written bench results: the group table,
//! the pairs lost, the JSON, and a clear error for a pair the candidate
//! lacks.

mod common;

use common::{normalnet, s, stderr};

fn results(dir: &std::path::Path, name: &str, e: &[(&str, f64)]) -> std::path::PathBuf {
    let records: Vec<serde_json::Value> = e
        .iter()
        .map(|(m, v)| serde_json::json!({"model": m, "method": "normalnet", "e_a_deg": v}))
        .collect();
    let report = serde_json::json!({
        "models": e.iter().map(|(m, _)| m).collect::<Vec<_>>(),
        "records": records,
        "groups": [{"name": "mild", "models": ["a", "b"]}],
    });
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("results.json"), report.to_string()).unwrap();
    out
}

#[test]
fn compare_prints_per_group_means_and_who_wins() {
    let dir = tempfile::tempdir().unwrap();
    let base = results(dir.path(), "base", &[("a", 1.0), ("b", 3.0), ("c", 8.0)]);
    let cand = results(dir.path(), "cand", &[("a", 1.5), ("b", 1.5), ("c", 9.5)]);
    let o = normalnet(&["compare", s(&base), s(&cand)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("mild               2     2.000      1.500  -0.500  wins"),
        "{text}"
    );
    assert!(
        text.contains("all                3     4.000      4.167  +0.167  loses"),
        "{text}"
    );
    assert!(text.contains("lower on 1 of 2"), "{text}");
    // per group the pairs it is lower on; the pairs it loses by more than
    // the margin (0.5° by default): the mild mean wins while a loses 0.5°
    assert!(text.contains("wins   1 of 2 pairs"), "{text}");
    assert!(
        text.contains("1 pairs higher by more than 0.50 deg"),
        "{text}"
    );
    assert!(text.contains("  c "), "{text}");
    let o = normalnet(&["compare", s(&base), s(&cand), "--worse-than", "0.4"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("2 pairs higher by more than 0.40 deg"),
        "{text}"
    );
    let o = normalnet(&["compare", s(&base), s(&cand), "--worse-than=-1"]);
    assert!(!o.status.success() && stderr(&o).contains("--worse-than"));
    let o = normalnet(&["compare", s(&base), s(&cand), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["wins"], 1);
    assert_eq!(v["groups"][0]["group"], "mild");
    assert_eq!(v["groups"][0]["pairs_lower"], 1);
    assert_eq!(v["worse"][0]["model"], "c");
    // a pair the candidate lacks
    let short = results(dir.path(), "short", &[("a", 1.0), ("b", 1.0)]);
    let o = normalnet(&["compare", s(&base), s(&short)]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("candidate run has no E_a of normalnet on c"),
        "{}",
        stderr(&o)
    );
}
