//! Headless software rasterizer: meshes to PNG, optionally coloured by
//! per-face angular error against ground truth, plus the comparison report
//! (table.md, CSV, JSON, HTML) of `normalnet bench`.
//!
//! Data comes from `normalnet-mesh` (a `Mesh`, per-face errors from its
//! metrics); the pictures and reports go to the CLI (`normalnet render`,
//! `normalnet bench`). No GPU, no windowing, no font files: a z-buffered
//! rasterizer parallel over row bands ([`raster`]), a built-in 5×7 bitmap font
//! ([`font`]), the turbo colormap with a labelled colour bar ([`colormap`]),
//! and side-by-side panels ([`grid`]).

pub mod annotate;
pub mod colormap;
pub mod error;
pub mod font;
pub mod grid;
pub mod image;
pub mod raster;
pub mod report;
pub mod texture;

pub use annotate::{append_colour_bar, draw_lines, render_against_gt, render_annotated};
pub use colormap::{
    ColourBar, draw_colour_bar, error_colors, error_colour, nice_error_scale, turbo,
};
pub use error::RenderError;
pub use grid::compose_grid;
pub use image::Image;
pub use raster::{Projection, RenderOptions, Shading, render};
pub use texture::{FaceLook, Texture, obj_texture};
