//! `normalnet metrics`: error metrics of a result against ground truth
//! (SPEC §3, `normalnet_mesh::metrics`, defined as the Python checker in
//! `shared/tools/eval/metrics.py`). The metrics compare face by face:
//! [`check_ground_truth`] refuses a pair with other face counts or a
//! degenerate ground truth, and warns about other face index lists, here
//! and in `normalnet denoise --gt` (before denoising).

use super::info::{format_for, parse_format};
use crate::input::read_mesh_as;
use crate::progress::Bar;
use anyhow::{Context, bail};
use normalnet_mesh::Mesh;
use normalnet_mesh::io::Format;
use normalnet_mesh::metrics::compare_with_progress;
use normalnet_mesh::validate::validate;
use std::io::Write;
use std::path::{Path, PathBuf};
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

/// Checks, before any work, that `gt` (read from `gt_path`) can be compared
/// with `mesh` (from `path`) face by face: the same face count, and a ground
/// truth that is not collapsed to a point (`l_e > 0`, else `E_v / l_e` is
/// undefined). Faces with other vertex indices (a flipped face, a
/// different triangulation) are allowed but warned about on stderr: the
/// normals are still compared face by face (`Metrics::faces_identical`,
/// `flipped_faces`).
///
/// # Errors
/// A message naming both files and what differs.
pub fn check_ground_truth(
    gt_path: &Path,
    gt: &Mesh,
    path: &Path,
    mesh: &Mesh,
) -> anyhow::Result<()> {
    if gt.num_faces() != mesh.num_faces() {
        bail!(
            "{}: face counts differ ({} faces, but {} has {}); metrics compare face by face",
            gt_path.display(),
            gt.num_faces(),
            path.display(),
            mesh.num_faces()
        );
    }
    let l_e = validate(gt).mean_edge_length;
    if l_e.is_nan() || l_e <= 0.0 {
        bail!(
            "{}: degenerate ground truth (mean edge length {l_e}: its faces are collapsed to \
             points), nothing to measure against",
            gt_path.display()
        );
    }
    if let Some(f) = (0..gt.num_faces()).find(|&f| gt.faces[f] != mesh.faces[f]) {
        let others = (f..gt.num_faces())
            .filter(|&g| gt.faces[g] != mesh.faces[g])
            .count();
        stderr_line!(
            "warning: {}: face {f} has vertices {:?}, but {} has {:?} ({others} faces differ); \
             same face count but different face index lists: normals compared face by face",
            gt_path.display(),
            gt.faces[f],
            path.display(),
            mesh.faces[f]
        );
    }
    Ok(())
}

/// Runs `normalnet metrics`.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let t = Instant::now();
    let gt = read_mesh_as(&args.gt, format_for(&args.gt, args.format)?)
        .with_context(|| format!("reading {}", args.gt.display()))?;
    let result = read_mesh_as(&args.result, format_for(&args.result, args.format)?)
        .with_context(|| format!("reading {}", args.result.display()))?;
    check_ground_truth(&args.gt, &gt, &args.result, &result)?;
    let t_metrics = Instant::now();
    let m = compare_with_progress(&gt, &result, &Bar::new(quiet)).with_context(|| {
        format!(
            "comparing {} with {}",
            args.result.display(),
            args.gt.display()
        )
    })?;
    let metrics_seconds = t_metrics.elapsed().as_secs_f64();
    let mut out = std::io::stdout().lock();
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
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "ground truth  {} ({} vertices, {} faces)",
        args.gt.display(),
        m.n_vertices_gt,
        m.n_faces_gt
    )?;
    writeln!(
        out,
        "result        {} ({} vertices, {} faces)",
        args.result.display(),
        m.n_vertices_result,
        m.n_faces_result
    )?;
    writeln!(out, "  E_a (mean normal angle)      {:.4} deg", m.e_a_deg)?;
    writeln!(
        out,
        "  RMS / median / max angle     {:.4} / {:.4} / {:.4} deg",
        m.rms_angle_deg, m.median_angle_deg, m.max_angle_deg
    )?;
    writeln!(
        out,
        "  MSAE                         {:.6e} rad^2",
        m.msae_rad2
    )?;
    writeln!(
        out,
        "  faces over 30 deg            {:.4} %",
        100.0 * m.frac_faces_over_30deg
    )?;
    writeln!(out, "  E_v                          {:.6e}", m.e_v)?;
    writeln!(
        out,
        "  E_v / l_e(GT)                {:.6}   (l_e = {:.6e})",
        m.e_v_over_le, m.gt_mean_edge_length
    )?;
    writeln!(
        out,
        "  E_v / bbox diagonal(GT)      {:.6e}",
        m.e_v_over_bbox_diag
    )?;
    writeln!(out, "  mean distance                {:.6e}", m.mean_dist)?;
    writeln!(
        out,
        "  max distance result -> GT    {:.6e}",
        m.max_dist_result_to_gt
    )?;
    writeln!(
        out,
        "  max distance GT -> result    {:.6e}",
        m.max_dist_gt_to_result
    )?;
    writeln!(out, "  Hausdorff (vertex-sampled)   {:.6e}", m.hausdorff)?;
    writeln!(
        out,
        "  degenerate result faces      {}",
        m.degenerate_faces_result
    )?;
    writeln!(out, "  flipped faces (n_r.n_g < 0)  {}", m.flipped_faces)?;
    writeln!(
        out,
        "  time                         {:.3} s metrics, {:.3} s total",
        metrics_seconds,
        t.elapsed().as_secs_f64()
    )?;
    Ok(())
}
