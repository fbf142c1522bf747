//! What a mesh file carries beyond positions and triangles (issue 38), and
//! the readers and writers that keep it: [`read_mesh_file`] returns the
//! [`Mesh`] together with its [`Attributes`], [`write_mesh_file`] writes a
//! mesh with the same connectivity (a denoised one: only positions moved)
//! back with every attribute of the input.
//!
//! What each format keeps (the rest of the policy is that of [`super`]):
//! - every format: the polygons of the file. The mesh holds their fan
//!   triangulation; [`Attributes::polygon_sizes`] says how many corners each
//!   polygon had (polygon `p` produced `size − 2` consecutive triangles), so
//!   the writer re-emits the polygons, or the triangles with
//!   [`FileWriteOptions::triangulate`];
//! - OBJ ([`ObjAttributes`]): every statement in file order. `v` keeps what
//!   follows its x y z (w, or a colour `r g b`) as written; `vt` and the
//!   corners' texture indices are kept; `vn` and the corners' normal indices
//!   are kept, the normals themselves **recomputed** from the written
//!   surface (each `vn` the normalised area-weighted sum of the normals of
//!   the polygons whose corners use it: the area-weighted vertex normal for
//!   the usual one-normal-per-vertex file, and hard edges stay hard);
//!   `mtllib` names are rewritten relative to the output's folder (the
//!   `.mtl` and its textures stay where they are and are not copied; a name
//!   that cannot be found is a warning and kept as written); `g`, `o`, `s`,
//!   `usemtl`, comments and any other statement are copied verbatim in their
//!   place. Corner indices are written absolute (1-based), `fo` as `f`;
//! - PLY ([`PlyAttributes`]): every element and property, in the input's
//!   order, types, and encoding (ASCII, binary little or big endian; ASCII
//!   with [`FileWriteOptions::ply_ascii`]), header comments and `obj_info`
//!   lines; `x y z` are written in their own type (a `float` file stays
//!   `float`; integer-typed coordinates are rounded), vertex and face
//!   `nx ny nz` are recomputed (area-weighted); a list property of the
//!   face element other than `vertex_indices` is repeated unchanged on each
//!   triangle when triangulating;
//! - STL ([`StlAttributes`]): binary: the 80-byte header and each facet's
//!   2-byte attribute; ASCII: the first solid's name (a file of several
//!   solids is written as one, with a warning; so is padding after the last
//!   binary facet, dropped). Facet normals are recomputed.
//! - OFF ([`OffAttributes`]): the header keyword (`COFF`, `NOFF`, …), what
//!   follows each vertex's x y z and each face's indices (colours) as
//!   written. Comments are dropped (a warning says how many); the header's
//!   edge count is written as 0.
//! - glTF and GLB ([`GltfAttributes`]): the whole document and its buffers.
//!   The mesh is every triangle primitive of the scene at its node's world
//!   transform, welded by exactly equal world positions (seams between
//!   primitives stay closed); written back, each `POSITION` accessor gets
//!   its moved vertices in place (local space, f32) and new `min`/`max`,
//!   `NORMAL` is recomputed, `TANGENT` dropped with a warning; materials,
//!   textures, images, UVs, colours, extensions and the buffer layout pass
//!   through (UVs and colours can be read per triangle corner with
//!   [`GltfAttributes::corner_values`]). Buffer files are written beside the output (`<stem>.bin`),
//!   image URIs rewritten relative to the output's folder; `.gltf` ↔
//!   `.glb` converts the container (the glTF module documents the rest).
//!
//! A mesh written in another format than it was read from (glTF and GLB
//! count as one) keeps its
//! positions and triangles only ([`write_mesh`](super::write_mesh)), with a warning naming what
//! was dropped. Warnings are returned, never printed: the caller decides.

use super::{Format, WriteOptions, format_of, perr, strip_bom, write_atomically, write_mesh_as};
use crate::error::MeshError;
use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};
use std::io::Write;
use std::path::{Path, PathBuf};

pub use super::gltf::{
    GltfAttributes, GltfBuffer, GltfBufferSource, GltfContainer, GltfCornerValues, GltfPositions,
    GltfPrimitive,
};
pub use super::obj::{ObjAttributes, ObjStatement};
pub use super::off::OffAttributes;
pub use super::ply::{
    PlyAttributes, PlyColumn, PlyElement, PlyEncoding, PlyHeaderLine, PlyKind, PlyProperty,
    PlyScalar,
};
pub use super::stl::{StlAttributes, StlEncoding};

/// A mesh file as read: the mesh, what else the file holds, and what the
/// reader could not keep.
#[derive(Clone, Debug)]
pub struct MeshFile {
    /// positions and (fan-triangulated) faces, exactly what [`super::read_mesh`] returns
    pub mesh: Mesh,
    /// everything else the file holds, for [`write_mesh_file`]
    pub attributes: Attributes,
    /// one line per thing the reader dropped or could not resolve (empty
    /// when the file is kept whole)
    pub warnings: Vec<String>,
}

/// What a file holds beyond positions and triangles, in a form that
/// [`write_mesh_file`] writes back around new positions.
///
/// The fields are public to be read (colours, texture coordinates, extra
/// properties). Changing values is fine; changing lengths (a per-vertex or
/// per-corner array, a PLY column) breaks the writer's invariants and may
/// make it panic: the counts must stay those of the file.
#[derive(Clone, Debug, PartialEq)]
pub struct Attributes {
    /// number of vertices of the file (the mesh written must have as many)
    pub num_vertices: usize,
    /// corners of each polygon, in file order (len #polygons); polygon `p`
    /// produced `polygon_sizes[p] − 2` consecutive triangles of the mesh,
    /// the fan `(v0, v_i, v_{i+1})`
    pub polygon_sizes: Vec<u32>,
    /// the folder of the file read, absolute when it could be made so
    /// (relative references such as OBJ `mtllib` are resolved from it);
    /// `None` for a file parsed from memory ([`parse_mesh_file`])
    pub source_dir: Option<PathBuf>,
    /// the attributes of the format
    pub content: FormatAttributes,
}

/// The attributes of one format.
#[derive(Clone, Debug, PartialEq)]
pub enum FormatAttributes {
    /// Wavefront OBJ
    Obj(ObjAttributes),
    /// Object File Format
    Off(OffAttributes),
    /// Stanford PLY
    Ply(PlyAttributes),
    /// STL
    Stl(StlAttributes),
    /// glTF 2.0 (`.gltf` or `.glb`)
    Gltf(GltfAttributes),
}

impl Attributes {
    /// The format these attributes were read from.
    pub fn format(&self) -> Format {
        match self.content {
            FormatAttributes::Obj(_) => Format::Obj,
            FormatAttributes::Off(_) => Format::Off,
            FormatAttributes::Ply(_) => Format::Ply,
            FormatAttributes::Stl(_) => Format::Stl,
            FormatAttributes::Gltf(ref g) => match g.container {
                GltfContainer::Json => Format::Gltf,
                GltfContainer::Binary => Format::Glb,
            },
        }
    }

    /// Number of triangles the polygons produce (what the mesh must have).
    pub fn num_triangles(&self) -> usize {
        self.polygon_sizes.iter().map(|&n| n as usize - 2).sum()
    }

    /// Checks that `mesh` has the vertex count and triangles of the file
    /// (and that every polygon has at least 3 corners).
    ///
    /// # Errors
    /// [`MeshError::Mismatch`] saying which count differs.
    pub fn check_matches(&self, mesh: &Mesh) -> Result<(), MeshError> {
        if let Some(p) = self.polygon_sizes.iter().position(|&n| n < 3) {
            return Err(MeshError::Mismatch(format!(
                "polygon {p} of the attributes has {} corners, at least 3 expected",
                self.polygon_sizes[p]
            )));
        }
        if mesh.num_vertices() != self.num_vertices || mesh.num_faces() != self.num_triangles() {
            return Err(MeshError::Mismatch(format!(
                "the mesh has {} vertices and {} faces, its attributes were read from a file \
                 with {} vertices and {} triangles",
                mesh.num_vertices(),
                mesh.num_faces(),
                self.num_vertices,
                self.num_triangles()
            )));
        }
        Ok(())
    }
}

/// Options of [`write_mesh_file`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FileWriteOptions {
    /// Write the mesh's triangles instead of the file's polygons (each
    /// triangle takes its polygon's per-face attributes).
    pub triangulate: bool,
    /// Write PLY as ASCII (default: the input's encoding).
    pub ply_ascii: bool,
}

/// Reads a mesh and everything else its file holds, choosing the format
/// from the extension. `.mesh` is what [`super::read_mesh`] returns.
///
/// # Errors
/// As [`super::read_mesh`]; in addition an OBJ texture or normal index
/// beyond the `vt` / `vn` statements, or a `vt` / `vn` that is no list of
/// numbers, is a [`MeshError::Parse`] naming the line.
pub fn read_mesh_file(path: impl AsRef<Path>) -> Result<MeshFile, MeshError> {
    let path = path.as_ref();
    read_mesh_file_as(path, format_of(path)?)
}

/// [`read_mesh_file`] in the given format, whatever the extension.
///
/// # Errors
/// As [`read_mesh_file`].
pub fn read_mesh_file_as(path: impl AsRef<Path>, format: Format) -> Result<MeshFile, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut file = parse_mesh_file_in(&bytes, format, path, Some(&absolute_dir(path)))?;
    file.attributes.source_dir = Some(absolute_dir(path));
    if let FormatAttributes::Obj(obj) = &file.attributes.content {
        file.warnings
            .extend(obj.missing_material_libraries(&absolute_dir(path)));
    }
    Ok(file)
}

/// Parses a mesh file from memory; `path` names it in errors and warnings
/// ([`Attributes::source_dir`] stays `None`: written back, OBJ `mtllib`
/// names and glTF image URIs are kept as read; a `.gltf` whose buffers are
/// files is refused, [`read_mesh_file`] reads them).
///
/// # Errors
/// As [`read_mesh_file`].
pub fn parse_mesh_file(bytes: &[u8], format: Format, path: &Path) -> Result<MeshFile, MeshError> {
    parse_mesh_file_in(bytes, format, path, None)
}

/// [`parse_mesh_file`]; `dir` is the folder a `.gltf`'s buffer files are
/// read from (`None`: refused).
fn parse_mesh_file_in(
    bytes: &[u8],
    format: Format,
    path: &Path,
    dir: Option<&Path>,
) -> Result<MeshFile, MeshError> {
    let mut warnings = Vec::new();
    let (positions, faces, polygon_sizes, content) = match format {
        Format::Obj => {
            let (p, f, (sizes, obj)) = super::obj::parse_with_attributes(strip_bom(bytes), path)?;
            (p, f, sizes, FormatAttributes::Obj(obj))
        }
        Format::Off => {
            let (p, f, (sizes, off)) = super::off::parse_with_attributes(strip_bom(bytes), path)?;
            if off.comments_dropped > 0 {
                warnings.push(format!(
                    "{}: {} comment lines dropped (OFF comments are not kept)",
                    path.display(),
                    off.comments_dropped
                ));
            }
            (p, f, sizes, FormatAttributes::Off(off))
        }
        Format::Ply => {
            let (p, f, (sizes, ply)) = super::ply::parse_with_attributes(strip_bom(bytes), path)?;
            (p, f, sizes, FormatAttributes::Ply(ply))
        }
        Format::Stl => {
            let (p, f, (sizes, stl)) = super::stl::parse_with_attributes(bytes, path)?;
            if stl.solids_merged > 0 {
                warnings.push(format!(
                    "{}: {} more solids merged into the first (their names are dropped)",
                    path.display(),
                    stl.solids_merged
                ));
            }
            if stl.padding_dropped > 0 {
                warnings.push(format!(
                    "{}: {} bytes of padding after the last facet dropped",
                    path.display(),
                    stl.padding_dropped
                ));
            }
            (p, f, sizes, FormatAttributes::Stl(stl))
        }
        Format::Gltf | Format::Glb => {
            let ((p, f, (sizes, gltf)), read_warnings) =
                super::gltf::parse_with_attributes(bytes, path, dir)?;
            warnings.extend(read_warnings);
            (p, f, sizes, FormatAttributes::Gltf(gltf))
        }
    };
    let num_vertices = positions.len();
    let mesh = super::finish(positions, faces, path)?;
    let attributes = Attributes {
        num_vertices,
        polygon_sizes,
        source_dir: None,
        content,
    };
    debug_assert_eq!(attributes.num_triangles(), mesh.num_faces());
    Ok(MeshFile {
        mesh,
        attributes,
        warnings,
    })
}

/// Writes `mesh` (the file's connectivity, new positions) atomically with
/// the file's `attributes`, choosing the format from the extension; returns
/// the warnings (what could not be written).
///
/// # Errors
/// [`MeshError::Mismatch`] when `mesh` has other vertex or triangle counts
/// than the file; [`MeshError::UnknownFormat`], [`MeshError::Io`].
pub fn write_mesh_file(
    path: impl AsRef<Path>,
    mesh: &Mesh,
    attributes: &Attributes,
    options: &FileWriteOptions,
) -> Result<Vec<String>, MeshError> {
    let path = path.as_ref();
    write_mesh_file_as(path, mesh, attributes, format_of(path)?, options)
}

/// [`write_mesh_file`] in the given format, whatever the extension. A
/// format other than the one the attributes were read from gets the
/// positions and triangles only ([`write_mesh_as`]) and a warning; glTF
/// and GLB convert into each other with everything. A glTF whose buffers
/// are files writes them beside `path` first (`<stem>.bin`, each
/// atomically), then `path`.
///
/// # Errors
/// As [`write_mesh_file`].
pub fn write_mesh_file_as(
    path: impl AsRef<Path>,
    mesh: &Mesh,
    attributes: &Attributes,
    format: Format,
    options: &FileWriteOptions,
) -> Result<Vec<String>, MeshError> {
    let path = path.as_ref();
    attributes.check_matches(mesh)?;
    if let (FormatAttributes::Gltf(gltf), true) = (&attributes.content, format.is_gltf()) {
        return write_gltf_files(path, mesh, gltf, attributes.source_dir.as_deref(), format);
    }
    if format != attributes.format() {
        write_mesh_as(
            path,
            mesh,
            format,
            &WriteOptions {
                ply_ascii: options.ply_ascii,
            },
        )?;
        let held = attributes.describe();
        if held.is_empty() {
            return Ok(Vec::new());
        }
        return Ok(vec![format!(
            "{}: written as {} from {} input: only positions and triangles are kept, \
             the input's {} dropped",
            path.display(),
            format.name(),
            attributes.format().name(),
            held.join(", ")
        )]);
    }
    let out_dir = absolute_dir(&super::write_target(path));
    write_atomically(path, |w| {
        write_attributes(w, mesh, attributes, options, Some(&out_dir))
    })?;
    Ok(Vec::new())
}

/// A glTF document and its buffer files, written beside `path` (see
/// [`write_mesh_file_as`]); returns the writer's warnings.
fn write_gltf_files(
    path: &Path,
    mesh: &Mesh,
    gltf: &GltfAttributes,
    source_dir: Option<&Path>,
    format: Format,
) -> Result<Vec<String>, MeshError> {
    let target = super::write_target(path);
    let out_dir = absolute_dir(&target);
    let stem = target
        .file_stem()
        .map_or_else(|| "mesh".into(), |s| s.to_string_lossy().into_owned());
    let output = super::gltf::Output {
        container: if format == Format::Glb {
            GltfContainer::Binary
        } else {
            GltfContainer::Json
        },
        stem: Some(&stem),
        from: source_dir,
        to: Some(&out_dir),
    };
    let encoded = super::gltf::encode_with_attributes(mesh, gltf, &output).map_err(|source| {
        MeshError::Io {
            path: path.to_path_buf(),
            source,
        }
    })?;
    let dir = super::target_dir(&target);
    for (name, bytes) in &encoded.files {
        write_atomically(&dir.join(name), |w| w.write_all(bytes))?;
    }
    write_atomically(path, |w| w.write_all(&encoded.main))?;
    Ok(encoded
        .warnings
        .into_iter()
        .map(|w| format!("{}: {w}", path.display()))
        .collect())
}

/// Encodes `mesh` with `attributes` into memory, in the attributes' format
/// (what [`write_mesh_file`] writes; OBJ `mtllib` names and glTF image
/// URIs as read, a `.gltf`'s buffer files embedded as `data:` URIs).
///
/// # Errors
/// [`MeshError::Mismatch`] as [`write_mesh_file`]; [`MeshError::Io`] when
/// the format cannot hold the mesh (STL: a coordinate beyond f32's range).
pub fn encode_mesh_file(
    mesh: &Mesh,
    attributes: &Attributes,
    options: &FileWriteOptions,
) -> Result<Vec<u8>, MeshError> {
    attributes.check_matches(mesh)?;
    let mut out = Vec::new();
    write_attributes(&mut out, mesh, attributes, options, None).map_err(|source| {
        MeshError::Io {
            path: PathBuf::from("<memory>"),
            source,
        }
    })?;
    Ok(out)
}

/// The one dispatch of the attribute writers; `out_dir` is the output's
/// folder (OBJ `mtllib` names are rewritten relative to it), `None` to keep
/// the names as read.
fn write_attributes(
    w: &mut dyn Write,
    mesh: &Mesh,
    attributes: &Attributes,
    options: &FileWriteOptions,
    out_dir: Option<&Path>,
) -> std::io::Result<()> {
    let polygons = Polygons::new(mesh, &attributes.polygon_sizes, options.triangulate);
    match &attributes.content {
        FormatAttributes::Obj(obj) => {
            let libraries = super::obj::LibraryPaths {
                from: attributes.source_dir.as_deref(),
                to: out_dir,
            };
            super::obj::write_with_attributes(w, mesh, &polygons, obj, &libraries)
        }
        FormatAttributes::Off(off) => super::off::write_with_attributes(w, mesh, &polygons, off),
        FormatAttributes::Ply(ply) => {
            super::ply::write_with_attributes(w, mesh, &polygons, ply, options.ply_ascii)
        }
        FormatAttributes::Stl(stl) => super::stl::write_with_attributes(w, mesh, &polygons, stl),
        FormatAttributes::Gltf(gltf) => {
            let output = super::gltf::Output {
                container: gltf.container,
                stem: None,
                from: attributes.source_dir.as_deref(),
                to: out_dir,
            };
            let encoded = super::gltf::encode_with_attributes(mesh, gltf, &output)?;
            w.write_all(&encoded.main)
        }
    }
}

impl Attributes {
    /// What the attributes hold beyond positions and triangles, for the
    /// warning of a format change; empty when the file held nothing else.
    fn describe(&self) -> Vec<String> {
        let mut held = Vec::new();
        if self.polygon_sizes.iter().any(|&n| n != 3) {
            held.push("polygons".to_string());
        }
        let mut add = |present: bool, what: &str| {
            if present {
                held.push(what.to_string());
            }
        };
        match &self.content {
            FormatAttributes::Obj(obj) => {
                let verbatim = |keyword: &str| {
                    obj.statements.iter().any(|st| match st {
                        ObjStatement::Verbatim(line) => line
                            .split(|b| b.is_ascii_whitespace())
                            .next()
                            .is_some_and(|k| k.eq_ignore_ascii_case(keyword.as_bytes())),
                        _ => false,
                    })
                };
                add(!obj.texture_coords.is_empty(), "texture coordinates");
                add(!obj.normals.is_empty(), "normals");
                let libraries = obj
                    .statements
                    .iter()
                    .any(|st| matches!(st, ObjStatement::MaterialLibrary(_)));
                add(libraries || verbatim("usemtl"), "materials");
                add(verbatim("g") || verbatim("o"), "groups and objects");
                add(verbatim("s"), "smoothing groups");
                add(!obj.vertex_tails.is_empty(), "vertex colours");
            }
            FormatAttributes::Off(off) => {
                add(
                    !off.vertex_tails.is_empty() || !off.face_tails.is_empty(),
                    "vertex and face colours",
                );
            }
            FormatAttributes::Ply(ply) => {
                let extra: Vec<String> = ply
                    .elements
                    .iter()
                    .flat_map(|e| {
                        e.properties
                            .iter()
                            .filter(|p| {
                                matches!(p.column, PlyColumn::Scalars(_) | PlyColumn::Lists { .. })
                            })
                            .map(move |p| format!("{} {}", e.name, p.name))
                    })
                    .collect();
                if !extra.is_empty() {
                    held.push(format!("properties {}", extra.join(", ")));
                }
            }
            FormatAttributes::Stl(stl) => {
                add(
                    stl.facet_attributes.iter().any(|&a| a != 0),
                    "facet attribute bytes",
                );
            }
            FormatAttributes::Gltf(gltf) => held.extend(gltf.describe()),
        }
        held
    }
}

/// The polygons of a file laid over a mesh's fan triangles: what the
/// writers iterate. With `triangulate`, every triangle is a polygon of its
/// own, and [`Polygons::source`] says which file polygon it came from.
pub(crate) struct Polygons<'a> {
    faces: &'a [[u32; 3]],
    sizes: &'a [u32],
    triangulate: bool,
}

/// One polygon to write.
pub(crate) struct Polygon {
    /// index of the file's polygon it is (or, triangulated, comes from)
    pub source: usize,
    /// the file polygon's first corner in the flat per-corner arrays
    pub first_corner: usize,
    /// which corners of the file polygon it has, in order: all of them, or
    /// the fan triangle `(0, i, i + 1)`
    pub corners: Vec<usize>,
    /// the mesh vertices of those corners
    pub vertices: Vec<u32>,
    /// twice its area times its unit normal: the sum of its fan triangles'
    /// `(q − p) × (r − p)`
    pub weighted_normal: Vec3,
}

impl<'a> Polygons<'a> {
    pub(crate) fn new(mesh: &'a Mesh, sizes: &'a [u32], triangulate: bool) -> Polygons<'a> {
        Polygons {
            faces: &mesh.faces,
            sizes,
            triangulate,
        }
    }

    /// The same polygons, never triangulated.
    pub(crate) fn whole(&self) -> Polygons<'a> {
        Polygons {
            triangulate: false,
            ..*self
        }
    }

    /// Number of polygons written.
    pub(crate) fn count(&self) -> usize {
        if self.triangulate {
            self.faces.len()
        } else {
            self.sizes.len()
        }
    }

    /// The polygons in order; `positions` gives the normals.
    pub(crate) fn iter<'b>(&'b self, positions: &'b [Vec3]) -> impl Iterator<Item = Polygon> + 'b {
        let mut triangle = 0;
        let mut corner = 0;
        self.sizes.iter().enumerate().flat_map(move |(p, &size)| {
            let size = size as usize;
            let tris = &self.faces[triangle..triangle + size - 2];
            triangle += size - 2;
            let first_corner = corner;
            corner += size;
            let normal_of = |t: &[u32; 3]| {
                let [a, b, c] = t.map(|v| positions[v as usize]);
                vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
            };
            let out: Vec<Polygon> = if self.triangulate {
                tris.iter()
                    .enumerate()
                    .map(|(i, t)| Polygon {
                        source: p,
                        first_corner,
                        corners: vec![0, i + 1, i + 2],
                        vertices: t.to_vec(),
                        weighted_normal: normal_of(t),
                    })
                    .collect()
            } else {
                let mut vertices = Vec::with_capacity(size);
                vertices.extend_from_slice(&tris[0]);
                vertices.extend(tris[1..].iter().map(|t| t[2]));
                let weighted_normal = tris.iter().map(normal_of).fold([0.0; 3], vec3::add);
                vec![Polygon {
                    source: p,
                    first_corner,
                    corners: (0..size).collect(),
                    vertices,
                    weighted_normal,
                }]
            };
            out
        })
    }
}

/// Records a polygon of `n` corners read from `path` at `line`: its size,
/// checked to fit u32.
pub(crate) fn push_polygon_size(
    sizes: &mut Vec<u32>,
    n: usize,
    path: &Path,
    line: usize,
) -> Result<(), MeshError> {
    let n = u32::try_from(n).map_err(|_| perr(path, line, format!("polygon of {n} corners")))?;
    sizes.push(n);
    Ok(())
}

/// What a reader that keeps attributes returns: positions, fan triangles,
/// and the polygons' corner counts with the format's attributes.
pub(crate) type ParsedWith<A> = (Vec<Vec3>, Vec<[u32; 3]>, (Vec<u32>, A));

/// The folder of `path`, absolute (and with links resolved) where possible.
fn absolute_dir(path: &Path) -> PathBuf {
    let dir = super::target_dir(path);
    std::fs::canonicalize(&dir)
        .or_else(|_| std::path::absolute(&dir))
        .unwrap_or(dir)
}

/// `target` relative to the folder `from` (both absolute), e.g.
/// `../in/a.mtl`; `None` when no relative path exists (another root).
pub(crate) fn relative_path(target: &Path, from: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let t: Vec<Component> = target.components().collect();
    let f: Vec<Component> = from.components().collect();
    if t.first() != f.first() {
        return None;
    }
    let common = t.iter().zip(&f).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    Some(out)
}
