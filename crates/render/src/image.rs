//! `Image`: an RGB8 raster with the few drawing operations the pictures need
//! (rectangles, blits, box downsampling, text) and atomic PNG output.

use crate::error::RenderError;
use crate::font;
use std::path::Path;

/// An RGB image, 8 bits per channel, rows top to bottom, `3 · width · height`
/// bytes in `pixels` (row-major, channel-interleaved).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
}

impl Image {
    /// A `width × height` image filled with `fill`.
    pub fn new(width: u32, height: u32, fill: [u8; 3]) -> Image {
        let n = width as usize * height as usize;
        let mut pixels = Vec::with_capacity(3 * n);
        for _ in 0..n {
            pixels.extend_from_slice(&fill);
        }
        Image {
            width,
            height,
            pixels,
        }
    }

    /// Wraps raw RGB8 bytes; `None` unless `pixels.len() == 3 · width · height`.
    pub fn from_raw(width: u32, height: u32, pixels: Vec<u8>) -> Option<Image> {
        (pixels.len() == 3 * width as usize * height as usize).then_some(Image {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The RGB8 bytes, row-major (len 3 · width · height).
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// Mutable RGB8 bytes, row-major.
    pub fn pixels_mut(&mut self) -> &mut [u8] {
        &mut self.pixels
    }

    /// The colour at `(x, y)`, `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]])
    }

    /// Sets `(x, y)` to `colour`; coordinates outside the image are ignored.
    pub fn set(&mut self, x: i64, y: i64, colour: [u8; 3]) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        self.pixels[i..i + 3].copy_from_slice(&colour);
    }

    /// Fills the rectangle with top-left `(x, y)` and size `w × h`, clipped to the image.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: i64, h: i64, colour: [u8; 3]) {
        let x0 = x.max(0);
        let y0 = y.max(0);
        let x1 = (x + w).min(self.width as i64);
        let y1 = (y + h).min(self.height as i64);
        for yy in y0..y1 {
            for xx in x0..x1 {
                self.set(xx, yy, colour);
            }
        }
    }

    /// Draws a 1-pixel rectangle outline.
    pub fn stroke_rect(&mut self, x: i64, y: i64, w: i64, h: i64, colour: [u8; 3]) {
        self.fill_rect(x, y, w, 1, colour);
        self.fill_rect(x, y + h - 1, w, 1, colour);
        self.fill_rect(x, y, 1, h, colour);
        self.fill_rect(x + w - 1, y, 1, h, colour);
    }

    /// Copies `src` with its top-left corner at `(x, y)`, clipped to this image.
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        for sy in 0..src.height as i64 {
            let dy = y + sy;
            if dy < 0 || dy >= self.height as i64 {
                continue;
            }
            let sx0 = (-x).max(0);
            let sx1 = (self.width as i64 - x).min(src.width as i64);
            if sx0 >= sx1 {
                continue;
            }
            let s = 3 * (sy as usize * src.width as usize + sx0 as usize);
            let d = 3 * (dy as usize * self.width as usize + (x + sx0) as usize);
            let n = 3 * (sx1 - sx0) as usize;
            self.pixels[d..d + n].copy_from_slice(&src.pixels[s..s + n]);
        }
    }

    /// Box-filter downsampling by an integer `factor` (anti-aliasing of a
    /// supersampled render). The size is `width / factor × height / factor`.
    pub fn downsample(&self, factor: u32) -> Image {
        if factor <= 1 {
            return self.clone();
        }
        let w = self.width / factor;
        let h = self.height / factor;
        let f = factor as usize;
        let mut out = Vec::with_capacity(3 * w as usize * h as usize);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let mut sum = [0u32; 3];
                for sy in 0..f {
                    let row = (y * f + sy) * self.width as usize;
                    for sx in 0..f {
                        let i = 3 * (row + x * f + sx);
                        for (c, s) in sum.iter_mut().enumerate() {
                            *s += self.pixels[i + c] as u32;
                        }
                    }
                }
                let n = (f * f) as u32;
                for s in sum {
                    out.push(((s + n / 2) / n) as u8);
                }
            }
        }
        Image {
            width: w,
            height: h,
            pixels: out,
        }
    }

    /// Draws `text` with the built-in 5×7 font, each font pixel a
    /// `scale × scale` block, top-left corner at `(x, y)`. Returns the width drawn.
    pub fn draw_text(&mut self, x: i64, y: i64, text: &str, scale: u32, colour: [u8; 3]) -> i64 {
        font::draw_text(self, x, y, text, scale, colour)
    }

    /// The image as PNG bytes (RGB8).
    pub fn encode_png(&self) -> Result<Vec<u8>, RenderError> {
        let err = |e: png::EncodingError| RenderError::Png {
            path: "<memory>".into(),
            message: e.to_string(),
        };
        let mut out = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_compression(png::Compression::Fast);
            let mut writer = encoder.write_header().map_err(err)?;
            writer.write_image_data(&self.pixels).map_err(err)?;
            writer.finish().map_err(err)?;
        }
        Ok(out)
    }

    /// Decodes a PNG of any colour type and depth to 8-bit RGB (palette and
    /// grey expanded, 16-bit reduced, alpha dropped): textures, tests and tools.
    pub fn decode_png(bytes: &[u8]) -> Result<Image, RenderError> {
        let err = |message: String| RenderError::Png {
            path: "<memory>".into(),
            message,
        };
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::normalize_to_color8());
        let mut reader = decoder.read_info().map_err(|e| err(e.to_string()))?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| err("image too large".into()))?;
        let mut buf = vec![0; size];
        let info = reader
            .next_frame(&mut buf)
            .map_err(|e| err(e.to_string()))?;
        if info.bit_depth != png::BitDepth::Eight {
            return Err(err(format!("unsupported bit depth {:?}", info.bit_depth)));
        }
        let channels = match info.color_type {
            png::ColorType::Grayscale => 1,
            png::ColorType::GrayscaleAlpha => 2,
            png::ColorType::Rgb => 3,
            png::ColorType::Rgba => 4,
            other => return Err(err(format!("unsupported colour type {other:?}"))),
        };
        let mut pixels = Vec::with_capacity(3 * info.width as usize * info.height as usize);
        for row in buf[..info.buffer_size()].chunks(info.line_size) {
            for px in row.chunks(channels).take(info.width as usize) {
                if channels < 3 {
                    pixels.extend_from_slice(&[px[0]; 3]);
                } else {
                    pixels.extend_from_slice(&px[..3]);
                }
            }
        }
        Ok(Image {
            width: info.width,
            height: info.height,
            pixels,
        })
    }

    /// Writes the image as PNG to `path`, atomically (temp file next to it, then rename).
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let bytes = self.encode_png().map_err(|e| match e {
            RenderError::Png { message, .. } => RenderError::Png {
                path: path.to_path_buf(),
                message,
            },
            other => other,
        })?;
        normalnet_mesh::io::write_atomically(path, |w| w.write_all(&bytes))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip_keeps_pixels() {
        let mut img = Image::new(7, 5, [10, 20, 30]);
        img.set(3, 2, [255, 0, 128]);
        img.fill_rect(0, 0, 2, 2, [1, 2, 3]);
        let bytes = img.encode_png().unwrap();
        let back = Image::decode_png(&bytes).unwrap();
        assert_eq!(back, img);
    }

    #[test]
    fn write_png_is_atomic_and_readable() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let img = Image::new(4, 3, [200, 100, 50]);
        img.write_png(&path).unwrap();
        let back = Image::decode_png(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(back, img);
        // no temp files left behind
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn write_png_into_missing_folder_is_an_error_naming_the_file() {
        let img = Image::new(2, 2, [0, 0, 0]);
        let err = img
            .write_png("/nonexistent-normalnet-dir/x.png")
            .unwrap_err();
        assert!(
            err.to_string().contains("nonexistent-normalnet-dir"),
            "{err}"
        );
    }

    #[test]
    fn downsample_averages_blocks() {
        let mut img = Image::new(4, 2, [0, 0, 0]);
        img.fill_rect(0, 0, 1, 2, [255, 255, 255]);
        let small = img.downsample(2);
        assert_eq!((small.width(), small.height()), (2, 1));
        assert_eq!(small.get(0, 0), Some([128, 128, 128]));
        assert_eq!(small.get(1, 0), Some([0, 0, 0]));
    }

    #[test]
    fn blit_clips() {
        let mut dst = Image::new(4, 4, [0, 0, 0]);
        let src = Image::new(3, 3, [9, 9, 9]);
        dst.blit(&src, 2, -1);
        assert_eq!(dst.get(2, 0), Some([9, 9, 9]));
        assert_eq!(dst.get(3, 1), Some([9, 9, 9]));
        assert_eq!(dst.get(3, 2), Some([0, 0, 0]));
        assert_eq!(dst.get(1, 0), Some([0, 0, 0]));
    }
}
