//! Research tool for the learned switch (`normalnet_net::switch`): runs the
//! NormalNet pipeline on a noisy/clean pair along one path
//! (`normalnet_net::switch_rows::trace`) and prints E_a after each
//! iteration and how often each candidate had the largest weight. Recipes
//! (`normalnet train --recipe`, stage `switch_rows`) collect the rows the
//! switch is fitted on through the same function.
//!
//! `switch_trace MODE NOISY GT [ITERATIONS] [OUT|SWITCH.toml]`, MODE:
//! - `paper` / `guided` / `gnf`: always that candidate
//! - `oracle`: per face the candidate closest to the ground truth (a ceiling)
//! - `dump OUT`: the paper's path; appends the rows to OUT (the input of
//!   `switch_fit`)
//! - `learned SWITCH.toml`: the switch of that file's `[switch]` table
//!   (env `DUMP=OUT` also appends rows along its path)
//!
//! Env: `INT8=1` residual blocks in 8-bit integers; `MU_G=X` (0.35), `NV=N`
//! (20), `FLAT=DEG` (0: off), `AUTO_STOP=DEG` (0: every iteration),
//! `NORMALNET_MODEL=DIR` (a bundle; else the shipped one).

use normalnet_mesh::read_mesh;
use normalnet_net::switch::SwitchWeights;
use normalnet_net::switch_rows::{TracePath, TraceSettings, append_rows, trace};

#[derive(serde::Deserialize)]
struct Table {
    switch: SwitchWeights,
}

fn env(name: &str, default: f64) -> f64 {
    std::env::var(name).map_or(default, |s| s.parse().expect(name))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args[1].as_str();
    let noisy = read_mesh(&args[2])?;
    let gt = read_mesh(&args[3])?;
    let iterations: usize = args.get(4).map_or(Ok(10), |s| s.parse())?;
    let extra = args.get(5).cloned();
    let path = match mode {
        "paper" | "dump" => TracePath::Candidate(0),
        "guided" => TracePath::Candidate(1),
        "gnf" => TracePath::Candidate(2),
        "oracle" => TracePath::Oracle,
        "learned" => {
            let text = std::fs::read_to_string(extra.as_deref().ok_or("SWITCH.toml")?)?;
            TracePath::Learned(toml::from_str::<Table>(&text)?.switch)
        }
        _ => return Err(format!("unknown mode {mode}").into()),
    };
    let dump = match mode {
        "dump" => extra,
        _ => std::env::var("DUMP").ok(),
    };
    let mut bundle = match std::env::var_os("NORMALNET_MODEL") {
        Some(p) => normalnet_net::Bundle::load(p)?,
        None => normalnet_net::embedded::lite()?,
    };
    if std::env::var_os("INT8").is_some() {
        let got = bundle.set_arithmetic(normalnet_cnn::Arithmetic::INT8_BLOCKS);
        eprintln!("arithmetic: {got:?}");
    }
    let settings = TraceSettings {
        iterations,
        mu_g: env("MU_G", 0.35),
        vertex_iterations: env("NV", 20.0) as usize,
        flat_skip_deg: env("FLAT", 0.0),
        auto_stop_deg: env("AUTO_STOP", 0.0),
        ..TraceSettings::default()
    };
    let t = trace(&bundle, &noisy, &gt, &path, &settings)?;
    if let Some(file) = dump {
        append_rows(std::path::Path::new(&file), &t.rows)?;
    }
    let e_a: Vec<String> = t.e_a_deg.iter().map(|e| format!("{e:.3}")).collect();
    println!("{mode}: {}  chosen {:?}", e_a.join(" "), t.chosen);
    Ok(())
}
