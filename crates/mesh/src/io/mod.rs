//! Mesh file I/O (SPEC §1): OBJ, OFF, PLY (ASCII and binary), STL (ASCII
//! and binary) and glTF 2.0 (`.gltf` and `.glb`) readers and writers.
//!
//! Policy, identical for every format:
//! - vertex order and face order of the file are kept; polygons are
//!   fan-triangulated `(v0, v_i, v_{i+1})` in file order, so the error metrics
//!   can compare meshes face by face. glTF is the exception by nature: its
//!   mesh is every triangle primitive of the scene in world space (node
//!   transforms applied), the primitives' vertices welded by exactly equal
//!   world positions in order of first appearance, their triangles in
//!   order ([`attributes`] and the glTF module say how it is written back);
//! - [`read_mesh`] reads past attributes other than positions and face
//!   indices (texture coordinates, normals, colours, extra PLY properties,
//!   groups, materials) and [`write_mesh`] writes positions and triangles
//!   only; [`read_mesh_file`] / [`write_mesh_file`] keep them
//!   ([`attributes`] says what each format keeps);
//! - only STL, which has no shared vertices, and glTF, whose primitives
//!   split at material and UV seams, merge bit-identical coincident
//!   vertices (in order of first appearance);
//! - any defect (truncated file, bad index, non-finite coordinate, wrong
//!   element count, empty file, a line that is no statement of the format)
//!   is a [`MeshError`] naming the file and the line (text) or byte offset /
//!   element (binary); the readers never panic;
//! - text is read as it comes from any editor: a UTF-8 byte-order mark at the
//!   start is skipped, lines may end in `\n`, `\r\n` or (old Mac) `\r`, and
//!   keywords are matched case-insensitively where writers are known to vary
//!   (OBJ `v`/`f`, the OFF header, every ASCII STL keyword);
//! - writers print coordinates in the shortest decimal form that reads back
//!   to the same `f64` (text formats), or the exact bits (binary PLY); STL and
//!   glTF are f32 by definition (a glTF of another format's mesh: one node,
//!   one primitive, u32 indices, its buffer a `data:` URI or the GLB BIN
//!   chunk). Output is written to a temporary file in the target
//!   directory and renamed into place, so a crash never leaves half a mesh;
//!   an output that is a symbolic link is written through (its target gets
//!   the mesh, the link stays) and a read-only output file is refused.

pub mod attributes;
mod gltf;
mod obj;
mod off;
mod ply;
mod stl;

pub use attributes::{
    Attributes, FileWriteOptions, FormatAttributes, MeshFile, encode_mesh_file, parse_mesh_file,
    read_mesh_file, read_mesh_file_as, write_mesh_file, write_mesh_file_as,
};
pub use obj::NO_INDEX;

use crate::error::MeshError;
use crate::mesh::Mesh;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ (`v`, `f`).
    Obj,
    /// Object File Format (`OFF` header, counts, vertices, polygons).
    Off,
    /// Stanford PLY, ASCII or binary (the header says which); written as
    /// binary little endian unless [`WriteOptions::ply_ascii`] is set.
    Ply,
    /// STL, ASCII or binary (detected from the content); written as binary.
    Stl,
    /// glTF 2.0 as JSON (`.gltf`; buffers in `data:` URIs or files beside
    /// it). A GLB file is read whatever its extension (told by content).
    Gltf,
    /// glTF 2.0 binary (`.glb`: JSON chunk and BIN chunk).
    Glb,
}

impl Format {
    /// The format named by the file extension (case-insensitive), if any.
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(Format::Obj),
            "off" => Some(Format::Off),
            "ply" => Some(Format::Ply),
            "stl" => Some(Format::Stl),
            "gltf" => Some(Format::Gltf),
            "glb" => Some(Format::Glb),
            _ => None,
        }
    }

    /// The format's usual name in text: `OBJ`, `OFF`, `PLY`, `STL`,
    /// `glTF`, `GLB`.
    pub fn name(self) -> &'static str {
        match self {
            Format::Obj => "OBJ",
            Format::Off => "OFF",
            Format::Ply => "PLY",
            Format::Stl => "STL",
            Format::Gltf => "glTF",
            Format::Glb => "GLB",
        }
    }

    /// Whether this is one of the two containers of glTF 2.0 (`.gltf`,
    /// `.glb`), between which the attribute writers convert.
    pub fn is_gltf(self) -> bool {
        matches!(self, Format::Gltf | Format::Glb)
    }

    /// Parses a format name (`obj`, `off`, `ply`, `stl`, `gltf`, `glb`;
    /// case-insensitive).
    pub fn from_name(name: &str) -> Option<Format> {
        Format::from_path(Path::new(&format!("x.{name}")))
    }
}

/// Options of the writers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// Write PLY as ASCII instead of binary little endian.
    pub ply_ascii: bool,
}

fn format_of(path: &Path) -> Result<Format, MeshError> {
    Format::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
        path: path.to_path_buf(),
    })
}

/// Reads a mesh, choosing the format from the extension.
///
/// # Errors
/// [`MeshError::UnknownFormat`], [`MeshError::Io`], [`MeshError::Parse`] and
/// the invariant errors of [`Mesh::new`] (wrapped as `Parse` with the file).
pub fn read_mesh(path: impl AsRef<Path>) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    read_mesh_as(path, format_of(path)?)
}

/// Reads a mesh in the given format, whatever the extension.
///
/// # Errors
/// As [`read_mesh`].
pub fn read_mesh_as(path: impl AsRef<Path>, format: Format) -> Result<Mesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_mesh_in(&bytes, format, path, Some(&target_dir(path)))
}

/// Parses a mesh from memory; `path` is only used in error messages (a
/// `.gltf` whose buffers are files is refused: [`read_mesh`] reads them).
///
/// # Errors
/// As [`read_mesh`].
pub fn parse_mesh(bytes: &[u8], format: Format, path: &Path) -> Result<Mesh, MeshError> {
    parse_mesh_in(bytes, format, path, None)
}

/// [`parse_mesh`]; `dir` is the folder a `.gltf`'s buffer files are read
/// from (`None`: refused).
fn parse_mesh_in(
    bytes: &[u8],
    format: Format,
    path: &Path,
    dir: Option<&Path>,
) -> Result<Mesh, MeshError> {
    let (positions, faces) = match format {
        Format::Obj => obj::parse(strip_bom(bytes), path)?,
        Format::Off => off::parse(strip_bom(bytes), path)?,
        Format::Ply => ply::parse(strip_bom(bytes), path)?,
        // A binary STL header is 80 arbitrary bytes: the reader strips the
        // mark only once it knows the file is text.
        Format::Stl => stl::parse(bytes, path)?,
        Format::Gltf | Format::Glb => gltf::parse(bytes, path, dir)?,
    };
    finish(positions, faces, path)
}

/// Builds the mesh, turning invariant errors into errors naming the file.
fn finish(positions: Vec<[f64; 3]>, faces: Vec<[u32; 3]>, path: &Path) -> Result<Mesh, MeshError> {
    if positions.is_empty() || faces.is_empty() {
        return Err(perr(
            path,
            0,
            format!(
                "no mesh in file: {} vertices, {} faces",
                positions.len(),
                faces.len()
            ),
        ));
    }
    Mesh::new(positions, faces).map_err(|e| match e {
        MeshError::Parse { .. } | MeshError::Io { .. } => e,
        other => perr(path, 0, other.to_string()),
    })
}

/// Writes a mesh atomically, choosing the format from the extension.
///
/// # Errors
/// [`MeshError::UnknownFormat`], [`MeshError::Io`].
pub fn write_mesh(path: impl AsRef<Path>, mesh: &Mesh) -> Result<(), MeshError> {
    let path = path.as_ref();
    write_mesh_as(path, mesh, format_of(path)?, &WriteOptions::default())
}

/// Writes a mesh atomically in the given format.
///
/// # Errors
/// [`MeshError::Io`].
pub fn write_mesh_as(
    path: impl AsRef<Path>,
    mesh: &Mesh,
    format: Format,
    options: &WriteOptions,
) -> Result<(), MeshError> {
    let path = path.as_ref();
    write_atomically(path, |w| write_format(w, mesh, format, options))
}

/// Writes `mesh` in `format` to `w` (the one dispatch of every writer).
fn write_format(
    w: &mut dyn Write,
    mesh: &Mesh,
    format: Format,
    options: &WriteOptions,
) -> std::io::Result<()> {
    match format {
        Format::Obj => obj::write(w, mesh),
        Format::Off => off::write(w, mesh),
        Format::Ply => ply::write(w, mesh, options.ply_ascii),
        Format::Stl => stl::write(w, mesh),
        Format::Gltf => gltf::write(w, mesh, gltf::GltfContainer::Json),
        Format::Glb => gltf::write(w, mesh, gltf::GltfContainer::Binary),
    }
}

/// Checks, before any work, that `format` can hold `mesh`: STL and glTF
/// store f32, so every coordinate must lie within its range (the text
/// formats and PLY hold any f64). `path` is the output, named in the error.
///
/// # Errors
/// [`MeshError::Io`] (`InvalidData`) naming `path` and the first vertex out
/// of range, as [`write_mesh_as`] would fail.
pub fn check_encodable(path: &Path, mesh: &Mesh, format: Format) -> Result<(), MeshError> {
    match format {
        Format::Stl => stl::check_range(mesh),
        Format::Gltf | Format::Glb => gltf::check_range(mesh),
        Format::Obj | Format::Off | Format::Ply => Ok(()),
    }
    .map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Encodes a mesh into memory (what [`write_mesh_as`] would write).
///
/// # Errors
/// A mesh the format cannot hold (STL, glTF: a coordinate beyond f32's
/// range).
pub fn encode_mesh(
    mesh: &Mesh,
    format: Format,
    options: &WriteOptions,
) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    write_format(&mut out, mesh, format, options)?;
    Ok(out)
}

/// The folder [`write_atomically`] puts its temporary file in: the parent of
/// `path`, or `.` for a bare file name.
fn target_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The file a write to `path` replaces: `path`, or, when `path` is a
/// symbolic link, the file it points to (followed through up to 40 links;
/// the target need not exist yet). Writing there keeps the link a link.
pub fn write_target(path: &Path) -> PathBuf {
    let mut target = path.to_path_buf();
    for _ in 0..40 {
        let Ok(next) = std::fs::read_link(&target) else {
            break;
        };
        // a relative link is relative to the folder holding it
        target = match target.parent() {
            Some(dir) => dir.join(next),
            None => next,
        };
    }
    target
}

/// Whether `path` is an existing file without write permission, which the
/// atomic rename would replace anyway (and root could write).
fn is_read_only(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().readonly())
}

/// The reason given for a read-only output file.
const READ_ONLY: &str = "output not writable (read-only file)";

/// Prefix of the temporary files of [`write_atomically`]:
/// `.normalnet-<process id>-`, so that a process can find (and remove) its
/// own leftovers after an interruption without touching another's.
pub fn temp_prefix() -> String {
    format!(".normalnet-{}-", std::process::id())
}

/// Checks, before any work, that [`write_atomically`] can write `path`: its
/// folder exists and is a folder, a temporary file can be created in it
/// (created and removed at once), and `path` itself is not a folder nor a
/// read-only file. A symbolic link is checked at its target
/// ([`write_target`]). The extension is not looked at (callers know which
/// ones they write).
///
/// # Errors
/// [`MeshError::Io`] naming `path` or its folder, with the reason.
pub fn check_writable(path: &Path) -> Result<(), MeshError> {
    let target = write_target(path);
    let dir = target_dir(&target);
    let fail = |p: &Path, kind: std::io::ErrorKind, why: String| MeshError::Io {
        path: p.to_path_buf(),
        source: std::io::Error::new(kind, why),
    };
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(fail(
                &dir,
                std::io::ErrorKind::NotADirectory,
                "not a folder, cannot write into it".into(),
            ));
        }
        Err(e) => {
            return Err(fail(
                &dir,
                e.kind(),
                format!("output folder cannot be used ({e})"),
            ));
        }
    }
    if path.is_dir() {
        return Err(fail(
            path,
            std::io::ErrorKind::IsADirectory,
            "is a folder, expected a file name".into(),
        ));
    }
    if is_read_only(&target) {
        return Err(fail(
            path,
            std::io::ErrorKind::PermissionDenied,
            READ_ONLY.into(),
        ));
    }
    tempfile::Builder::new()
        .prefix(&temp_prefix())
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map(drop)
        .map_err(|e| {
            fail(
                &dir,
                e.kind(),
                format!("output folder is not writable ({e})"),
            )
        })
}

/// Runs `body` on a buffered temporary file next to `path`, then renames the
/// temporary file onto `path`. On any error the temporary file is removed
/// (named [`temp_prefix`] + random + `.tmp`, in the folder of `path`). A
/// symbolic link `path` is written through: its target ([`write_target`])
/// is replaced and the link stays.
///
/// # Errors
/// [`MeshError::Io`] naming `path`: a read-only existing file (refused
/// before `body` runs), or any error creating, writing or renaming.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    let io = |source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    };
    let target = write_target(path);
    if is_read_only(&target) {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::PermissionDenied,
            READ_ONLY,
        )));
    }
    let dir = target_dir(&target);
    let tmp = tempfile::Builder::new()
        .prefix(&temp_prefix())
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(io)?;
    {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, tmp.as_file());
        body(&mut w).map_err(io)?;
        w.flush().map_err(io)?;
    }
    // tempfile creates 0600 files: give the result the permissions of the
    // file it replaces, or the usual 0644 for a new file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let perm = std::fs::metadata(&target)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
        tmp.as_file().set_permissions(perm).map_err(io)?;
    }
    tmp.persist(&target).map_err(|e| io(e.error))?;
    Ok(())
}

/// A parse error at `line` (0: whole file / binary) of `path`.
pub(crate) fn perr(path: &Path, line: usize, message: impl Into<String>) -> MeshError {
    MeshError::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Splits a line into whitespace-separated tokens.
#[inline]
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// Parses a finite f64 from a token.
#[inline]
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    let s = std::str::from_utf8(tok).ok()?;
    s.parse::<f64>().ok()
}

/// Parses an unsigned integer from a token.
#[inline]
pub(crate) fn parse_u64(tok: &[u8]) -> Option<u64> {
    if tok.is_empty() || tok.len() > 19 {
        return None;
    }
    let mut v: u64 = 0;
    for &b in tok {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (b - b'0') as u64;
    }
    Some(v)
}

/// Parses a signed integer from a token; `None` also when it lies outside
/// the range of i64 (checked, never wrapped).
#[inline]
pub(crate) fn parse_i64(tok: &[u8]) -> Option<i64> {
    match tok.first() {
        Some(b'-') => parse_u64(&tok[1..]).and_then(|v| 0i64.checked_sub_unsigned(v)),
        Some(b'+') => parse_u64(&tok[1..]).and_then(|v| i64::try_from(v).ok()),
        _ => parse_u64(tok).and_then(|v| i64::try_from(v).ok()),
    }
}

/// Whether a token is written as an integer (optional sign, then digits),
/// whatever its size: tells an index out of range from one that is no
/// number.
#[inline]
pub(crate) fn is_integer(tok: &[u8]) -> bool {
    let digits = tok
        .strip_prefix(b"-")
        .or(tok.strip_prefix(b"+"))
        .unwrap_or(tok);
    !digits.is_empty() && digits.iter().all(u8::is_ascii_digit)
}

/// Lossy printable form of a token for error messages.
pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned();
    if tok.len() > 40 { format!("{s}…") } else { s }
}

/// Appends the fan triangulation of `poly` to `faces`.
#[inline]
pub(crate) fn fan(poly: &[u32], faces: &mut Vec<[u32; 3]>) {
    for i in 1..poly.len() - 1 {
        faces.push([poly[0], poly[i], poly[i + 1]]);
    }
}

/// The UTF-8 byte-order mark some Windows editors put at the start of text.
pub(crate) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// `bytes` without a leading UTF-8 byte-order mark.
#[inline]
pub(crate) fn strip_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(BOM).unwrap_or(bytes)
}

/// Iterates lines (without `\n` / `\r\n`) with 1-based numbers. A file
/// without any `\n` but with `\r` (classic Mac line ends) is split at `\r`.
/// Every `\r` at a line's end goes (`\r\r\n` too), so that a line kept
/// verbatim reads back the same after it is written with `\n`.
pub(crate) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let sep = if !bytes.contains(&b'\n') && bytes.contains(&b'\r') {
        b'\r'
    } else {
        b'\n'
    };
    let bytes = bytes.strip_suffix(&[sep]).unwrap_or(bytes);
    bytes
        .split(move |&b| b == sep)
        .enumerate()
        .map(|(i, l)| (i + 1, without_trailing_cr(l)))
}

/// `line` without every `\r` at its end (`\r\r\n` ends leave none).
#[inline]
pub(crate) fn without_trailing_cr(line: &[u8]) -> &[u8] {
    let end = line.iter().rposition(|&b| b != b'\r').map_or(0, |k| k + 1);
    &line[..end]
}

#[cfg(test)]
mod tests;
