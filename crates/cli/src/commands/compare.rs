//! `normalnet compare`: two bench runs of one suite side by side — per
//! group and over all pairs, the mean E_a of a method in each run, the
//! difference, who wins and on how many pairs; then the pairs the candidate
//! loses by more than a margin (`normalnet_bench::compare`).

use normalnet_bench::compare::{compare, pair_deltas, read_results};
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
    /// List the pairs the candidate is higher on by more than this many
    /// degrees (a group's mean can hide them)
    #[arg(long, default_value_t = 0.5)]
    pub worse_than: f64,
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
    if !(args.worse_than.is_finite() && args.worse_than >= 0.0) {
        anyhow::bail!(
            "--worse-than {}: give a margin of at least 0 degrees",
            args.worse_than
        );
    }
    let mut worse = pair_deltas(&base, base_method, &candidate, &args.method)?;
    worse.retain(|p| p.loss() > args.worse_than);
    worse.sort_by(|a, b| b.loss().total_cmp(&a.loss()));
    let mut out = std::io::stdout().lock();
    if args.json {
        let groups: Vec<serde_json::Value> = deltas
            .iter()
            .map(|d| {
                serde_json::json!({
                    "group": d.group, "pairs": d.pairs, "base_deg": d.base,
                    "candidate_deg": d.candidate, "wins": d.wins(),
                    "pairs_lower": d.pairs_lower,
                })
            })
            .collect();
        let v = serde_json::json!({
            "base": args.base, "base_method": base_method,
            "candidate": args.candidate, "method": args.method,
            "groups": groups, "wins": wins, "of": deltas.len(),
            "worse_than_deg": args.worse_than,
            "worse": worse.iter().map(|p| serde_json::json!({
                "model": p.model, "base_deg": p.base, "candidate_deg": p.candidate,
            })).collect::<Vec<_>>(),
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
        "{:<14}{:>6}{:>10}{:>11}{:>8}  {:<6} lower on",
        "group", "pairs", "base", "candidate", "diff", ""
    )?;
    for d in &deltas {
        writeln!(
            out,
            "{:<14}{:>6}{:>10.3}{:>11.3}{:>+8.3}  {:<6} {} of {} pairs",
            d.group,
            d.pairs,
            d.base,
            d.candidate,
            d.candidate - d.base,
            if d.wins() { "wins" } else { "loses" },
            d.pairs_lower,
            d.pairs
        )?;
    }
    writeln!(
        out,
        "the candidate is lower on {wins} of {} (groups and all)",
        deltas.len()
    )?;
    if worse.is_empty() {
        writeln!(
            out,
            "no pair is higher by more than {:.2} deg",
            args.worse_than
        )?;
    } else {
        writeln!(
            out,
            "{} pairs higher by more than {:.2} deg:",
            worse.len(),
            args.worse_than
        )?;
        for p in &worse {
            writeln!(
                out,
                "  {:<34}{:>8.3}{:>9.3}{:>+8.3}",
                p.model,
                p.base,
                p.candidate,
                p.loss()
            )?;
        }
    }
    Ok(())
}
