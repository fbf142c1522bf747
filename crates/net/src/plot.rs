//! A small loss-curve picture for training runs: training loss (per step,
//! log scale, grey) and validation error (per validation, blue, own scale)
//! over the global step, drawn with the `png` crate.

use std::path::Path;

use crate::NetError;

const W: usize = 800;
const H: usize = 400;
const MARGIN: usize = 30;

/// Reads `train_log.csv` (network,step,lr,loss,val_deg,seconds) and writes
/// a PNG line plot to `png_path`. Network boundaries are drawn as vertical
/// lines.
pub fn loss_curve_png(csv_path: &Path, png_path: &Path) -> Result<(), NetError> {
    let text = std::fs::read_to_string(csv_path).map_err(|e| NetError::io(csv_path, e))?;
    let mut losses = Vec::new(); // (x, loss)
    let mut vals = Vec::new(); // (x, val)
    let mut bounds = Vec::new();
    let mut x = 0usize;
    let mut last_net = String::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 6 {
            continue;
        }
        if f[0] != last_net {
            if !last_net.is_empty() {
                bounds.push(x);
            }
            last_net = f[0].to_string();
        }
        if let Ok(l) = f[3].parse::<f64>() {
            x += 1;
            if l > 0.0 {
                losses.push((x, l.log10()));
            }
        }
        if let Ok(v) = f[4].parse::<f64>() {
            vals.push((x, v));
        }
    }
    let mut img = vec![255u8; W * H * 3];
    let x_max = x.max(1) as f64;
    let plot = |img: &mut Vec<u8>, pts: &[(usize, f64)], colour: [u8; 3]| {
        if pts.is_empty() {
            return;
        }
        let lo = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        let span = (hi - lo).max(1e-9);
        let to_px = |(px, py): (usize, f64)| {
            let u = MARGIN as f64 + (px as f64 / x_max) * (W - 2 * MARGIN) as f64;
            let v = (H - MARGIN) as f64 - ((py - lo) / span) * (H - 2 * MARGIN) as f64;
            (u, v)
        };
        for w in pts.windows(2) {
            let (a, b) = (to_px(w[0]), to_px(w[1]));
            let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) as usize).max(1);
            for s in 0..=n {
                let t = s as f64 / n as f64;
                let (u, v) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                put(img, u as usize, v as usize, colour);
                put(img, u as usize, v as usize + 1, colour);
            }
        }
        if pts.len() == 1 {
            let (u, v) = to_px(pts[0]);
            put(img, u as usize, v as usize, colour);
        }
    };
    // axes
    for u in MARGIN..W - MARGIN {
        put(&mut img, u, H - MARGIN, [0, 0, 0]);
    }
    for v in MARGIN..H - MARGIN {
        put(&mut img, MARGIN, v, [0, 0, 0]);
    }
    for &b in &bounds {
        let u = MARGIN + (b as f64 / x_max * (W - 2 * MARGIN) as f64) as usize;
        for v in (MARGIN..H - MARGIN).step_by(3) {
            put(&mut img, u, v, [200, 120, 0]);
        }
    }
    plot(&mut img, &losses, [150, 150, 150]);
    plot(&mut img, &vals, [20, 60, 220]);
    let tmp = png_path.with_extension("png.tmp");
    {
        let file = std::fs::File::create(&tmp).map_err(|e| NetError::io(&tmp, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), W as u32, H as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| NetError::Record {
            path: tmp.clone(),
            message: e.to_string(),
        })?;
        writer
            .write_image_data(&img)
            .map_err(|e| NetError::Record {
                path: tmp.clone(),
                message: e.to_string(),
            })?;
    }
    std::fs::rename(&tmp, png_path).map_err(|e| NetError::io(png_path, e))
}

fn put(img: &mut [u8], u: usize, v: usize, c: [u8; 3]) {
    if u < W && v < H {
        let i = (v * W + u) * 3;
        img[i..i + 3].copy_from_slice(&c);
    }
}
