//! Fits the learned switch (`normalnet_net::switch_fit`) to rows dumped by
//! `switch_trace` and writes a `[switch]` table to append to a bundle's
//! `manifest.toml` (with `MIN_ITERATION` > 1 a `[switch.late]` table, to
//! append after the bundle's `[switch]` table).
//!
//! `cargo run --release -p normalnet-net --example switch_fit -- OUT.toml NOTES DATA.bin...`
//! (env `HIDDEN`, `EPOCHS`, `SEED`, `MAX_ITERATION`: the iteration
//! feature's clamp, 10; `MIN_ITERATION`: leave out the rows of earlier
//! iterations, 1 — a late table (`[switch.late]`) is fitted on the rows
//! after the main table's clamp).

use normalnet_net::switch::{CANDIDATES, SwitchWeights};
use normalnet_net::switch_fit::{FitParams, fit};
use normalnet_net::switch_rows::read_rows;

#[derive(serde::Serialize)]
struct Table {
    switch: SwitchWeights,
}

/// Written as `[switch.late]`.
#[derive(serde::Serialize)]
struct LateTable {
    switch: Late,
}

#[derive(serde::Serialize)]
struct Late {
    late: SwitchWeights,
}

fn env(name: &str, default: usize) -> usize {
    std::env::var(name).map_or(default, |v| v.parse().expect(name))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (out, notes, files) = (&args[1], &args[2], &args[3..]);
    let min_iteration = env("MIN_ITERATION", 1);
    let mut rows = Vec::new();
    for f in files {
        rows.extend(read_rows(std::path::Path::new(f), min_iteration)?);
    }
    let params = FitParams {
        hidden: env("HIDDEN", 32),
        epochs: env("EPOCHS", 40),
        seed: env("SEED", 1) as u64,
        max_iteration: env("MAX_ITERATION", 10),
        ..FitParams::default()
    };
    let t = std::time::Instant::now();
    let (mut weights, report) = fit(&rows, &[0, 1, 2, 3], &params)?;
    println!(
        "{} rows, {:.0} s; mean angle per candidate {:?}: {:.3?}, per-row best {:.3}",
        rows.len() / normalnet_net::switch_fit::ROW_LEN,
        t.elapsed().as_secs_f64(),
        CANDIDATES,
        report.candidate_mean_deg,
        report.best_mean_deg
    );
    println!("expected angle per epoch: {:.3?}", report.epoch_loss);
    weights.notes = notes.clone();
    let table = if min_iteration > 1 {
        toml::to_string(&LateTable {
            switch: Late { late: weights },
        })?
    } else {
        toml::to_string(&Table { switch: weights })?
    };
    std::fs::write(out, format!("\n{table}"))?;
    Ok(())
}
