//! Textured rendering (issue 38): the diffuse textures of an OBJ file's
//! materials (`mtllib` → `newmtl` / `map_Kd` / `Kd`) and, per triangle of
//! the mesh, which texture and which texture coordinates it shows.
//!
//! Denoising moves vertices only, so a denoised OBJ keeps its `vt`
//! statements, corner indices and `mtllib`: drawn with [`Texture`], the
//! picture shows the texture in place on the new surface.

use crate::error::RenderError;
use crate::image::Image;
use normalnet_mesh::io::attributes::{ObjAttributes, ObjStatement};
use normalnet_mesh::io::{Attributes, FormatAttributes};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What one triangle shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaceLook {
    /// the renderer's base colour (no material, or a material without colour)
    Plain,
    /// one colour (a material's `Kd` without a texture map)
    Colour([u8; 3]),
    /// `images[image]` at these texture coordinates of the triangle's
    /// three corners (OBJ convention: `v` = 0 at the image's bottom row)
    Textured {
        /// index into [`Texture::images`]
        image: usize,
        /// (u, v) of corners 0, 1, 2
        uv: [[f64; 2]; 3],
    },
}

/// Texture images and what each triangle of a mesh shows.
#[derive(Clone, Debug, Default)]
pub struct Texture {
    /// the decoded texture images
    pub images: Vec<Image>,
    /// per triangle of the mesh (len #F)
    pub faces: Vec<FaceLook>,
}

impl Texture {
    /// The colour of `images[image]` at `uv`: bilinear, repeating outside
    /// [0, 1] (OBJ's default wrap), `v` upwards.
    pub fn sample(&self, image: usize, uv: [f64; 2]) -> [u8; 3] {
        let img = &self.images[image];
        let (w, h) = (img.width() as usize, img.height() as usize);
        let x = uv[0].rem_euclid(1.0) * w as f64 - 0.5;
        let y = (1.0 - uv[1].rem_euclid(1.0)) * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f64, n: usize| (i as i64).rem_euclid(n as i64) as u32;
        let texel = |dx: f64, dy: f64| {
            img.get(wrap(x0 + dx, w), wrap(y0 + dy, h))
                .expect("wrapped into the image")
        };
        let (a, b, c, d) = (
            texel(0.0, 0.0),
            texel(1.0, 0.0),
            texel(0.0, 1.0),
            texel(1.0, 1.0),
        );
        std::array::from_fn(|k| {
            let top = a[k] as f64 * (1.0 - fx) + b[k] as f64 * fx;
            let bottom = c[k] as f64 * (1.0 - fx) + d[k] as f64 * fx;
            (top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8
        })
    }

    /// Whether any triangle shows a texture or a material colour.
    pub fn is_visible(&self) -> bool {
        self.faces.iter().any(|f| *f != FaceLook::Plain)
    }
}

/// A material of an `.mtl` file, as far as drawing needs it.
#[derive(Clone, Debug, Default)]
struct Material {
    /// `Kd`, 0–1 per channel
    diffuse: Option<[f64; 3]>,
    /// `map_Kd`, resolved against the library's folder
    map: Option<PathBuf>,
}

/// The texture of a file read by `normalnet_mesh::read_mesh_file`, for the
/// mesh it returned (one [`FaceLook`] per triangle). `Ok(None)` when the
/// file is not an OBJ or uses no material; an error names the material
/// library or image that could not be read (the caller may draw without
/// the texture). A material named by `usemtl` but found in no library
/// draws plain.
///
/// # Errors
/// [`RenderError::Texture`] for an unreadable library or image.
pub fn obj_texture(attributes: &Attributes) -> Result<Option<Texture>, RenderError> {
    let FormatAttributes::Obj(obj) = &attributes.content else {
        return Ok(None);
    };
    let dir = attributes.source_dir.clone().unwrap_or_default();
    let mut materials = HashMap::new();
    for name in obj.material_libraries() {
        read_material_library(&dir.join(name), &mut materials)?;
    }
    if materials.is_empty() {
        return Ok(None);
    }
    let mut images = Vec::new();
    let mut image_of: HashMap<PathBuf, usize> = HashMap::new();
    let mut look_of: HashMap<String, Look> = HashMap::new();
    for (name, material) in &materials {
        let look = match (&material.map, material.diffuse) {
            (Some(path), _) => {
                let index = match image_of.get(path) {
                    Some(&i) => i,
                    None => {
                        images.push(read_image(path)?);
                        image_of.insert(path.clone(), images.len() - 1);
                        images.len() - 1
                    }
                };
                Look::Image(index)
            }
            (None, Some(kd)) => {
                Look::Colour(kd.map(|c| (c * 255.0).round().clamp(0.0, 255.0) as u8))
            }
            (None, None) => Look::Plain,
        };
        look_of.insert(name.clone(), look);
    }
    let faces = face_looks(obj, &attributes.polygon_sizes, &look_of);
    Ok(Some(Texture { images, faces }))
}

/// What a material shows, before texture coordinates.
#[derive(Clone, Copy, Debug)]
enum Look {
    Plain,
    Colour([u8; 3]),
    Image(usize),
}

/// One [`FaceLook`] per triangle: the material in effect (`usemtl`) at each
/// polygon, and for a textured one its fan triangles' corner coordinates.
/// Attributes whose statements and polygon sizes disagree (edited by hand)
/// give fewer looks than triangles, which [`crate::render`] refuses.
fn face_looks(
    obj: &ObjAttributes,
    polygon_sizes: &[u32],
    look_of: &HashMap<String, Look>,
) -> Vec<FaceLook> {
    let mut faces = Vec::new();
    let mut look = Look::Plain;
    let mut polygon = 0;
    let mut first_corner = 0;
    for statement in &obj.statements {
        match statement {
            ObjStatement::Verbatim(line) => {
                let text = String::from_utf8_lossy(line);
                let mut words = text.split_ascii_whitespace();
                if words.next() == Some("usemtl") {
                    let name = words.collect::<Vec<_>>().join(" ");
                    look = look_of.get(&name).copied().unwrap_or(Look::Plain);
                }
            }
            ObjStatement::Polygons(count) => {
                for _ in 0..*count {
                    let Some(&size) = polygon_sizes.get(polygon) else {
                        return faces;
                    };
                    let size = size as usize;
                    let uv = |c: usize| -> Option<[f64; 2]> {
                        let t = *obj.corner_texture_coords.get(first_corner + c)?;
                        let coords = obj.texture_coords.get(t as usize)?;
                        Some([coords[0], coords.get(1).copied().unwrap_or(0.0)])
                    };
                    for i in 1..size.saturating_sub(1) {
                        faces.push(match look {
                            Look::Plain => FaceLook::Plain,
                            Look::Colour(c) => FaceLook::Colour(c),
                            Look::Image(image) => match (uv(0), uv(i), uv(i + 1)) {
                                (Some(a), Some(b), Some(c)) => FaceLook::Textured {
                                    image,
                                    uv: [a, b, c],
                                },
                                _ => FaceLook::Plain,
                            },
                        });
                    }
                    first_corner += size;
                    polygon += 1;
                }
            }
            _ => {}
        }
    }
    faces
}

/// Adds the materials of one `.mtl` file (`newmtl`, `Kd`, `map_Kd`; other
/// statements ignored). A texture map's options (`-s 1 1 1`, ...) are
/// skipped: the file name is the last word.
fn read_material_library(
    path: &Path,
    materials: &mut HashMap<String, Material>,
) -> Result<(), RenderError> {
    let text = std::fs::read_to_string(path).map_err(|e| RenderError::Texture {
        path: path.to_path_buf(),
        message: format!("material library: {e}"),
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut current: Option<String> = None;
    for line in text.lines() {
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        if keyword == "newmtl" {
            let name = rest.join(" ");
            materials.entry(name.clone()).or_default();
            current = Some(name);
            continue;
        }
        let Some(material) = current.as_ref().and_then(|n| materials.get_mut(n)) else {
            continue;
        };
        match keyword {
            "Kd" => {
                let rgb: Vec<f64> = rest.iter().filter_map(|w| w.parse().ok()).collect();
                if let [r, g, b, ..] = rgb[..] {
                    material.diffuse = Some([r, g, b]);
                }
            }
            "map_Kd" => {
                if let Some(file) = rest.last() {
                    material.map = Some(dir.join(file.replace('\\', "/")));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Decodes a PNG texture.
fn read_image(path: &Path) -> Result<Image, RenderError> {
    let bytes = std::fs::read(path).map_err(|e| RenderError::Texture {
        path: path.to_path_buf(),
        message: format!("texture image: {e}"),
    })?;
    Image::decode_png(&bytes).map_err(|e| RenderError::Texture {
        path: path.to_path_buf(),
        message: format!("texture image (PNG only): {e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{RenderOptions, Shading, render};
    use normalnet_mesh::Mesh;

    const RED: [u8; 3] = [220, 30, 30];
    const BLUE: [u8; 3] = [30, 30, 220];

    /// An 8×2 texture: red on the left half, blue on the right.
    fn halves() -> Image {
        let mut img = Image::new(8, 2, RED);
        img.fill_rect(4, 0, 4, 2, BLUE);
        img
    }

    #[test]
    fn sampling_is_bilinear_repeats_and_has_v_upwards() {
        let mut img = Image::new(1, 2, [0, 0, 0]);
        img.set(0, 0, [0, 200, 0]); // the top row
        let t = Texture {
            images: vec![halves(), img],
            faces: vec![],
        };
        assert_eq!(t.sample(0, [0.25, 0.5]), RED);
        assert_eq!(t.sample(0, [0.75, 0.5]), BLUE);
        assert_eq!(t.sample(0, [1.25, -0.5]), RED); // repeats
        assert_eq!(t.sample(0, [0.5, 0.5]), [125, 30, 125]); // halfway
        assert_eq!(t.sample(1, [0.5, 0.75]), [0, 200, 0]); // v = 1 is the top
        assert_eq!(t.sample(1, [0.5, 0.25]), [0, 0, 0]);
    }

    #[test]
    fn a_textured_square_shows_its_texture_in_place_on_both_shadings() {
        let (u0, u1) = ([0.0, 0.0], [1.0, 0.0]);
        let (u2, u3) = ([1.0, 1.0], [0.0, 1.0]);
        let texture = Texture {
            images: vec![halves()],
            faces: vec![
                FaceLook::Textured {
                    image: 0,
                    uv: [u0, u1, u2],
                },
                FaceLook::Textured {
                    image: 0,
                    uv: [u0, u2, u3],
                },
            ],
        };
        for shading in [Shading::Flat, Shading::Smooth] {
            let opts = RenderOptions {
                width: 100,
                height: 100,
                azimuth_deg: 0.0,
                elevation_deg: 0.0,
                margin: 0.1,
                shading,
                texture: Some(texture.clone()),
                ..Default::default()
            };
            let img = render(&Mesh::unit_square(), &opts).unwrap();
            // facing the headlight: diffuse 1 (flat: the texel itself)
            let left = img.get(20, 50).unwrap();
            let right = img.get(80, 50).unwrap();
            assert!(left[0] > 200 && left[2] < 100, "{shading:?} left {left:?}");
            assert!(
                right[2] > 200 && right[0] < 100,
                "{shading:?} right {right:?}"
            );
            if shading == Shading::Flat {
                assert_eq!((left, right), (RED, BLUE));
            }
        }
    }

    #[test]
    fn a_wrong_face_count_is_an_error_naming_the_option() {
        let opts = RenderOptions {
            texture: Some(Texture {
                images: vec![],
                faces: vec![FaceLook::Plain],
            }),
            ..Default::default()
        };
        let e = render(&Mesh::unit_square(), &opts).unwrap_err().to_string();
        assert!(e.contains("texture") && e.contains("1 faces"), "{e}");
    }

    #[test]
    fn an_obj_with_materials_gives_each_triangle_its_look() {
        let dir = tempfile::tempdir().unwrap();
        halves().write_png(dir.path().join("halves.png")).unwrap();
        std::fs::write(
            dir.path().join("part.mtl"),
            "newmtl painted\nKd 1 0.5 0\nnewmtl skin\nKd 1 1 1\nmap_Kd -s 1 1 1 halves.png\n",
        )
        .unwrap();
        let obj = "mtllib part.mtl\n\
                   v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n\
                   vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                   usemtl skin\nf 1/1 2/2 3/3 4/4\n\
                   usemtl painted\nf 2 5 3\n\
                   usemtl unknown\nf 1 2 4\n";
        std::fs::write(dir.path().join("part.obj"), obj).unwrap();
        let file = normalnet_mesh::read_mesh_file(dir.path().join("part.obj")).unwrap();
        let t = obj_texture(&file.attributes).unwrap().unwrap();
        assert_eq!(t.images.len(), 1);
        assert_eq!(t.images[0].get(7, 0), Some(BLUE));
        let (a, b, c, d) = ([0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]);
        assert_eq!(
            t.faces,
            vec![
                FaceLook::Textured {
                    image: 0,
                    uv: [a, b, c]
                },
                FaceLook::Textured {
                    image: 0,
                    uv: [a, c, d]
                },
                FaceLook::Colour([255, 128, 0]),
                FaceLook::Plain,
            ]
        );
        assert!(t.is_visible());
    }

    #[test]
    fn a_missing_texture_is_an_error_naming_it_and_no_material_is_none() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl a\nmap_Kd gone.png\n").unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
        std::fs::write(dir.path().join("a.obj"), obj).unwrap();
        let file = normalnet_mesh::read_mesh_file(dir.path().join("a.obj")).unwrap();
        let e = obj_texture(&file.attributes).unwrap_err().to_string();
        assert!(e.contains("gone.png"), "{e}");
        std::fs::write(
            dir.path().join("b.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let file = normalnet_mesh::read_mesh_file(dir.path().join("b.obj")).unwrap();
        assert!(obj_texture(&file.attributes).unwrap().is_none());
    }
}
