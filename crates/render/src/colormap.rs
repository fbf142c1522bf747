//! Error colouring: the turbo colormap (Mikhailov 2019, "Turbo, an improved
//! rainbow colormap for visualization", Google AI blog; here its published
//! degree-5 polynomial fit), per-face colours from angular errors, and a
//! labelled vertical colour bar drawn with the built-in font.
//!
//! Turbo keeps the rainbow's contrast but is close to perceptually uniform
//! and has no false bands, so "blue = small error, red = large" reads right.

use crate::font;
use crate::image::Image;

/// The turbo colour at `t` in `[0, 1]` (clamped; NaN maps to the top colour).
pub fn turbo(t: f64) -> [u8; 3] {
    let x = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    let r = 0.13572138
        + x * (4.61539260
            + x * (-42.66032258 + x * (132.13108234 + x * (-152.94239396 + x * 59.28637943))));
    let g = 0.09140261
        + x * (2.19418839
            + x * (4.84296658 + x * (-14.18503333 + x * (4.27729857 + x * 2.82956604))));
    let b = 0.10667330
        + x * (12.64194608
            + x * (-60.58204836 + x * (110.36276771 + x * (-89.90310912 + x * 27.34824973))));
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    [q(r), q(g), q(b)]
}

/// Part of turbo used for errors: its near-black start and darkest red end
/// are cut so small errors read as blue and shading stays visible.
const ERROR_RANGE: (f64, f64) = (0.1, 0.95);

/// The error-map colour of `t` in `[0, 1]` (0 = no error, blue; 1 = the
/// top of the scale, red); clamped, NaN gives the top colour.
pub fn error_colour(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    turbo(ERROR_RANGE.0 + (ERROR_RANGE.1 - ERROR_RANGE.0) * t)
}

/// One colour per face (len #F) for per-face angular errors in degrees: 0° is
/// the bottom of the map, `max_deg` and above the top. A non-finite error or
/// a non-positive `max_deg` gives the top colour (it is reported, not hidden).
pub fn error_colors(per_face_deg: &[f64], max_deg: f64) -> Vec<[u8; 3]> {
    per_face_deg
        .iter()
        .map(|&e| {
            if max_deg.is_nan() || max_deg <= 0.0 || !e.is_finite() {
                error_colour(1.0)
            } else {
                error_colour(e / max_deg)
            }
        })
        .collect()
}

/// A round top for an error scale: the 95th percentile of the finite errors
/// rounded up to 1, 2, 5, 10, 15, 20, 30, 45, 60 or 90 degrees (1 when there
/// are no errors), so one outlier does not wash the picture out.
pub fn nice_error_scale(per_face_deg: &[f64]) -> f64 {
    let mut v: Vec<f64> = per_face_deg
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(f64::total_cmp);
    let p95 = v[((v.len() - 1) as f64 * 0.95).round() as usize];
    [1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0]
        .into_iter()
        .find(|&s| p95 <= s)
        .unwrap_or(180.0)
}

/// A number of ticks (3–6) whose spacing is a whole number, else a multiple
/// of 0.5, else 5: 15 → 4 (0, 5, 10, 15), 10 → 6, 20 → 5, 1 → 3.
pub fn round_tick_count(max_value: f64) -> usize {
    let fits = |n: usize, unit: f64| {
        let step = max_value / (n - 1) as f64 / unit;
        step > 0.0 && (step - step.round()).abs() < 1e-9
    };
    [1.0, 0.5]
        .iter()
        .find_map(|&unit| [5, 4, 6, 3].into_iter().find(|&n| fits(n, unit)))
        .unwrap_or(5)
}

/// A vertical colour bar from 0 (bottom) to `max_value` (top) with evenly
/// spaced tick labels on its right and a title above.
#[derive(Clone, Debug)]
pub struct ColourBar {
    /// the value at the top of the bar (e.g. degrees)
    pub max_value: f64,
    /// number of tick labels including 0 and `max_value` (at least 2)
    pub ticks: usize,
    /// text above the bar (e.g. "error (deg)")
    pub title: String,
    /// gradient width in pixels
    pub bar_width: u32,
    /// gradient height in pixels
    pub bar_height: u32,
    /// font scale for the labels
    pub text_scale: u32,
    /// colour of labels and outline
    pub text_colour: [u8; 3],
}

impl ColourBar {
    /// A bar sized for an image of height `image_height`.
    pub fn for_height(max_value: f64, image_height: u32, title: &str) -> ColourBar {
        let text_scale = (image_height / 300).clamp(1, 4);
        ColourBar {
            max_value,
            ticks: round_tick_count(max_value),
            title: title.to_string(),
            bar_width: 6 * text_scale + 8,
            bar_height: (image_height as f64 * 0.6) as u32,
            text_scale,
            text_colour: [20, 20, 20],
        }
    }

    /// Tick labels, bottom to top. Degrees get a `°` on the top label.
    pub fn tick_labels(&self) -> Vec<String> {
        let n = self.ticks.max(2);
        let values: Vec<f64> = (0..n)
            .map(|i| self.max_value * i as f64 / (n - 1) as f64)
            .collect();
        let integral = values.iter().all(|v| (v - v.round()).abs() < 1e-9);
        values
            .iter()
            .map(|v| {
                if integral {
                    format!("{v:.0}")
                } else {
                    format!("{v:.1}")
                }
            })
            .collect()
    }

    /// `(width, height)` in pixels of the whole bar with labels and title.
    pub fn size(&self) -> (u32, u32) {
        let s = self.text_scale;
        let label_w = self
            .tick_labels()
            .iter()
            .map(|l| font::text_width(l, s))
            .max()
            .unwrap_or(0);
        let w = (self.bar_width + 3 * s + label_w).max(font::text_width(&self.title, s));
        let h = self.bar_height + font::text_height(s) * 2 + 4 * s;
        (w, h)
    }
}

/// Draws `bar` with its top-left corner at `(x, y)` (title first, gradient
/// below, labels on the right). Returns the `(width, height)` used.
pub fn draw_colour_bar(image: &mut Image, bar: &ColourBar, x: i64, y: i64) -> (u32, u32) {
    let s = bar.text_scale.max(1);
    image.draw_text(x, y, &bar.title, s, bar.text_colour);
    let top = y + (font::text_height(s) + 3 * s + font::text_height(s) / 2) as i64;
    let h = bar.bar_height.max(2) as i64;
    for row in 0..h {
        let t = 1.0 - row as f64 / (h - 1) as f64;
        image.fill_rect(x, top + row, bar.bar_width as i64, 1, error_colour(t));
    }
    image.stroke_rect(
        x - 1,
        top - 1,
        bar.bar_width as i64 + 2,
        h + 2,
        bar.text_colour,
    );
    let labels = bar.tick_labels();
    let n = labels.len();
    for (i, label) in labels.iter().enumerate() {
        let ty = top + h - 1 - ((h - 1) * i as i64) / (n as i64 - 1);
        let lx = x + bar.bar_width as i64 + 1;
        image.fill_rect(lx, ty, 2 * s as i64, 1, bar.text_colour);
        image.draw_text(
            lx + 3 * s as i64,
            ty - font::text_height(s) as i64 / 2,
            label,
            s,
            bar.text_colour,
        );
    }
    bar.size()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_colours_run_from_blue_to_red() {
        let lo = error_colour(0.0);
        let hi = error_colour(1.0);
        assert!(lo[2] > lo[0], "{lo:?}");
        assert!(hi[0] > hi[2] && hi[0] > 100, "{hi:?}");
        // the middle is bright green-yellow
        let mid = error_colour(0.5);
        assert!(mid[1] > 180, "{mid:?}");
    }

    #[test]
    fn error_colors_clamp_and_flag_bad_values() {
        let c = error_colors(&[0.0, 5.0, 10.0, 50.0, f64::NAN], 10.0);
        assert_eq!(c.len(), 5);
        assert_eq!(c[0], error_colour(0.0));
        assert_eq!(c[1], error_colour(0.5));
        assert_eq!(c[2], error_colour(1.0));
        assert_eq!(c[3], error_colour(1.0));
        assert_eq!(c[4], error_colour(1.0));
        assert_ne!(c[0], c[2]);
        assert!(
            error_colors(&[1.0], 0.0)
                .iter()
                .all(|&x| x == error_colour(1.0))
        );
    }

    #[test]
    fn error_scale_rounds_the_95th_percentile_up() {
        let mut e: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect(); // 0..9.9
        assert_eq!(nice_error_scale(&e), 10.0);
        e.push(f64::NAN);
        e.push(170.0);
        assert_eq!(nice_error_scale(&e), 10.0);
        assert_eq!(nice_error_scale(&[]), 1.0);
        assert_eq!(nice_error_scale(&[25.0; 10]), 30.0);
    }

    #[test]
    fn tick_counts_give_round_steps() {
        let labels = |m: f64| ColourBar::for_height(m, 400, "").tick_labels();
        assert_eq!(labels(15.0), vec!["0", "5", "10", "15"]);
        assert_eq!(labels(30.0), vec!["0", "10", "20", "30"]);
        assert_eq!(labels(10.0), vec!["0", "2", "4", "6", "8", "10"]);
        assert_eq!(labels(20.0), vec!["0", "5", "10", "15", "20"]);
        assert_eq!(labels(1.0), vec!["0.0", "0.5", "1.0"]);
        assert_eq!(labels(90.0), vec!["0", "30", "60", "90"]);
    }

    #[test]
    fn tick_labels_are_even() {
        let bar = ColourBar {
            ticks: 5,
            ..ColourBar::for_height(30.0, 400, "deg")
        };
        assert_eq!(
            bar.tick_labels(),
            vec!["0.0", "7.5", "15.0", "22.5", "30.0"]
        );
        let bar = ColourBar { ticks: 4, ..bar };
        assert_eq!(bar.tick_labels(), vec!["0", "10", "20", "30"]);
    }

    #[test]
    fn colour_bar_draws_gradient_inside_its_size() {
        let bar = ColourBar::for_height(20.0, 400, "E_a");
        let (w, h) = bar.size();
        let mut img = Image::new(w + 20, h + 20, [255, 255, 255]);
        draw_colour_bar(&mut img, &bar, 10, 10);
        // every non-background pixel lies inside the reported box
        for y in 0..img.height() {
            for x in 0..img.width() {
                if img.get(x, y) != Some([255, 255, 255]) {
                    assert!(
                        x >= 9 && x < 11 + w && y >= 9 && y < 11 + h,
                        "ink at {x},{y}"
                    );
                }
            }
        }
        // the gradient's top is the top colour, its bottom the bottom colour
        let (gx, _) = (10 + bar.bar_width / 2, 0);
        let column: Vec<[u8; 3]> = (0..img.height()).filter_map(|y| img.get(gx, y)).collect();
        assert!(column.contains(&error_colour(1.0)));
        assert!(column.contains(&error_colour(0.0)));
    }
}
