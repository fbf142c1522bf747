//! The rasterizer: a triangle mesh to an RGB image with a z-buffer.
//!
//! - Camera: orbits the bounding box centre (azimuth about the +y axis, 0° looks
//!   down −z; elevation towards +y), orthographic or perspective, fitted so the
//!   projected corners of the bounding box (the mesh's, or `bounds` so several
//!   panels share one camera) fill the image minus `margin`.
//! - Shading: a headlight (light at the eye) plus ambient, two-sided so the
//!   back faces of open scans are lit too. `Flat` uses face normals; `Smooth`
//!   interpolates area-weighted vertex normals per pixel and adds a Phong
//!   highlight. Per-face base colours (`face_colors`) carry error maps.
//! - Degenerate faces (zero normal) and faces seen edge-on are skipped; no
//!   NaN reaches the image.
//! - Parallel: faces are binned into bands of rows; rayon renders the bands
//!   independently, each with its own z-buffer slice. Within a band faces are
//!   drawn in index order and a pixel keeps the strictly nearest face (ties go
//!   to the lower index), so the image does not depend on the thread count.
//! - Anti-aliasing: `supersample` renders at k× the size and box-filters down.

use crate::error::RenderError;
use crate::image::Image;
use crate::texture::{FaceLook, Texture};
use normalnet_mesh::Mesh;
use normalnet_mesh::vec3::{self, Vec3};
use rayon::prelude::*;

/// How faces are lit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// one intensity per face (shows the facets, the honest view of noise)
    #[default]
    Flat,
    /// per-pixel interpolated vertex normals with a Phong highlight
    Smooth,
}

/// How the camera projects.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Projection {
    /// parallel projection (sizes comparable across the image)
    #[default]
    Orthographic,
    /// pinhole camera with the given vertical/horizontal field of view in degrees
    Perspective {
        /// full field of view in degrees, in (0, 170)
        fov_deg: f64,
    },
}

/// Everything `render` needs besides the mesh.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// output width in pixels (1..=16384)
    pub width: u32,
    /// output height in pixels (1..=16384)
    pub height: u32,
    /// rotation of the eye about +y in degrees; 0 puts the eye on +z
    pub azimuth_deg: f64,
    /// elevation of the eye above the xz-plane in degrees (−90..=90)
    pub elevation_deg: f64,
    /// orthographic (default) or perspective
    pub projection: Projection,
    /// flat (default) or smooth
    pub shading: Shading,
    /// one base colour per face (len #F), e.g. from `error_colors`; `None` uses `base_color`
    pub face_colors: Option<Vec<[u8; 3]>>,
    /// base colour of every face when `face_colors` is `None`
    pub base_color: [u8; 3],
    /// per face, a texture image with corner coordinates or a material
    /// colour (e.g. [`crate::texture::obj_texture`]), lit like the base
    /// colour; ignored where `face_colors` is given
    pub texture: Option<Texture>,
    /// background colour
    pub background: [u8; 3],
    /// ambient light fraction in [0, 1]; the headlight gives the rest
    pub ambient: f64,
    /// empty border on each side as a fraction of the image, in [0, 0.45]
    pub margin: f64,
    /// render at `supersample`× the size and average down (1..=4)
    pub supersample: u32,
    /// fit the camera to this box `(min, max)` instead of the mesh's own
    /// bounding box (panels of one comparison share a camera this way)
    pub bounds: Option<(Vec3, Vec3)>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 800,
            height: 600,
            azimuth_deg: 30.0,
            elevation_deg: 20.0,
            projection: Projection::Orthographic,
            shading: Shading::Flat,
            face_colors: None,
            base_color: [196, 200, 210],
            texture: None,
            background: [255, 255, 255],
            ambient: 0.25,
            margin: 0.05,
            supersample: 1,
            bounds: None,
        }
    }
}

impl RenderOptions {
    /// Checks every option; the error names the option.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |name, message: String| Err(RenderError::InvalidOption { name, message });
        if self.width == 0 || self.width > 16384 {
            return bad("width", format!("{} is outside 1..=16384", self.width));
        }
        if self.height == 0 || self.height > 16384 {
            return bad("height", format!("{} is outside 1..=16384", self.height));
        }
        if !self.azimuth_deg.is_finite() {
            return bad("azimuth_deg", format!("{} is not finite", self.azimuth_deg));
        }
        if !(-90.0..=90.0).contains(&self.elevation_deg) {
            return bad(
                "elevation_deg",
                format!("{} is outside -90..=90", self.elevation_deg),
            );
        }
        if let Projection::Perspective { fov_deg } = self.projection
            && !(fov_deg > 0.0 && fov_deg < 170.0)
        {
            return bad("fov_deg", format!("{fov_deg} is outside (0, 170)"));
        }
        if !(0.0..=1.0).contains(&self.ambient) {
            return bad("ambient", format!("{} is outside [0, 1]", self.ambient));
        }
        if !(0.0..=0.45).contains(&self.margin) {
            return bad("margin", format!("{} is outside [0, 0.45]", self.margin));
        }
        if !(1..=4).contains(&self.supersample) {
            return bad(
                "supersample",
                format!("{} is outside 1..=4", self.supersample),
            );
        }
        if let Some((lo, hi)) = self.bounds
            && (lo.iter().chain(hi.iter()).any(|v| !v.is_finite()) || (0..3).any(|k| lo[k] > hi[k]))
        {
            return bad("bounds", format!("{lo:?}..{hi:?} is not a finite box"));
        }
        Ok(())
    }
}

/// The fitted camera: view basis, projection and the map to pixel coordinates.
#[derive(Clone, Debug)]
pub struct Camera {
    target: Vec3,
    right: Vec3,
    up: Vec3,
    /// unit vector from the target towards the eye
    towards_eye: Vec3,
    /// distance eye–target for perspective, `None` for orthographic
    eye_distance: Option<f64>,
    scale: f64,
    centre: [f64; 2],
    size: [f64; 2],
}

impl Camera {
    /// The camera of `options` fitted to the box `(lo, hi)` for an image of
    /// `width × height` pixels.
    pub fn fit(bounds: (Vec3, Vec3), options: &RenderOptions, width: u32, height: u32) -> Camera {
        let (lo, hi) = bounds;
        let target = vec3::scale(vec3::add(lo, hi), 0.5);
        let (az, el) = (
            options.azimuth_deg.to_radians(),
            options.elevation_deg.to_radians(),
        );
        let towards_eye = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
        let mut right = vec3::cross([0.0, 1.0, 0.0], towards_eye);
        if vec3::norm(right) < 1e-9 {
            // looking straight down or up: keep the azimuth's "right"
            right = [az.cos(), 0.0, -az.sin()];
        }
        let right = vec3::normalize_or_zero(right);
        let up = vec3::cross(towards_eye, right);
        let radius = 0.5 * vec3::norm(vec3::sub(hi, lo));
        let eye_distance = match options.projection {
            Projection::Orthographic => None,
            Projection::Perspective { fov_deg } => {
                let half = 0.5 * fov_deg.to_radians();
                Some(radius.max(1e-12) / half.sin())
            }
        };
        let mut camera = Camera {
            target,
            right,
            up,
            towards_eye,
            eye_distance,
            scale: 1.0,
            centre: [0.0, 0.0],
            size: [width as f64, height as f64],
        };
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for i in 0..8 {
            let corner = [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ];
            let (p, _) = camera.project_plane(corner);
            for k in 0..2 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        let extent = [max[0] - min[0], max[1] - min[1]];
        let usable = 1.0 - 2.0 * options.margin;
        let sx = if extent[0] > 0.0 {
            width as f64 * usable / extent[0]
        } else {
            f64::INFINITY
        };
        let sy = if extent[1] > 0.0 {
            height as f64 * usable / extent[1]
        } else {
            f64::INFINITY
        };
        let scale = sx.min(sy);
        camera.scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
        camera.centre = [0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])];
        camera
    }

    /// View coordinates of `p`: (right, up, towards the eye).
    pub fn view(&self, p: Vec3) -> Vec3 {
        let d = vec3::sub(p, self.target);
        [
            vec3::dot(d, self.right),
            vec3::dot(d, self.up),
            vec3::dot(d, self.towards_eye),
        ]
    }

    /// A direction in view coordinates.
    pub fn view_direction(&self, v: Vec3) -> Vec3 {
        [
            vec3::dot(v, self.right),
            vec3::dot(v, self.up),
            vec3::dot(v, self.towards_eye),
        ]
    }

    /// Projected plane coordinates before the pixel map, and the depth key
    /// (larger = nearer; affine in screen space). The key is NaN behind the eye.
    fn project_plane(&self, p: Vec3) -> ([f64; 2], f64) {
        let v = self.view(p);
        match self.eye_distance {
            None => ([v[0], v[1]], v[2]),
            Some(d) => {
                let w = d - v[2];
                if w <= 1e-9 * d {
                    ([0.0, 0.0], f64::NAN)
                } else {
                    ([v[0] / w, v[1] / w], 1.0 / w)
                }
            }
        }
    }

    /// Pixel coordinates (x right, y down, pixel centres at +0.5) and depth key
    /// (larger = nearer, NaN behind the eye).
    pub fn project(&self, p: Vec3) -> [f64; 3] {
        let (q, key) = self.project_plane(p);
        [
            0.5 * self.size[0] + self.scale * (q[0] - self.centre[0]),
            0.5 * self.size[1] - self.scale * (q[1] - self.centre[1]),
            key,
        ]
    }

    /// Unit direction from a view-space point towards the light (the eye).
    fn light_direction(&self, view_point: Vec3) -> Vec3 {
        match self.eye_distance {
            None => [0.0, 0.0, 1.0],
            Some(d) => vec3::normalize_or_zero(vec3::sub([0.0, 0.0, d], view_point)),
        }
    }
}

/// Rows per band of the parallel rasterizer.
const BAND_ROWS: usize = 16;

/// Renders `mesh` with `options` to an RGB image of `width × height`.
///
/// Errors: an option out of range (`RenderError::InvalidOption`), or
/// `face_colors` without exactly one colour per face.
pub fn render(mesh: &Mesh, options: &RenderOptions) -> Result<Image, RenderError> {
    options.validate()?;
    if let Some(colors) = &options.face_colors
        && colors.len() != mesh.num_faces()
    {
        return Err(RenderError::FaceColorCount {
            expected: mesh.num_faces(),
            got: colors.len(),
        });
    }
    if let Some(texture) = &options.texture
        && texture.faces.len() != mesh.num_faces()
    {
        return Err(RenderError::InvalidOption {
            name: "texture",
            message: format!(
                "{} faces described, the mesh has {}",
                texture.faces.len(),
                mesh.num_faces()
            ),
        });
    }
    let ss = options.supersample;
    let (w, h) = (options.width * ss, options.height * ss);
    let bounds = options.bounds.unwrap_or_else(|| mesh.bounding_box());
    let camera = Camera::fit(bounds, options, w, h);
    let positions = &mesh.positions;
    let faces = &mesh.faces;

    let screen: Vec<[f64; 3]> = positions.par_iter().map(|&p| camera.project(p)).collect();
    let view_positions: Vec<Vec3> = positions.par_iter().map(|&p| camera.view(p)).collect();
    // unnormalised face normals (2·area·n) in view space
    let face_cross: Vec<Vec3> = faces
        .par_iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| view_positions[i as usize]);
            vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
        })
        .collect();
    let vertex_normals = match options.shading {
        Shading::Flat => Vec::new(),
        Shading::Smooth => {
            let mut sums = vec![[0.0; 3]; positions.len()];
            for (f, n) in faces.iter().zip(&face_cross) {
                for &i in f {
                    sums[i as usize] = vec3::add(sums[i as usize], *n);
                }
            }
            sums.into_par_iter().map(vec3::normalize_or_zero).collect()
        }
    };

    let ambient = options.ambient;
    let texture = options
        .texture
        .as_ref()
        .filter(|_| options.face_colors.is_none());
    let look = |f: usize| texture.map_or(FaceLook::Plain, |t| t.faces[f]);
    let base = |f: usize| -> [u8; 3] {
        match (&options.face_colors, look(f)) {
            (Some(c), _) => c[f],
            (None, FaceLook::Colour(c)) => c,
            (None, _) => options.base_color,
        }
    };
    // per-face draw data; None = skipped (degenerate, edge-on, behind the eye)
    let prepared: Vec<Option<FaceDraw>> = (0..faces.len())
        .into_par_iter()
        .map(|f| {
            let idx = faces[f].map(|i| i as usize);
            let n = vec3::normalize_or_zero(face_cross[f]);
            if n == [0.0; 3] {
                return None;
            }
            let s = idx.map(|i| screen[i]);
            if s.iter().any(|p| !p[2].is_finite()) {
                return None;
            }
            let area2 = (s[1][0] - s[0][0]) * (s[2][1] - s[0][1])
                - (s[1][1] - s[0][1]) * (s[2][0] - s[0][0]);
            if area2.abs() < 1e-12 || !area2.is_finite() {
                return None;
            }
            let centre = vec3::scale(
                vec3::add(
                    vec3::add(view_positions[idx[0]], view_positions[idx[1]]),
                    view_positions[idx[2]],
                ),
                1.0 / 3.0,
            );
            let light = camera.light_direction(centre);
            let intensity = ambient + (1.0 - ambient) * vec3::dot(n, light).abs();
            let b = base(f);
            Some(FaceDraw {
                screen: s,
                vertices: idx,
                area2,
                flat: lit(b, intensity),
                intensity,
                base: b,
                look: look(f),
                light,
            })
        })
        .collect();

    // bin faces into bands of rows (CSR: offsets + face indices)
    let bands = (h as usize).div_ceil(BAND_ROWS);
    let band_range = |d: &FaceDraw| -> Option<(usize, usize)> {
        let ymin = d.screen.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let ymax = d
            .screen
            .iter()
            .map(|p| p[1])
            .fold(f64::NEG_INFINITY, f64::max);
        let r0 = (ymin - 0.5).ceil().max(0.0);
        let r1 = (ymax - 0.5).floor().min(h as f64 - 1.0);
        if r0 > r1 {
            return None;
        }
        Some((r0 as usize / BAND_ROWS, r1 as usize / BAND_ROWS))
    };
    let mut counts = vec![0usize; bands + 1];
    for d in prepared.iter().flatten() {
        if let Some((b0, b1)) = band_range(d) {
            for b in b0..=b1 {
                counts[b + 1] += 1;
            }
        }
    }
    for b in 0..bands {
        counts[b + 1] += counts[b];
    }
    let mut fill = counts.clone();
    let mut binned = vec![0u32; counts[bands]];
    for (f, d) in prepared.iter().enumerate() {
        if let Some(d) = d
            && let Some((b0, b1)) = band_range(d)
        {
            for b in b0..=b1 {
                binned[fill[b]] = f as u32;
                fill[b] += 1;
            }
        }
    }

    let mut image = Image::new(w, h, options.background);
    let row_bytes = 3 * w as usize;
    let smooth = options.shading == Shading::Smooth;
    image
        .pixels_mut()
        .par_chunks_mut(BAND_ROWS * row_bytes)
        .enumerate()
        .for_each(|(band, pixels)| {
            let y0 = band * BAND_ROWS;
            let rows = pixels.len() / row_bytes;
            let mut depth = vec![f64::NEG_INFINITY; rows * w as usize];
            for &f in &binned[counts[band]..counts[band + 1]] {
                let d = prepared[f as usize]
                    .as_ref()
                    .expect("binned faces are prepared");
                let normals = if smooth {
                    Some(d.vertices.map(|i| vertex_normals[i]))
                } else {
                    None
                };
                rasterize_face(
                    d, normals, texture, ambient, y0, rows, w as usize, pixels, &mut depth,
                );
            }
        });
    Ok(image.downsample(ss))
}

/// A face ready to draw.
struct FaceDraw {
    /// pixel x, y and depth key of the three corners
    screen: [[f64; 3]; 3],
    vertices: [usize; 3],
    /// twice the signed screen area
    area2: f64,
    /// flat-shaded colour
    flat: [u8; 3],
    /// flat shading's light intensity
    intensity: f64,
    /// unlit colour
    base: [u8; 3],
    /// texture or material colour
    look: FaceLook,
    /// view-space direction towards the light
    light: Vec3,
}

/// Draws one face into the band of `rows` rows starting at image row `y0`.
#[allow(clippy::too_many_arguments)]
fn rasterize_face(
    d: &FaceDraw,
    normals: Option<[Vec3; 3]>,
    texture: Option<&Texture>,
    ambient: f64,
    y0: usize,
    rows: usize,
    width: usize,
    pixels: &mut [u8],
    depth: &mut [f64],
) {
    // orient counter-clockwise in pixel space (positive area)
    let a = d.screen[0];
    let (mut b, mut c) = (d.screen[1], d.screen[2]);
    let mut order = [0usize, 1, 2];
    let mut area2 = d.area2;
    if area2 < 0.0 {
        std::mem::swap(&mut b, &mut c);
        order.swap(1, 2);
        area2 = -area2;
    }
    let xmin = a[0].min(b[0]).min(c[0]);
    let xmax = a[0].max(b[0]).max(c[0]);
    let ymin = a[1].min(b[1]).min(c[1]);
    let ymax = a[1].max(b[1]).max(c[1]);
    let x0 = ((xmin - 0.5).ceil().max(0.0)) as i64;
    let x1 = ((xmax - 0.5).floor().min(width as f64 - 1.0)) as i64;
    let r0 = ((ymin - 0.5).ceil().max(y0 as f64)) as i64;
    let r1 = ((ymax - 0.5).floor().min((y0 + rows) as f64 - 1.0)) as i64;
    if x0 > x1 || r0 > r1 {
        return;
    }
    // edge functions: w_a is opposite a (edge b→c), etc.; sum = area2
    let edge = |p: [f64; 3], q: [f64; 3], x: f64, y: f64| {
        (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])
    };
    let (dxa, dxb, dxc) = (-(c[1] - b[1]), -(a[1] - c[1]), -(b[1] - a[1]));
    let inv = 1.0 / area2;
    let eps = -1e-7 * area2.max(1.0);
    let n = normals.map(|n| [n[order[0]], n[order[1]], n[order[2]]]);
    for y in r0..=r1 {
        let py = y as f64 + 0.5;
        let px = x0 as f64 + 0.5;
        let mut wa = edge(b, c, px, py);
        let mut wb = edge(c, a, px, py);
        let mut wc = edge(a, b, px, py);
        let row = (y as usize - y0) * width;
        for x in x0..=x1 {
            if wa >= eps && wb >= eps && wc >= eps {
                let (la, lb, lc) = (wa * inv, wb * inv, wc * inv);
                let z = la * a[2] + lb * b[2] + lc * c[2];
                let i = row + x as usize;
                if z > depth[i] {
                    depth[i] = z;
                    let l = [la, lb, lc];
                    let base = match (texture, d.look) {
                        (Some(t), FaceLook::Textured { image, uv }) => {
                            let mut at = [0.0; 2];
                            for k in 0..3 {
                                for j in 0..2 {
                                    at[j] += uv[order[k]][j] * l[k];
                                }
                            }
                            Some(t.sample(image, at))
                        }
                        _ => None,
                    };
                    let colour = match (n, base) {
                        (None, None) => d.flat,
                        (None, Some(base)) => lit(base, d.intensity),
                        (Some(n), base) => {
                            smooth_colour(base.unwrap_or(d.base), d.light, n, l, ambient)
                        }
                    };
                    pixels[3 * i..3 * i + 3].copy_from_slice(&colour);
                }
            }
            wa += dxa;
            wb += dxb;
            wc += dxc;
        }
    }
}

/// `base` scaled by a light intensity.
fn lit(base: [u8; 3], intensity: f64) -> [u8; 3] {
    base.map(|c| (c as f64 * intensity).round().clamp(0.0, 255.0) as u8)
}

/// Phong-lit colour from interpolated vertex normals (two-sided).
fn smooth_colour(base: [u8; 3], light: Vec3, n: [Vec3; 3], l: [f64; 3], ambient: f64) -> [u8; 3] {
    let mut normal = [0.0; 3];
    for k in 0..3 {
        normal = vec3::add(normal, vec3::scale(n[k], l[k]));
    }
    let normal = vec3::normalize_or_zero(normal);
    let cos = vec3::dot(normal, light).abs();
    let diffuse = ambient + (1.0 - ambient) * cos;
    // headlight: the half vector is the light direction itself
    let specular = 0.25 * cos.powi(32);
    base.map(|c| {
        (c as f64 * diffuse + 255.0 * specular)
            .round()
            .clamp(0.0, 255.0) as u8
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn covered(img: &Image, bg: [u8; 3]) -> usize {
        img.pixels().chunks(3).filter(|p| p != &bg).count()
    }

    #[test]
    fn square_facing_the_camera_covers_its_fitted_rectangle() {
        let bg = [0, 0, 0];
        let opts = RenderOptions {
            width: 100,
            height: 100,
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            margin: 0.1,
            background: bg,
            ..Default::default()
        };
        let img = render(&Mesh::unit_square(), &opts).unwrap();
        // the square spans pixels 10..90 in both directions: 80 × 80
        assert_eq!(covered(&img, bg), 6400);
        assert_eq!(img.get(10, 10), Some(opts.base_color)); // full headlight, facing
        assert_eq!(img.get(9, 50), Some(bg));
        assert_eq!(img.get(89, 89), Some(opts.base_color));
        assert_eq!(img.get(90, 89), Some(bg));
    }

    #[test]
    fn back_faces_are_drawn() {
        let bg = [0, 0, 0];
        let opts = RenderOptions {
            width: 50,
            height: 50,
            azimuth_deg: 180.0,
            elevation_deg: 0.0,
            margin: 0.0,
            background: bg,
            ..Default::default()
        };
        let img = render(&Mesh::unit_square(), &opts).unwrap();
        assert_eq!(covered(&img, bg), 2500);
    }

    #[test]
    fn degenerate_faces_are_skipped_without_nan() {
        let mesh = Mesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 1, 3]],
        )
        .unwrap();
        let bg = [0, 0, 0];
        let opts = RenderOptions {
            width: 40,
            height: 40,
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            background: bg,
            shading: Shading::Smooth,
            ..Default::default()
        };
        let img = render(&mesh, &opts).unwrap();
        assert!(covered(&img, bg) > 0);
    }

    #[test]
    fn nearer_face_hides_farther_one() {
        // two squares at z = 0 (red) and z = 1 (green, nearer to the eye on +z)
        let mesh = Mesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
                [0.0, 1.0, 1.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
        )
        .unwrap();
        for projection in [
            Projection::Orthographic,
            Projection::Perspective { fov_deg: 40.0 },
        ] {
            let opts = RenderOptions {
                width: 60,
                height: 60,
                azimuth_deg: 0.0,
                elevation_deg: 0.0,
                ambient: 1.0,
                projection,
                face_colors: Some(vec![[255, 0, 0], [255, 0, 0], [0, 255, 0], [0, 255, 0]]),
                ..Default::default()
            };
            let img = render(&mesh, &opts).unwrap();
            assert_eq!(img.get(30, 30), Some([0, 255, 0]), "{projection:?}");
            assert!(
                !img.pixels().chunks(3).any(|p| p == [255, 0, 0])
                    || projection != Projection::Orthographic
            );
        }
    }

    #[test]
    fn bad_options_are_errors_naming_the_option() {
        let m = Mesh::unit_square();
        let e = render(
            &m,
            &RenderOptions {
                width: 0,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("width"), "{e}");
        let e = render(
            &m,
            &RenderOptions {
                face_colors: Some(vec![[0; 3]]),
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("2 faces"), "{e}");
        let e = render(
            &m,
            &RenderOptions {
                elevation_deg: 91.0,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("elevation"), "{e}");
    }

    #[test]
    fn result_does_not_depend_on_thread_count() {
        let m = Mesh::unit_square();
        let opts = RenderOptions {
            supersample: 2,
            shading: Shading::Smooth,
            ..Default::default()
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| render(&m, &opts).unwrap());
        let many = render(&m, &opts).unwrap();
        assert_eq!(one, many);
    }
}
