//! Annotated pictures: a render with title lines and an error colour bar,
//! and a colour bar appended to a composed grid.

use crate::colormap::{ColourBar, draw_colour_bar};
use crate::error::RenderError;
use crate::font;
use crate::image::Image;
use crate::raster::{RenderOptions, render};
use normalnet_mesh::Mesh;

/// Padding in pixels around a colour bar.
const PAD: u32 = 12;

/// Draws `lines` top-left at `(x, y)`, one per row, in dark grey. Returns the height used.
pub fn draw_lines(image: &mut Image, x: i64, y: i64, lines: &[String], scale: u32) -> u32 {
    for (k, line) in lines.iter().enumerate() {
        image.draw_text(
            x,
            y + (k as u32 * font::LINE_HEIGHT * scale) as i64,
            line,
            scale,
            [20, 20, 20],
        );
    }
    lines.len() as u32 * font::LINE_HEIGHT * scale
}

/// Renders `mesh` into an image of exactly `options.width × options.height`
/// with `lines` of text at the top-left and, when `bar` is given, the colour
/// bar on the right (the mesh gets the remaining width).
pub fn render_annotated(
    mesh: &Mesh,
    options: &RenderOptions,
    lines: &[String],
    bar: Option<&ColourBar>,
) -> Result<Image, RenderError> {
    options.validate()?;
    let (w, h) = (options.width, options.height);
    let bar_w = bar.map(|b| b.size().0 + 2 * PAD).unwrap_or(0);
    if bar_w + 16 > w {
        return Err(RenderError::InvalidOption {
            name: "width",
            message: format!("{w} px leaves no room for the mesh next to a {bar_w} px colour bar"),
        });
    }
    let scale = (h / 300).clamp(1, 4);
    let text_h = lines.len() as u32 * font::LINE_HEIGHT * scale;
    let mesh_h = h.saturating_sub(text_h + PAD).max(16).min(h);
    let panel = render(
        mesh,
        &RenderOptions {
            width: w - bar_w,
            height: mesh_h,
            ..options.clone()
        },
    )?;
    let mut out = Image::new(w, h, options.background);
    out.blit(&panel, 0, (h - mesh_h) as i64);
    draw_lines(&mut out, PAD as i64 / 2, PAD as i64 / 2, lines, scale);
    if let Some(bar) = bar {
        let (_, bh) = bar.size();
        let y = (h as i64 - bh as i64) / 2;
        draw_colour_bar(&mut out, bar, (w - bar_w + PAD) as i64, y.max(0));
    }
    Ok(out)
}

/// `image` widened on the right by a colour bar (vertically centred), on white.
pub fn append_colour_bar(image: &Image, bar: &ColourBar) -> Image {
    let (bw, bh) = bar.size();
    let w = image.width() + bw + 2 * PAD;
    let h = image.height().max(bh + 2 * PAD);
    let mut out = Image::new(w, h, [255, 255, 255]);
    out.blit(image, 0, 0);
    draw_colour_bar(
        &mut out,
        bar,
        (image.width() + PAD) as i64,
        (h as i64 - bh as i64) / 2,
    );
    out
}

/// A titled picture of `mesh`; with `gt` (same faces), faces coloured by
/// their angular error against it (turbo, colour bar up to `max_error`
/// degrees or a rounded scale of the errors), `E_a` appended to the title,
/// and the camera framed on the ground truth so that pictures of several
/// results line up. What `normalnet render` and the Python `render` draw.
pub fn render_against_gt(
    mesh: &Mesh,
    gt: Option<&Mesh>,
    options: &RenderOptions,
    title: &str,
    max_error: Option<f64>,
) -> Result<Image, RenderError> {
    let mut options = options.clone();
    let mut lines = vec![title.to_string()];
    let mut bar = None;
    if let Some(gt) = gt {
        let errors = normalnet_mesh::metrics::per_face_angle_errors(gt, mesh)?;
        let e_a = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        let max = max_error.unwrap_or_else(|| crate::colormap::nice_error_scale(&errors));
        if !(max > 0.0 && max.is_finite()) {
            return Err(RenderError::InvalidOption {
                name: "max_error",
                message: format!("must be a positive number of degrees, got {max}"),
            });
        }
        options.face_colors = Some(crate::colormap::error_colors(&errors, max));
        options.bounds = Some(gt.bounding_box());
        lines[0] = format!("{title}   E_a = {e_a:.2} deg")
            .trim_start()
            .to_string();
        bar = Some(ColourBar::for_height(max, options.height, "error (deg)"));
    }
    render_annotated(mesh, &options, &lines, bar.as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> Mesh {
        Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap()
    }

    #[test]
    fn annotated_render_keeps_the_requested_size() {
        let bar = ColourBar::for_height(20.0, 300, "deg");
        let opts = RenderOptions {
            width: 400,
            height: 300,
            ..Default::default()
        };
        let img = render_annotated(&triangle(), &opts, &["title".into()], Some(&bar)).unwrap();
        assert_eq!((img.width(), img.height()), (400, 300));
        let e = render_annotated(
            &triangle(),
            &RenderOptions { width: 30, ..opts },
            &[],
            Some(&bar),
        );
        assert!(e.is_err());
    }

    #[test]
    fn appended_bar_widens_the_image() {
        let img = Image::new(100, 400, [0, 0, 0]);
        let bar = ColourBar::for_height(10.0, 400, "deg");
        let out = append_colour_bar(&img, &bar);
        assert!(out.width() > 100);
        assert_eq!(out.get(50, 50), Some([0, 0, 0]));
    }
}
