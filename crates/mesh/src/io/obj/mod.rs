//! Wavefront OBJ: the reader ([`read`]), the writers ([`write`]) and the
//! statements an OBJ file holds beyond positions and triangles
//! ([`ObjAttributes`], kept by [`super::read_mesh_file`]).

mod read;
mod write;

pub(super) use read::{parse, parse_with_attributes};
pub(crate) use write::LibraryPaths;
pub(super) use write::{write, write_with_attributes};

use std::path::Path;

/// "No index": a corner without a texture coordinate or normal.
pub const NO_INDEX: u32 = u32::MAX;

/// One statement, or a run of statements of one kind, of an OBJ file, in
/// file order. Replaying them writes the file back in its own order.
#[derive(Clone, Debug, PartialEq)]
pub enum ObjStatement {
    /// this many `v` statements (the next ones of the mesh's positions)
    Vertices(u32),
    /// this many `vt` statements (the next [`ObjAttributes::texture_coords`])
    TextureCoords(u32),
    /// this many `vn` statements (the next [`ObjAttributes::normals`])
    Normals(u32),
    /// this many `f` / `fo` statements (the next polygons)
    Polygons(u32),
    /// an `mtllib` statement: the text after the keyword, trimmed (one or
    /// more file names, relative to the OBJ file's folder)
    MaterialLibrary(String),
    /// any other line (`g`, `o`, `s`, `usemtl`, `l`, comments, ...), as
    /// written (without its line end)
    Verbatim(Vec<u8>),
}

/// The statements of an OBJ file beyond positions and triangles. Per-corner
/// arrays run over the corners of the file's polygons, polygon after
/// polygon, each polygon's corners in file order (len Σ
/// [`super::Attributes::polygon_sizes`]); they are empty when no corner
/// has that attribute.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjAttributes {
    /// the file's statements in order
    pub statements: Vec<ObjStatement>,
    /// per vertex, the text after its x y z (`w`, or a colour `r g b`),
    /// trimmed, as written; empty when no vertex has any (len #V or 0)
    pub vertex_tails: Vec<String>,
    /// the `vt` statements' values (u, or u v, or u v w), in order
    pub texture_coords: Vec<Vec<f64>>,
    /// the `vn` statements as read (the writer recomputes them)
    pub normals: Vec<[f64; 3]>,
    /// per corner, its 0-based index into `texture_coords`, or [`NO_INDEX`]
    pub corner_texture_coords: Vec<u32>,
    /// per corner, its 0-based index into `normals`, or [`NO_INDEX`]
    pub corner_normals: Vec<u32>,
}

impl ObjAttributes {
    /// The per-vertex colours `v x y z r g b` (len #V), when every vertex
    /// has one; `None` otherwise.
    pub fn vertex_colors(&self) -> Option<Vec<[f64; 3]>> {
        if self.vertex_tails.is_empty() {
            return None;
        }
        self.vertex_tails
            .iter()
            .map(|tail| {
                let v: Vec<f64> = tail
                    .split_ascii_whitespace()
                    .map(|t| t.parse().ok())
                    .collect::<Option<_>>()?;
                match v.as_slice() {
                    [r, g, b] | [_, r, g, b] => Some([*r, *g, *b]),
                    _ => None,
                }
            })
            .collect()
    }

    /// The `mtllib` file names, as written.
    pub fn material_libraries(&self) -> Vec<&str> {
        self.statements
            .iter()
            .filter_map(|s| match s {
                ObjStatement::MaterialLibrary(names) => Some(names.as_str()),
                _ => None,
            })
            .flat_map(split_library_names)
            .collect()
    }

    /// Warnings for the `mtllib` files that do not exist relative to `dir`.
    pub(crate) fn missing_material_libraries(&self, dir: &Path) -> Vec<String> {
        self.material_libraries()
            .into_iter()
            .filter(|name| !dir.join(name).is_file())
            .map(|name| {
                format!(
                    "material library {name:?} not found in {}: its name is kept as written",
                    dir.display()
                )
            })
            .collect()
    }
}

/// The file names of an `mtllib` statement: whitespace-separated.
pub(crate) fn split_library_names(names: &str) -> impl Iterator<Item = &str> {
    names.split_ascii_whitespace()
}
