//! One picture per model: the noisy input, every method and the ground
//! truth side by side, faces coloured by their angle to the ground truth.

use anyhow::Context;
use normalnet_mesh::metrics::per_face_angle_errors;
use normalnet_mesh::{Mesh, read_mesh};
use normalnet_render::report::{BenchReport, NOISY};
use normalnet_render::{
    ColourBar, Image, RenderOptions, append_colour_bar, compose_grid, draw_lines, error_colors,
    nice_error_scale, render,
};
use std::path::Path;

/// One panel of a model's picture.
pub(crate) struct Panel {
    label: String,
    mesh: Mesh,
    errors: Option<Vec<f64>>,
    /// E_a of a ranked method's result (chooses the colour scale)
    ranked_e_a: Option<f64>,
}

/// Renders the panels of one model side by side with a shared camera (the
/// ground truth's box) and error scale, a title and a colour bar.
pub(crate) fn model_picture(
    model: &str,
    panels: &[Panel],
    gt: &Mesh,
    panel_size: (u32, u32),
    view: (f64, f64),
) -> anyhow::Result<Image> {
    // the scale fits the best ranked method (95th percentile of its errors,
    // rounded up), so differences between good results stay visible; worse
    // results and the noisy input saturate towards red
    let best = panels
        .iter()
        .filter(|p| p.errors.is_some() && p.ranked_e_a.is_some())
        .min_by(|a, b| {
            a.ranked_e_a
                .partial_cmp(&b.ranked_e_a)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    let max = match best.and_then(|p| p.errors.as_ref()) {
        Some(errors) => nice_error_scale(errors),
        None => {
            let all: Vec<f64> = panels
                .iter()
                .filter_map(|p| p.errors.as_ref())
                .flatten()
                .copied()
                .collect();
            nice_error_scale(&all)
        }
    };
    let base = RenderOptions {
        width: panel_size.0,
        height: panel_size.1,
        azimuth_deg: view.0,
        elevation_deg: view.1,
        supersample: 2,
        bounds: Some(gt.bounding_box()),
        ..Default::default()
    };
    let mut images = Vec::with_capacity(panels.len());
    let mut labels = Vec::with_capacity(panels.len());
    for p in panels {
        let options = RenderOptions {
            face_colors: p.errors.as_ref().map(|e| error_colors(e, max)),
            ..base.clone()
        };
        images.push(
            render(&p.mesh, &options).with_context(|| format!("rendering {model} {}", p.label))?,
        );
        labels.push(p.label.clone());
    }
    let cols = if images.len() <= 4 {
        images.len()
    } else {
        images.len().div_ceil(2)
    };
    let grid = compose_grid(&images, cols, &labels);
    let bar = ColourBar::for_height(max, grid.height().min(2 * panel_size.1), "error (deg)");
    let body = append_colour_bar(&grid, &bar);
    let scale = (body.width() / 600).clamp(1, 3);
    let title_h = 8 * scale + 24;
    let mut out = Image::new(body.width(), body.height() + title_h, [255, 255, 255]);
    draw_lines(
        &mut out,
        8,
        8,
        &[format!(
            "{model}: faces coloured by angle to ground-truth normals"
        )],
        scale,
    );
    out.blit(&body, 0, title_h as i64);
    Ok(out)
}

/// A finished run kept for the picture.
pub(crate) struct Finished {
    pub(crate) method: String,
    pub(crate) mesh: Mesh,
    pub(crate) e_a: f64,
}

/// The picture panels of one model: noisy, each method in column order (this
/// run's results, or with `--merge` the saved mesh of an earlier run), ground truth.
pub(crate) fn panels_for(
    model: &str,
    noisy: &Mesh,
    gt: &Mesh,
    finished: Vec<Finished>,
    report: &BenchReport,
    out: &Path,
) -> Vec<Panel> {
    let errors = |mesh: &Mesh| per_face_angle_errors(gt, mesh).ok();
    let mut panels = Vec::new();
    if let Some(r) = report
        .records
        .iter()
        .find(|r| r.model == model && r.method == NOISY)
        && let Some(e_a) = r.e_a_deg
    {
        panels.push(Panel {
            label: format!("{NOISY}\nE_a {e_a:.2} deg"),
            errors: errors(noisy),
            mesh: noisy.clone(),
            ranked_e_a: None,
        });
    }
    let mut finished: Vec<Option<Finished>> = finished.into_iter().map(Some).collect();
    for method in report.methods.iter().filter(|m| *m != NOISY) {
        let ranked = !report.unranked.contains(method);
        let this_run = finished
            .iter_mut()
            .find(|f| f.as_ref().is_some_and(|f| &f.method == method))
            .and_then(Option::take);
        let (mesh, e_a) = match this_run {
            Some(f) => (f.mesh, f.e_a),
            None => {
                // an earlier run's result, when it was saved with --save-meshes
                let Some(e_a) = report
                    .records
                    .iter()
                    .find(|r| r.model == model && &r.method == method && r.error.is_none())
                    .and_then(|r| r.e_a_deg)
                else {
                    continue;
                };
                match read_mesh(out.join(model).join(format!("{method}.obj"))) {
                    Ok(mesh) if mesh.faces == gt.faces => (mesh, e_a),
                    _ => continue,
                }
            }
        };
        panels.push(Panel {
            label: format!("{method}\nE_a {e_a:.2} deg"),
            errors: errors(&mesh),
            mesh,
            ranked_e_a: ranked.then_some(e_a),
        });
    }
    panels.push(Panel {
        label: "ground truth\n ".into(),
        mesh: gt.clone(),
        errors: None,
        ranked_e_a: None,
    });
    panels
}
