//! `normalnet metrics`: error metrics of a result against ground truth
//! (SPEC §3, `normalnet_mesh::metrics`, defined as the Python checker in
//! `shared/tools/eval/metrics.py`).

use super::info::{format_for, parse_format};
use crate::input::read_mesh_as;
use crate::progress::Bar;
use anyhow::Context;
use normalnet_mesh::io::Format;
use normalnet_mesh::metrics::compare_with_progress;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `normalnet metrics`.
#[derive(clap::Args)]
pub struct Args {
    /// Ground-truth (clean) mesh.
    pub gt: PathBuf,
    /// Result mesh (same faces in the same order).
    pub result: PathBuf,
    /// Print JSON (snake_case keys) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Read both meshes as this format whatever the extensions.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<Format>,
}

/// Runs `normalnet metrics`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let t = Instant::now();
    let gt = read_mesh_as(&args.gt, format_for(&args.gt, args.format)?)
        .with_context(|| format!("reading {}", args.gt.display()))?;
    let result = read_mesh_as(&args.result, format_for(&args.result, args.format)?)
        .with_context(|| format!("reading {}", args.result.display()))?;
    let t_metrics = Instant::now();
    let m = compare_with_progress(&gt, &result, &Bar::new(quiet)).with_context(|| {
        format!(
            "comparing {} with {}",
            args.result.display(),
            args.gt.display()
        )
    })?;
    let metrics_seconds = t_metrics.elapsed().as_secs_f64();
    if args.json {
        let mut v = serde_json::to_value(&m)?;
        if let Some(o) = v.as_object_mut() {
            o.insert("gt".into(), serde_json::json!(args.gt));
            o.insert("result".into(), serde_json::json!(args.result));
            o.insert("metrics_seconds".into(), serde_json::json!(metrics_seconds));
            o.insert(
                "seconds".into(),
                serde_json::json!(t.elapsed().as_secs_f64()),
            );
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "ground truth  {} ({} vertices, {} faces)",
        args.gt.display(),
        m.n_vertices_gt,
        m.n_faces_gt
    );
    println!(
        "result        {} ({} vertices, {} faces)",
        args.result.display(),
        m.n_vertices_result,
        m.n_faces_result
    );
    if !m.faces_identical {
        println!(
            "warning: same face count but different face index lists; normals compared face by face"
        );
    }
    println!("  E_a (mean normal angle)      {:.4} deg", m.e_a_deg);
    println!(
        "  RMS / median / max angle     {:.4} / {:.4} / {:.4} deg",
        m.rms_angle_deg, m.median_angle_deg, m.max_angle_deg
    );
    println!("  MSAE                         {:.6e} rad^2", m.msae_rad2);
    println!(
        "  faces over 30 deg            {:.4} %",
        100.0 * m.frac_faces_over_30deg
    );
    println!("  E_v                          {:.6e}", m.e_v);
    println!(
        "  E_v / l_e(GT)                {:.6}   (l_e = {:.6e})",
        m.e_v_over_le, m.gt_mean_edge_length
    );
    println!(
        "  E_v / bbox diagonal(GT)      {:.6e}",
        m.e_v_over_bbox_diag
    );
    println!("  mean distance                {:.6e}", m.mean_dist);
    println!(
        "  max distance result -> GT    {:.6e}",
        m.max_dist_result_to_gt
    );
    println!(
        "  max distance GT -> result    {:.6e}",
        m.max_dist_gt_to_result
    );
    println!("  Hausdorff (vertex-sampled)   {:.6e}", m.hausdorff);
    println!(
        "  degenerate result faces      {}",
        m.degenerate_faces_result
    );
    println!("  flipped faces (n_r.n_g < 0)  {}", m.flipped_faces);
    println!(
        "  time                         {:.3} s metrics, {:.3} s total",
        metrics_seconds,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
