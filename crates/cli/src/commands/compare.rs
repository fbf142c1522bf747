//! `normalnet compare`: two bench runs of one suite side by side — per
//! group and over all pairs, the mean E_a of a method in each run, the
//! difference and who wins (`normalnet_bench::compare`).

use normalnet_bench::compare::{compare, read_results};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The base run: a `normalnet bench` output folder (or its results.json)
    pub base: PathBuf,
    /// The candidate run, of the same suite or models
    pub candidate: PathBuf,
    /// The candidate's method (column)
    #[arg(long, default_value = "normalnet")]
    pub method: String,
    /// The base's method (default: --method)
    #[arg(long)]
    pub base_method: Option<String>,
    /// Machine-readable output
    #[arg(long)]
    pub json: bool,
}

/// Runs `normalnet compare`.
pub fn run(args: Args, _quiet: bool) -> anyhow::Result<()> {
    let base = read_results(&args.base)?;
    let candidate = read_results(&args.candidate)?;
    let base_method = args.base_method.as_deref().unwrap_or(&args.method);
    let deltas = compare(&base, base_method, &candidate, &args.method)?;
    let wins = deltas.iter().filter(|d| d.wins()).count();
    let mut out = std::io::stdout().lock();
    if args.json {
        let groups: Vec<serde_json::Value> = deltas
            .iter()
            .map(|d| {
                serde_json::json!({
                    "group": d.group, "pairs": d.pairs, "base_deg": d.base,
                    "candidate_deg": d.candidate, "wins": d.wins(),
                })
            })
            .collect();
        let v = serde_json::json!({
            "base": args.base, "base_method": base_method,
            "candidate": args.candidate, "method": args.method,
            "groups": groups, "wins": wins, "of": deltas.len(),
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "E_a (deg), base {} ({base_method}) against candidate {} ({})",
        args.base.display(),
        args.candidate.display(),
        args.method
    )?;
    writeln!(
        out,
        "{:<14}{:>6}{:>10}{:>11}{:>8}",
        "group", "pairs", "base", "candidate", "diff"
    )?;
    for d in &deltas {
        writeln!(
            out,
            "{:<14}{:>6}{:>10.3}{:>11.3}{:>+8.3}  {}",
            d.group,
            d.pairs,
            d.base,
            d.candidate,
            d.candidate - d.base,
            if d.wins() { "wins" } else { "loses" }
        )?;
    }
    writeln!(
        out,
        "the candidate is lower on {wins} of {} (groups and all)",
        deltas.len()
    )?;
    Ok(())
}
