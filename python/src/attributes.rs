//! The attributes of a mesh file as numpy arrays (issue 38): what
//! `normalnet.read_mesh(path, attributes=True)` returns beside the vertices
//! and faces, and how `normalnet.write_mesh(..., attributes=dict)` writes
//! the user's edits of it back.
//!
//! The dict holds, format-independent where it can be (keys absent when the
//! file has no such data):
//! - `format` (`obj`/`off`/`ply`/`stl`/`gltf`), `encoding` (PLY: `ascii`,
//!   `binary_little_endian`, `binary_big_endian`; STL: `ascii`, `binary`;
//!   glTF: `json`, `binary`), `polygon_sizes` (int64, one per file polygon),
//!   `warnings` (the reader's);
//! - `uv` (float64 `K×2`, `K×3` when a `vt` has w; missing components 0)
//!   and `corner_uv` (int64 `M×3`, one row per returned triangle, index
//!   into `uv`, −1 for a corner without one): OBJ `vt`;
//!   For glTF, `uv` is the `TEXCOORD_0` elements of the primitives
//!   ([`GltfAttributes::corner_values`]: each accessor once, in the order
//!   the primitives first use it) and `corner_uv` indexes them per corner
//!   (−1 for the triangles of a primitive without `TEXCOORD_0`);
//! - `colors` (float64 `K×3` or `K×4`, alpha 1 for an RGB element in a
//!   file that also has RGBA ones) and `corner_colors` (int64 `M×3`, as
//!   `corner_uv`): glTF `COLOR_0`, normalized integers as 0..1;
//! - `vertex_colors` (float64 `N×3` or `N×4`, values as the file writes
//!   them): OBJ `v x y z r g b`, PLY `red green blue [alpha]`, OFF colours;
//! - `vertex_properties` / `face_properties` (dict name → float64 array):
//!   PLY's scalar properties of the `vertex` / `face` element other than
//!   `x y z nx ny nz` (face ones per file polygon);
//! - `_file`: a [`FileAttributes`], the Rust [`Attributes`] the dict was
//!   made from, so that writing needs no re-reading.
//!
//! Writing compares each editable array with the one [`FileAttributes`]
//! gives and changes only what differs (text tails of unchanged vertices
//! stay byte for byte as read); read-only entries must be unchanged. glTF
//! `uv` and `colors` edits go into their accessors (in their component
//! types: f32, or the nearest step of a normalized integer); `corner_uv`
//! and `corner_colors` are read-only (the connectivity of the file).

use normalnet_mesh::Attributes;
use normalnet_mesh::MeshError;
use normalnet_mesh::io::attributes::{
    GltfAttributes, GltfContainer, ObjAttributes, OffAttributes, PlyAttributes, PlyColumn,
    PlyEncoding, PlyKind, PlyScalar, StlEncoding,
};
use normalnet_mesh::io::{FormatAttributes, NO_INDEX};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

/// The attributes of one mesh file (opaque; the `_file` entry of the dict of
/// `read_mesh(path, attributes=True)`). Immutable: copies share it.
#[pyclass(frozen, module = "normalnet._normalnet")]
pub struct FileAttributes {
    pub(crate) attributes: Attributes,
    /// the file's (fan) triangles: a mesh written with these attributes
    /// must have them
    pub(crate) faces: Vec<[u32; 3]>,
    /// what the reader could not keep (also the dict's `warnings`)
    pub(crate) warnings: Vec<String>,
}

#[pymethods]
impl FileAttributes {
    /// The format read (`obj`, `off`, `ply`, `stl`, `gltf`).
    #[getter]
    fn format(&self) -> &'static str {
        format_name(&self.attributes)
    }

    fn __repr__(&self) -> String {
        format!(
            "<FileAttributes of a {} file: {} vertices, {} polygons>",
            self.attributes.format().name(),
            self.attributes.num_vertices,
            self.attributes.polygon_sizes.len()
        )
    }

    fn __copy__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __deepcopy__(slf: Py<Self>, _memo: &Bound<'_, PyAny>) -> Py<Self> {
        slf
    }
}

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `format` of the dict.
fn format_name(a: &Attributes) -> &'static str {
    match a.content {
        FormatAttributes::Obj(_) => "obj",
        FormatAttributes::Off(_) => "off",
        FormatAttributes::Ply(_) => "ply",
        FormatAttributes::Stl(_) => "stl",
        FormatAttributes::Gltf(_) => "gltf",
    }
}

/// `encoding` of the dict, for the formats that have several.
fn encoding_name(a: &Attributes) -> Option<&'static str> {
    Some(match &a.content {
        FormatAttributes::Ply(ply) => match ply.encoding {
            PlyEncoding::Ascii => "ascii",
            PlyEncoding::BinaryLittleEndian => "binary_little_endian",
            PlyEncoding::BinaryBigEndian => "binary_big_endian",
        },
        FormatAttributes::Stl(stl) => match stl.encoding {
            StlEncoding::Ascii { .. } => "ascii",
            StlEncoding::Binary { .. } => "binary",
        },
        FormatAttributes::Gltf(gltf) => match gltf.container {
            GltfContainer::Json => "json",
            GltfContainer::Binary => "binary",
        },
        FormatAttributes::Obj(_) | FormatAttributes::Off(_) => return None,
    })
}

/// A row-major `rows × cols` table of numbers.
#[derive(Clone, Debug, PartialEq)]
struct Table {
    cols: usize,
    data: Vec<f64>,
}

impl Table {
    fn rows(&self) -> usize {
        self.data.len().checked_div(self.cols).unwrap_or(0)
    }

    fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    fn to_array<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        Array2::from_shape_vec((self.rows(), self.cols), self.data.clone())
            .expect("rows × cols")
            .into_pyarray(py)
            .into_any()
    }
}

/// Whether two values are the same (NaN equal to NaN), so that an array
/// handed back unchanged is no edit.
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

// ---------------------------------------------------------------- reading

/// OBJ `vt` values as a table: 3 columns when a `vt` has w, else 2; the
/// components a statement leaves out are 0 (OBJ's defaults).
fn obj_uv(obj: &ObjAttributes) -> Option<Table> {
    if obj.texture_coords.is_empty() {
        return None;
    }
    let cols = if obj.texture_coords.iter().any(|t| t.len() > 2) {
        3
    } else {
        2
    };
    let mut data = Vec::with_capacity(obj.texture_coords.len() * cols);
    for t in &obj.texture_coords {
        data.extend((0..cols).map(|k| t.get(k).copied().unwrap_or(0.0)));
    }
    Some(Table { cols, data })
}

/// Per returned triangle, the `vt` index of each corner (−1: none), from
/// the per-polygon-corner indices (the fan `(c0, c_i, c_{i+1})`).
fn obj_corner_uv(polygon_sizes: &[u32], obj: &ObjAttributes) -> Vec<i64> {
    let triangles: usize = polygon_sizes.iter().map(|&n| n as usize - 2).sum();
    let mut out = Vec::with_capacity(triangles * 3);
    let index = |corner: usize| match obj.corner_texture_coords.get(corner) {
        Some(&t) if t != NO_INDEX => i64::from(t),
        _ => -1,
    };
    let mut first = 0;
    for &n in polygon_sizes {
        let n = n as usize;
        for i in 1..n - 1 {
            out.extend([index(first), index(first + i), index(first + i + 1)]);
        }
        first += n;
    }
    out
}

/// The per-corner entries of glTF: (values key, corner key, vertex
/// attribute, what fills the components an element lacks: UV 0, alpha 1).
const GLTF_CORNER_KEYS: [(&str, &str, &str, f64); 2] = [
    ("uv", "corner_uv", "TEXCOORD_0", 0.0),
    ("colors", "corner_colors", "COLOR_0", 1.0),
];

/// A glTF vertex attribute as the dict's pair: its values as a table as
/// wide as the widest element (the others filled with `fill`), and per
/// mesh triangle the row of each corner (−1: none). `None` when no
/// primitive has it; `Err` (the message) when its accessors are broken.
fn gltf_corner_table(
    gltf: &GltfAttributes,
    attribute: &str,
    fill: f64,
) -> Result<Option<(Table, Vec<i64>)>, String> {
    let found = gltf.corner_values(attribute).map_err(|e| match e {
        MeshError::Parse { message, .. } => message,
        e => e.to_string(),
    })?;
    let Some(found) = found else {
        return Ok(None);
    };
    let cols = found.values.iter().map(Vec::len).max().unwrap_or(2);
    let mut data = Vec::with_capacity(found.values.len() * cols);
    for v in &found.values {
        data.extend((0..cols).map(|k| v.get(k).copied().unwrap_or(fill)));
    }
    let corners = found
        .corners
        .iter()
        .flatten()
        .map(|&i| if i == NO_INDEX { -1 } else { i64::from(i) })
        .collect();
    Ok(Some((Table { cols, data }, corners)))
}

/// The per-corner table of `key` (`uv`, `colors`) of a glTF file, for the
/// check of an edit: `None` when the file is no glTF file or has no such
/// attribute; a broken attribute is a ValueError naming `key`.
fn gltf_entry(a: &Attributes, key: &str) -> PyResult<Option<(Table, Vec<i64>)>> {
    let FormatAttributes::Gltf(gltf) = &a.content else {
        return Ok(None);
    };
    let (_, _, attribute, fill) = GLTF_CORNER_KEYS
        .into_iter()
        .find(|(values, corners, ..)| key == *values || key == *corners)
        .expect("a glTF corner key");
    gltf_corner_table(gltf, attribute, fill)
        .map_err(|e| value_error(format!("{key}: the file's {attribute} cannot be read: {e}")))
}

/// Where a file keeps its vertex colours.
enum ColorSource {
    /// OBJ: the last 3 numbers of each `v` tail (`[w] r g b`)
    ObjTails,
    /// OFF: tokens `start..start + len` of each vertex tail
    OffTails { start: usize, len: usize },
    /// PLY: these scalar properties of the vertex element (r, g, b[, a])
    Ply { properties: Vec<usize> },
}

/// The numbers of a text tail; `None` when a token is no number.
fn numbers(tail: &str) -> Option<Vec<f64>> {
    tail.split_ascii_whitespace()
        .map(|t| t.parse().ok())
        .collect()
}

/// Where the colours of an OFF file are: after the normal (`N`), before
/// the texture coordinates (`ST`), 3 or 4 numbers on every vertex. A `C`
/// in the keyword says the file has colours; a plain `OFF` whose every
/// vertex has 3 or 4 extra numbers is read as coloured too (common in the
/// wild).
fn off_color_range(off: &OffAttributes) -> Option<(usize, usize)> {
    if off.vertex_tails.is_empty() {
        return None;
    }
    let upper = off.keyword.to_ascii_uppercase();
    let prefix = upper.strip_suffix("OFF").unwrap_or("");
    let texture = prefix.starts_with("ST");
    let color = prefix.contains('C');
    let normal = off.has_vertex_normals();
    if !color && (texture || normal) {
        return None;
    }
    let start = if normal { 3 } else { 0 };
    let mut len = None;
    for tail in &off.vertex_tails {
        let n = numbers(tail)?.len();
        let here = n.checked_sub(start + if texture { 2 } else { 0 })?;
        if !(3..=4).contains(&here) || len.is_some_and(|l| l != here) {
            return None;
        }
        len = Some(here);
    }
    len.map(|len| (start, len))
}

fn color_source(a: &Attributes) -> Option<ColorSource> {
    match &a.content {
        FormatAttributes::Obj(obj) => obj.vertex_colors().map(|_| ColorSource::ObjTails),
        FormatAttributes::Off(off) => {
            off_color_range(off).map(|(start, len)| ColorSource::OffTails { start, len })
        }
        FormatAttributes::Ply(ply) => {
            let el = &ply.elements[ply.vertex_element];
            let find = |name: &str| {
                el.properties
                    .iter()
                    .position(|p| p.name == name && matches!(p.column, PlyColumn::Scalars(_)))
            };
            let mut properties = vec![find("red")?, find("green")?, find("blue")?];
            properties.extend(find("alpha"));
            Some(ColorSource::Ply { properties })
        }
        FormatAttributes::Stl(_) | FormatAttributes::Gltf(_) => None,
    }
}

fn read_colors(a: &Attributes, source: &ColorSource) -> Table {
    match (&a.content, source) {
        (FormatAttributes::Obj(obj), ColorSource::ObjTails) => Table {
            cols: 3,
            data: obj
                .vertex_colors()
                .expect("the source says every vertex has a colour")
                .into_iter()
                .flatten()
                .collect(),
        },
        (FormatAttributes::Off(off), &ColorSource::OffTails { start, len }) => Table {
            cols: len,
            data: off
                .vertex_tails
                .iter()
                .flat_map(|t| numbers(t).expect("checked numbers")[start..start + len].to_vec())
                .collect(),
        },
        (FormatAttributes::Ply(ply), ColorSource::Ply { properties }) => {
            let el = &ply.elements[ply.vertex_element];
            let columns: Vec<&[f64]> = properties
                .iter()
                .map(|&p| match &el.properties[p].column {
                    PlyColumn::Scalars(v) => v.as_slice(),
                    _ => unreachable!("colour properties are scalar columns"),
                })
                .collect();
            Table {
                cols: columns.len(),
                data: (0..el.count)
                    .flat_map(|i| columns.iter().map(move |c| c[i]))
                    .collect(),
            }
        }
        _ => unreachable!("colour source of another format"),
    }
}

/// The scalar properties of element `ei` kept as values (not x y z, the
/// normals, the face indices): (property index, name), first of a name.
fn ply_scalar_properties(ply: &PlyAttributes, ei: usize) -> Vec<(usize, &str)> {
    let mut out: Vec<(usize, &str)> = Vec::new();
    for (pi, p) in ply.elements[ei].properties.iter().enumerate() {
        if matches!(p.column, PlyColumn::Scalars(_)) && out.iter().all(|(_, n)| *n != p.name) {
            out.push((pi, &p.name));
        }
    }
    out
}

fn ply_properties_dict<'py>(
    py: Python<'py>,
    ply: &PlyAttributes,
    ei: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (pi, name) in ply_scalar_properties(ply, ei) {
        if let PlyColumn::Scalars(values) = &ply.elements[ei].properties[pi].column {
            dict.set_item(name, Array1::from_vec(values.clone()).into_pyarray(py))?;
        }
    }
    Ok(dict)
}

/// The dict of `read_mesh(path, attributes=True)`.
pub(crate) fn attributes_dict<'py>(
    py: Python<'py>,
    file: FileAttributes,
) -> PyResult<Bound<'py, PyDict>> {
    let a = &file.attributes;
    let dict = PyDict::new(py);
    dict.set_item("format", format_name(a))?;
    if let Some(encoding) = encoding_name(a) {
        dict.set_item("encoding", encoding)?;
    }
    let sizes: Vec<i64> = a.polygon_sizes.iter().map(|&n| i64::from(n)).collect();
    dict.set_item("polygon_sizes", Array1::from_vec(sizes).into_pyarray(py))?;
    let mut warnings = file.warnings.clone();
    let corner_array = |corners: Vec<i64>| {
        Array2::from_shape_vec((corners.len() / 3, 3), corners)
            .expect("M×3")
            .into_pyarray(py)
    };
    if let FormatAttributes::Obj(obj) = &a.content
        && let Some(uv) = obj_uv(obj)
    {
        dict.set_item("uv", uv.to_array(py))?;
        let corners = obj_corner_uv(&a.polygon_sizes, obj);
        dict.set_item("corner_uv", corner_array(corners))?;
    }
    if let FormatAttributes::Gltf(gltf) = &a.content {
        for (values_key, corners_key, attribute, fill) in GLTF_CORNER_KEYS {
            match gltf_corner_table(gltf, attribute, fill) {
                Ok(None) => {}
                Ok(Some((values, corners))) => {
                    dict.set_item(values_key, values.to_array(py))?;
                    dict.set_item(corners_key, corner_array(corners))?;
                }
                // the mesh is fine and the accessor is written back as read:
                // the entry is left out, the warnings say why
                Err(e) => warnings.push(format!(
                    "{attribute} is not in the dict ({values_key}, {corners_key}): {e}"
                )),
            }
        }
    }
    dict.set_item("warnings", warnings)?;
    if let Some(source) = color_source(a) {
        dict.set_item("vertex_colors", read_colors(a, &source).to_array(py))?;
    }
    if let FormatAttributes::Ply(ply) = &a.content {
        dict.set_item(
            "vertex_properties",
            ply_properties_dict(py, ply, ply.vertex_element)?,
        )?;
        if let Some(fe) = ply.face_element {
            dict.set_item("face_properties", ply_properties_dict(py, ply, fe)?)?;
        }
    }
    dict.set_item("_file", Bound::new(py, file)?)?;
    Ok(dict)
}

// ---------------------------------------------------------------- writing

/// An f64 array of the edits with the expected shape, else a ValueError
/// naming `key`.
fn table_edit(value: &Bound<'_, PyAny>, key: &str, expected: &[usize]) -> PyResult<Vec<f64>> {
    let array: PyReadonlyArrayDyn<f64> = value
        .extract()
        .map_err(|_| value_error(format!("{key}: expected a float64 array")))?;
    let view = array.as_array();
    if view.shape() != expected {
        return Err(value_error(format!(
            "{key}: shape {:?} differs from the file's {:?} (only values can be edited)",
            view.shape(),
            expected
        )));
    }
    Ok(view.iter().copied().collect())
}

/// An int64 array that must equal `original` (a read-only entry).
fn check_unchanged_ints(
    value: &Bound<'_, PyAny>,
    key: &str,
    original: &[i64],
    shape: &[usize],
) -> PyResult<()> {
    let array: PyReadonlyArrayDyn<i64> = value
        .extract()
        .map_err(|_| value_error(format!("{key}: expected an int64 array")))?;
    let view = array.as_array();
    if view.shape() != shape || !view.iter().copied().eq(original.iter().copied()) {
        return Err(value_error(format!(
            "{key}: cannot be edited (it describes the file read); \
             pass it as read_mesh returned it"
        )));
    }
    Ok(())
}

/// glTF: the edits of the `key` table (`uv`, `colors`, made from the
/// accessors of `attribute` with `fill` in the columns an element lacks)
/// written into those accessors ([`GltfAttributes::set_corner_values`]);
/// a filled column must stay filled (an RGB accessor has no alpha).
fn apply_gltf_values(
    gltf: &mut GltfAttributes,
    (key, attribute, fill): (&str, &str, f64),
    table: &Table,
    value: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let new = table_edit(value, key, &[table.rows(), table.cols])?;
    if (0..new.len()).all(|i| same(new[i], table.data[i])) {
        return Ok(());
    }
    let mut values = gltf
        .corner_values(attribute)
        .map_err(|e| value_error(format!("{key}: {e}")))?
        .map(|found| found.values)
        .unwrap_or_default();
    for (i, element) in values.iter_mut().enumerate() {
        let row = &new[i * table.cols..(i + 1) * table.cols];
        if let Some(k) = (element.len()..table.cols).find(|&k| !same(row[k], fill)) {
            return Err(value_error(format!(
                "{key}: row {i} column {k} cannot be set: its accessor's elements have {} \
                 components (the column only fills the table, with {fill})",
                element.len()
            )));
        }
        let n = element.len();
        element.copy_from_slice(&row[..n]);
    }
    gltf.set_corner_values(attribute, &values)
        .map_err(|e| value_error(format!("{key}: {e}")))
}

/// Checks that `v` can be written as a PLY value of type `t` (integers:
/// finite and within the type, rounded on writing; f32: within its range
/// unless infinite or NaN).
fn check_ply_value(v: f64, t: PlyScalar, key: &str, at: usize) -> PyResult<()> {
    let range = match t {
        PlyScalar::I8 => Some((i8::MIN as f64, i8::MAX as f64)),
        PlyScalar::U8 => Some((0.0, u8::MAX as f64)),
        PlyScalar::I16 => Some((i16::MIN as f64, i16::MAX as f64)),
        PlyScalar::U16 => Some((0.0, u16::MAX as f64)),
        PlyScalar::I32 => Some((i32::MIN as f64, i32::MAX as f64)),
        PlyScalar::U32 => Some((0.0, u32::MAX as f64)),
        PlyScalar::F32 if v.is_finite() => Some((f32::MIN as f64, f32::MAX as f64)),
        PlyScalar::F32 | PlyScalar::F64 => None,
    };
    if let Some((lo, hi)) = range {
        let written = if t.is_int() { v.round() } else { v };
        if !(lo..=hi).contains(&written) {
            return Err(value_error(format!(
                "{key}: value {v} at row {at} does not fit the file's {} property",
                ply_type_name(t)
            )));
        }
    }
    Ok(())
}

/// The PLY name of a scalar type.
fn ply_type_name(t: PlyScalar) -> &'static str {
    match t {
        PlyScalar::I8 => "char",
        PlyScalar::U8 => "uchar",
        PlyScalar::I16 => "short",
        PlyScalar::U16 => "ushort",
        PlyScalar::I32 => "int",
        PlyScalar::U32 => "uint",
        PlyScalar::F32 => "float",
        PlyScalar::F64 => "double",
    }
}

/// Writes into scalar property `pi` of element `ei` the values of `new`
/// (one per instance) that differ from `old` (the file's), checking each
/// against the property's type.
fn set_ply_scalars(
    ply: &mut PlyAttributes,
    (ei, pi): (usize, usize),
    old: &[f64],
    new: &[f64],
    key: &str,
) -> PyResult<()> {
    let prop = &mut ply.elements[ei].properties[pi];
    let PlyKind::Scalar(t) = prop.kind else {
        unreachable!("scalar columns have scalar kinds")
    };
    let PlyColumn::Scalars(values) = &mut prop.column else {
        unreachable!("a scalar property")
    };
    for (i, (&was, &v)) in old.iter().zip(new).enumerate() {
        if !same(was, v) {
            check_ply_value(v, t, key, i)?;
            values[i] = v;
        }
    }
    Ok(())
}

/// `vertex_properties` or `face_properties` of element `ei`: every name
/// must be one the file has, every array of the element's length.
fn apply_ply_properties(
    ply: &mut PlyAttributes,
    original: &PlyAttributes,
    ei: usize,
    edits: &Bound<'_, PyAny>,
    key: &str,
) -> PyResult<()> {
    let edits = edits
        .cast::<PyDict>()
        .map_err(|_| value_error(format!("{key}: expected a dict name → array")))?;
    let element = &original.elements[ei];
    for (name, value) in edits.iter() {
        let name = name
            .cast::<PyString>()
            .map_err(|_| value_error(format!("{key}: property names must be str")))?
            .to_string();
        let what = format!("{key}[{name:?}]");
        let found = ply_scalar_properties(original, ei)
            .into_iter()
            .find(|(_, n)| *n == name);
        let (pi, PlyColumn::Scalars(old)) = found
            .map(|(pi, _)| (pi, &element.properties[pi].column))
            .ok_or_else(|| {
                value_error(format!(
                    "{what}: the file's {} element has no scalar property {name:?} \
                     (properties cannot be added)",
                    element.name
                ))
            })?
        else {
            unreachable!("scalar properties have scalar columns")
        };
        let new = table_edit(&value, &what, &[element.count])?;
        set_ply_scalars(ply, (ei, pi), old, &new, &what)?;
    }
    Ok(())
}

/// Replaces, in each text tail whose row of `new` differs from `old`, the
/// numbers from token `start(number of tokens)` on with the row (the other
/// tokens stay as written).
fn set_tail_numbers(
    tails: &mut [String],
    start: impl Fn(usize) -> usize,
    old: &Table,
    new: &[f64],
) {
    let cols = old.cols;
    for (i, tail) in tails.iter_mut().enumerate() {
        let row = &new[i * cols..(i + 1) * cols];
        if row.iter().zip(old.row(i)).all(|(a, b)| same(*a, *b)) {
            continue;
        }
        let mut tokens: Vec<String> = tail.split_ascii_whitespace().map(String::from).collect();
        let at = start(tokens.len());
        for (k, v) in row.iter().enumerate() {
            tokens[at + k] = v.to_string();
        }
        *tail = tokens.join(" ");
    }
}

/// `vertex_colors`: the changed values go where the file keeps colours.
fn apply_colors(
    a: &mut Attributes,
    original: &Attributes,
    value: &Bound<'_, PyAny>,
) -> PyResult<()> {
    const KEY: &str = "vertex_colors";
    let source = color_source(original).ok_or_else(|| {
        value_error(format!(
            "{KEY}: the file has no vertex colours (attributes cannot be added)"
        ))
    })?;
    let old = read_colors(original, &source);
    let new = table_edit(value, KEY, &[old.rows(), old.cols])?;
    let text = !matches!(source, ColorSource::Ply { .. });
    if text && let Some(i) = new.iter().position(|v| !v.is_finite()) {
        return Err(value_error(format!(
            "{KEY}: value {} at row {} is not finite",
            new[i],
            i / old.cols
        )));
    }
    match (&mut a.content, source) {
        // `[w] r g b`: the colour is the last three numbers
        (FormatAttributes::Obj(obj), ColorSource::ObjTails) => {
            set_tail_numbers(&mut obj.vertex_tails, |n| n - 3, &old, &new);
        }
        (FormatAttributes::Off(off), ColorSource::OffTails { start, .. }) => {
            set_tail_numbers(&mut off.vertex_tails, |_| start, &old, &new);
        }
        (FormatAttributes::Ply(ply), ColorSource::Ply { properties }) => {
            let ve = ply.vertex_element;
            let column = |t: &[f64], k: usize| -> Vec<f64> {
                t.iter().skip(k).step_by(old.cols).copied().collect()
            };
            for (k, &pi) in properties.iter().enumerate() {
                let name = format!("{KEY} ({})", ply.elements[ve].properties[pi].name);
                let (was, now) = (column(&old.data, k), column(&new, k));
                set_ply_scalars(ply, (ve, pi), &was, &now, &name)?;
            }
        }
        _ => unreachable!("colour source of another format"),
    }
    Ok(())
}

fn apply_uv(obj: &mut ObjAttributes, value: &Bound<'_, PyAny>) -> PyResult<()> {
    const KEY: &str = "uv";
    let Some(old) = obj_uv(obj) else {
        return Err(value_error(format!(
            "{KEY}: the file has no texture coordinates (attributes cannot be added)"
        )));
    };
    let new = table_edit(value, KEY, &[old.rows(), old.cols])?;
    if let Some(i) = new.iter().position(|v| !v.is_finite()) {
        return Err(value_error(format!(
            "{KEY}: value {} at row {} is not finite",
            new[i],
            i / old.cols
        )));
    }
    for (i, t) in obj.texture_coords.iter_mut().enumerate() {
        let row = &new[i * old.cols..(i + 1) * old.cols];
        if row.iter().zip(old.row(i)).all(|(a, b)| same(*a, *b)) {
            continue;
        }
        // as many components as read, more when an omitted one is set
        let len = (t.len()..old.cols)
            .rev()
            .find(|&k| row[k] != 0.0)
            .map_or(t.len(), |k| k + 1);
        *t = row[..len].to_vec();
    }
    Ok(())
}

/// The entries of the dict (besides `_file`).
const KEYS: [&str; 11] = [
    "format",
    "encoding",
    "polygon_sizes",
    "warnings",
    "uv",
    "corner_uv",
    "colors",
    "corner_colors",
    "vertex_colors",
    "vertex_properties",
    "face_properties",
];

/// The file's attributes with the edits of the dict applied; an entry that
/// changed shape, a read-only entry that changed, or an unknown key is a
/// ValueError naming it.
pub(crate) fn apply_edits(
    file: &FileAttributes,
    edits: &Bound<'_, PyDict>,
) -> PyResult<Attributes> {
    let mut a = file.attributes.clone();
    let get = |key: &str| edits.get_item(key);
    for (key, _) in edits.iter() {
        let key = key.to_string();
        if key != "_file" && !KEYS.contains(&key.as_str()) {
            return Err(value_error(format!(
                "{key}: not an entry of read_mesh(..., attributes=True) (expected one of {})",
                KEYS.join(", ")
            )));
        }
    }
    for (key, expected) in [
        ("format", Some(format_name(&a))),
        ("encoding", encoding_name(&a)),
    ] {
        if let Some(value) = get(key)? {
            let given: Option<String> = value.extract().ok();
            if given.as_deref() != expected {
                return Err(value_error(format!(
                    "{key}: {value} differs from the file's {} (it cannot be edited; \
                     the output's format comes from its suffix)",
                    expected.unwrap_or("none")
                )));
            }
        }
    }
    if let Some(value) = get("polygon_sizes")? {
        let sizes: Vec<i64> = a.polygon_sizes.iter().map(|&n| i64::from(n)).collect();
        check_unchanged_ints(&value, "polygon_sizes", &sizes, &[sizes.len()])?;
    }
    // glTF: the values go into their accessors, the corners are read-only
    let gltf = matches!(a.content, FormatAttributes::Gltf(_));
    for (values_key, corners_key, attribute, fill) in GLTF_CORNER_KEYS {
        let (values, corners) = (get(values_key)?, get(corners_key)?);
        if !gltf || (values.is_none() && corners.is_none()) {
            continue;
        }
        let Some((table, original)) = gltf_entry(&a, values_key)? else {
            let key = if values.is_some() {
                values_key
            } else {
                corners_key
            };
            return Err(value_error(format!(
                "{key}: the file has no {attribute} (attributes cannot be added)"
            )));
        };
        if let Some(value) = corners {
            check_unchanged_ints(&value, corners_key, &original, &[original.len() / 3, 3])?;
        }
        if let (Some(value), FormatAttributes::Gltf(g)) = (values, &mut a.content) {
            apply_gltf_values(g, (values_key, attribute, fill), &table, &value)?;
        }
    }
    if let Some(value) = get("corner_uv")?
        && !gltf
    {
        let original = match &a.content {
            FormatAttributes::Obj(obj) if !obj.texture_coords.is_empty() => {
                obj_corner_uv(&a.polygon_sizes, obj)
            }
            _ => {
                return Err(value_error(
                    "corner_uv: the file has no texture coordinates (attributes cannot be added)",
                ));
            }
        };
        check_unchanged_ints(&value, "corner_uv", &original, &[original.len() / 3, 3])?;
    }
    if let Some(value) = get("uv")?
        && !gltf
    {
        match &mut a.content {
            FormatAttributes::Obj(obj) => apply_uv(obj, &value)?,
            _ => {
                return Err(value_error(
                    "uv: the file has no texture coordinates (attributes cannot be added)",
                ));
            }
        }
    }
    for key in ["colors", "corner_colors"] {
        if get(key)?.is_some() && !gltf {
            return Err(value_error(format!(
                "{key}: only glTF files have per-corner colours (this file's are vertex_colors, \
                 if any; attributes cannot be added)"
            )));
        }
    }
    for (key, face) in [("vertex_properties", false), ("face_properties", true)] {
        if let Some(value) = get(key)? {
            let (FormatAttributes::Ply(ply), FormatAttributes::Ply(original)) =
                (&mut a.content, &file.attributes.content)
            else {
                return Err(value_error(format!(
                    "{key}: only PLY files have properties"
                )));
            };
            let ei = if face {
                ply.face_element
                    .ok_or_else(|| value_error(format!("{key}: the file has no face element")))?
            } else {
                ply.vertex_element
            };
            apply_ply_properties(ply, original, ei, &value, key)?;
        }
    }
    if let Some(value) = get("vertex_colors")? {
        apply_colors(&mut a, &file.attributes, &value)?;
    }
    Ok(a)
}
