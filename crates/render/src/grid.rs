//! Side-by-side panels: images in a grid, each with a caption above it.

use crate::font;
use crate::image::Image;

/// Pixels between panels and around the grid.
const GAP: u32 = 8;

/// Places `images` left to right, top to bottom, `cols` per row, on a white
/// background. Each cell is as large as the largest image; `labels[i]`
/// (may hold several lines separated by `\n`; missing labels are blank) is
/// drawn centred above image `i` with a font scale that suits the cell.
/// An empty `images` gives a 1×1 white image.
pub fn compose_grid(images: &[Image], cols: usize, labels: &[String]) -> Image {
    let white = [255, 255, 255];
    if images.is_empty() {
        return Image::new(1, 1, white);
    }
    let cols = cols.clamp(1, images.len());
    let rows = images.len().div_ceil(cols);
    let cell_w = images.iter().map(|i| i.width()).max().unwrap_or(1);
    let cell_h = images.iter().map(|i| i.height()).max().unwrap_or(1);
    let scale = (cell_w / 200).clamp(1, 4);
    let lines = labels.iter().map(|l| l.lines().count()).max().unwrap_or(0) as u32;
    let caption_h = if lines == 0 {
        0
    } else {
        lines * font::LINE_HEIGHT * scale + GAP
    };
    let width = cols as u32 * (cell_w + GAP) + GAP;
    let height = rows as u32 * (cell_h + caption_h + GAP) + GAP;
    let mut out = Image::new(width, height, white);
    for (i, img) in images.iter().enumerate() {
        let (r, c) = ((i / cols) as u32, (i % cols) as u32);
        let x = GAP + c * (cell_w + GAP);
        let y = GAP + r * (cell_h + caption_h + GAP);
        if let Some(label) = labels.get(i) {
            for (k, line) in label.lines().enumerate() {
                let tw = font::text_width(line, scale);
                let tx = x as i64 + (cell_w as i64 - tw as i64) / 2;
                let ty = y as i64 + (k as u32 * font::LINE_HEIGHT * scale) as i64;
                out.draw_text(tx.max(x as i64), ty, line, scale, [20, 20, 20]);
            }
        }
        let ox = x + (cell_w - img.width()) / 2;
        let oy = y + caption_h + (cell_h - img.height()) / 2;
        out.blit(img, ox as i64, oy as i64);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_places_images_in_rows_and_columns() {
        let red = Image::new(10, 6, [255, 0, 0]);
        let blue = Image::new(10, 6, [0, 0, 255]);
        let g = compose_grid(&[red.clone(), blue.clone(), red], 2, &[]);
        assert_eq!(g.width(), 2 * (10 + GAP) + GAP);
        assert_eq!(g.height(), 2 * (6 + GAP) + GAP);
        assert_eq!(g.get(GAP, GAP), Some([255, 0, 0]));
        assert_eq!(g.get(2 * GAP + 10, GAP), Some([0, 0, 255]));
        assert_eq!(g.get(GAP, 2 * GAP + 6), Some([255, 0, 0]));
        assert_eq!(g.get(2 * GAP + 10, 2 * GAP + 6), Some([255, 255, 255]));
    }

    #[test]
    fn labels_get_a_caption_strip() {
        let img = Image::new(40, 20, [0, 200, 0]);
        let g = compose_grid(&[img], 1, &["GNF\nE_a 3.1".to_string()]);
        assert_eq!(g.height(), 20 + 2 * font::LINE_HEIGHT + GAP + 2 * GAP);
        // some dark caption ink above the image
        let ink = (0..g.width())
            .flat_map(|x| (0..GAP + 2 * font::LINE_HEIGHT).map(move |y| (x, y)))
            .filter(|&(x, y)| g.get(x, y) == Some([20, 20, 20]))
            .count();
        assert!(ink > 20);
    }

    #[test]
    fn empty_grid_is_tiny() {
        assert_eq!(compose_grid(&[], 3, &[]).width(), 1);
    }
}
