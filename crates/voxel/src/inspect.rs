//! Files for looking at grids and samples: `.npy` arrays (NumPy format 1.0,
//! little-endian, C order; header written here) and a PNG picture of a grid
//! (three orthographic views of the occupied cubes coloured by normal).

use crate::error::VoxelError;
use crate::params::VoxelParams;
use normalnet_mesh::io::write_atomically;
use std::io::Write;
use std::path::Path;

/// Element types [`write_npy`] can store.
pub trait NpyElement: Copy {
    /// NumPy `descr` string.
    const DESCR: &'static str;
    /// Appends the little-endian bytes of `self`.
    fn put(self, out: &mut Vec<u8>);
}

impl NpyElement for f32 {
    const DESCR: &'static str = "<f4";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

impl NpyElement for u8 {
    const DESCR: &'static str = "|u1";
    fn put(self, out: &mut Vec<u8>) {
        out.push(self);
    }
}

impl NpyElement for u32 {
    const DESCR: &'static str = "<u4";
    fn put(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

/// The bytes of a `.npy` file holding `data` with `shape` (C order).
///
/// # Errors
/// [`VoxelError::InvalidParameter`] when `shape`'s product is not `data.len()`.
pub fn encode_npy<T: NpyElement>(shape: &[usize], data: &[T]) -> Result<Vec<u8>, VoxelError> {
    let n: usize = shape.iter().product();
    if n != data.len() {
        return Err(VoxelError::InvalidParameter {
            name: "shape",
            message: format!("shape {shape:?} holds {n} values, data has {}", data.len()),
        });
    }
    let dims = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!(
        "{{'descr': '{}', 'fortran_order': False, 'shape': {dims}, }}",
        T::DESCR
    );
    // magic (6) + version (2) + length (2) + header + '\n', padded to 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len() * 4);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for &x in data {
        x.put(&mut out);
    }
    Ok(out)
}

/// Writes `data` with `shape` as a `.npy` file (atomically).
///
/// # Errors
/// Shape mismatch as [`encode_npy`]; I/O errors naming the file.
pub fn write_npy<T: NpyElement>(
    path: &Path,
    shape: &[usize],
    data: &[T],
) -> Result<(), VoxelError> {
    let bytes = encode_npy(shape, data)?;
    write_atomically(path, |w: &mut dyn Write| w.write_all(&bytes))?;
    Ok(())
}

/// An RGB picture of one `[3, D, H, W]` grid: three orthographic views side
/// by side, looking along −x (H up, W right), −y (D down, W right) and −z
/// (H up, D right); each pixel shows the first occupied cube along the view
/// ray, coloured `(n + 1) / 2`, darker with depth; empty rays are dark grey.
/// Each cube is `zoom` pixels wide. Returns `(width, height, rgb bytes)`.
///
/// # Panics
/// If `grid.len() != params.grid_len()`.
pub fn grid_picture(grid: &[f32], params: VoxelParams, zoom: usize) -> (usize, usize, Vec<u8>) {
    assert_eq!(grid.len(), params.grid_len());
    let side = params.side();
    let cells = side * side * side;
    let zoom = zoom.max(1);
    let gap = 4;
    let view = side * zoom;
    let (width, height) = (3 * view + 2 * gap, view);
    let mut rgb = vec![16u8; width * height * 3];
    let value = |i: usize, j: usize, k: usize| {
        let c = (i * side + j) * side + k;
        [grid[c], grid[cells + c], grid[2 * cells + c]]
    };
    for v in 0..3 {
        for a in 0..side {
            for b in 0..side {
                // (row, col) of the view → first occupied cube along depth.
                let mut hit = None;
                for d in 0..side {
                    let depth = side - 1 - d;
                    let (i, j, k) = match v {
                        0 => (depth, side - 1 - a, b),
                        1 => (a, depth, b),
                        _ => (b, side - 1 - a, depth),
                    };
                    let n = value(i, j, k);
                    if n != [0.0; 3] {
                        hit = Some((n, d));
                        break;
                    }
                }
                let colour = match hit {
                    Some((n, d)) => {
                        let shade = 1.0 - 0.5 * d as f32 / side as f32;
                        n.map(|x| (((x + 1.0) * 0.5).clamp(0.0, 1.0) * 255.0 * shade) as u8)
                    }
                    None => [40, 40, 40],
                };
                for y in 0..zoom {
                    for x in 0..zoom {
                        let px = v * (view + gap) + b * zoom + x;
                        let py = a * zoom + y;
                        let o = (py * width + px) * 3;
                        rgb[o..o + 3].copy_from_slice(&colour);
                    }
                }
            }
        }
    }
    (width, height, rgb)
}

/// Encodes RGB bytes as PNG.
///
/// # Errors
/// [`VoxelError::InvalidParameter`] on a size mismatch or encoder error.
pub fn encode_png(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, VoxelError> {
    let bad = |message: String| VoxelError::InvalidParameter {
        name: "image",
        message,
    };
    if rgb.len() != width * height * 3 {
        return Err(bad(format!(
            "{} bytes for a {width}×{height} RGB image",
            rgb.len()
        )));
    }
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width as u32, height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| bad(e.to_string()))?;
        w.write_image_data(rgb).map_err(|e| bad(e.to_string()))?;
    }
    Ok(out)
}

/// Writes RGB bytes as a PNG file (atomically).
///
/// # Errors
/// As [`encode_png`]; I/O errors naming the file.
pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<(), VoxelError> {
    let bytes = encode_png(width, height, rgb)?;
    write_atomically(path, |w: &mut dyn Write| w.write_all(&bytes))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_parsable() {
        let data: Vec<f32> = (0..24).map(|x| x as f32).collect();
        let bytes = encode_npy(&[2, 3, 4], &data).unwrap();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + hl]).unwrap();
        assert!(
            header.contains("'shape': (2, 3, 4)")
                && header.contains("'<f4'")
                && header.ends_with('\n')
        );
        assert_eq!(bytes.len(), 10 + hl + 96);
        assert_eq!(&bytes[10 + hl + 4..10 + hl + 8], &1f32.to_le_bytes());
        assert!(encode_npy(&[5], &data).is_err());
        let one = encode_npy(&[3], &[1u8, 2, 3]).unwrap();
        assert!(
            std::str::from_utf8(&one[10..])
                .unwrap_or("")
                .contains("(3,)")
                || one.windows(4).any(|w| w == b"(3,)")
        );
    }

    #[test]
    fn picture_colours_occupied_cubes() {
        let params = VoxelParams::tiny();
        let mut grid = vec![0.0f32; params.grid_len()];
        let cells = params.num_cells();
        let side = params.side();
        let c = (7 * side + 7) * side + 7;
        grid[cells + c] = 1.0;
        let (w, h, rgb) = grid_picture(&grid, params, 2);
        assert_eq!((w, h), (3 * 30 + 8, 30));
        // The y view (middle) shows the cube's colour (0.5, 1, 0.5)·shade.
        let px = 30 + 4 + 7 * 2;
        let py = 7 * 2;
        let o = (py * w + px) * 3;
        assert!(
            rgb[o + 1] > 150 && rgb[o] < rgb[o + 1],
            "{:?}",
            &rgb[o..o + 3]
        );
        let png = encode_png(w, h, &rgb).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}
