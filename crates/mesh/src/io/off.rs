//! Object File Format: `[C][N][ST]OFF` header (counts may follow on the same
//! line), `#V #F #E`, one vertex per line (extra columns such as colours
//! ignored), one polygon per line `n i_1 … i_n [colour]` (0-based,
//! fan-triangulated). The header keyword is matched case-insensitively
//! (`OFF`, `off`, `COFF`, `NOFF`, `STCNOFF`, …); binary, 4D and n-dimensional
//! (`nOFF`) files are refused. [`parse_with_attributes`] keeps the header
//! keyword and what follows each vertex's coordinates and each face's
//! indices (colours, normals, texture coordinates) as written
//! ([`OffAttributes`]); [`write_with_attributes`] writes them back, the
//! vertex normals of an `NOFF` file recomputed.

use super::attributes::{ParsedWith, Polygons, push_polygon_size};
use super::{fan, lines, parse_f64, parse_u64, perr, show, tokens};
use crate::error::MeshError;
use crate::mesh::Mesh;
use std::io::Write;
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// What an OFF file holds beyond positions and triangles.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct OffAttributes {
    /// the header keyword as written (`OFF`, `COFF`, `NOFF`, `STCOFF`, …)
    pub keyword: String,
    /// per vertex, the text after x y z (normal, colour, texture
    /// coordinates), trimmed; empty when no vertex has any (len #V or 0)
    pub vertex_tails: Vec<String>,
    /// per polygon, the text after its indices (a colour), trimmed; empty
    /// when no face has any (len #polygons or 0)
    pub face_tails: Vec<String>,
    /// number of comments (`#` to the line end) read past
    pub comments_dropped: usize,
}

impl OffAttributes {
    /// Whether the vertices carry normals (`N` in the header keyword): the
    /// first three values of each vertex tail, recomputed on writing.
    pub fn has_vertex_normals(&self) -> bool {
        let upper = self.keyword.to_ascii_uppercase();
        upper
            .strip_suffix("OFF")
            .is_some_and(|prefix| prefix.ends_with('N'))
    }
}

/// What [`parse_with_attributes`] gathers on the way.
#[derive(Default)]
struct Collector {
    attributes: OffAttributes,
    polygon_sizes: Vec<u32>,
}

/// The trimmed text of `line` from the token `t` (a slice of it) on.
fn tail_from(line: &[u8], t: Option<&[u8]>) -> String {
    match t {
        Some(t) => {
            let start = t.as_ptr() as usize - line.as_ptr() as usize;
            String::from_utf8_lossy(line[start..].trim_ascii()).into_owned()
        }
        None => String::new(),
    }
}

/// Positions, fan triangles, polygon sizes and the attributes of an OFF file.
pub(super) fn parse_with_attributes(
    bytes: &[u8],
    path: &Path,
) -> Result<ParsedWith<OffAttributes>, MeshError> {
    let mut keep = Collector::default();
    let (positions, faces) = parse_into(bytes, path, Some(&mut keep))?;
    let mut a = keep.attributes;
    if a.vertex_tails.iter().all(String::is_empty) {
        a.vertex_tails = Vec::new();
    }
    if a.face_tails.iter().all(String::is_empty) {
        a.face_tails = Vec::new();
    }
    Ok((positions, faces, (keep.polygon_sizes, a)))
}

/// Positions and fan triangles of an OFF file.
pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    parse_into(bytes, path, None)
}

/// The one OFF parser; `keep` gathers the attributes when given.
fn parse_into(
    bytes: &[u8],
    path: &Path,
    mut keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    let mut comments = 0;
    // Non-empty, comment-stripped lines.
    let mut it = lines(bytes).filter_map(|(ln, l)| {
        let l = match l.iter().position(|&b| b == b'#') {
            Some(i) => {
                comments += 1;
                &l[..i]
            }
            None => l,
        };
        if tokens(l).next().is_some() {
            Some((ln, l))
        } else {
            None
        }
    });
    let Some((ln, first)) = it.next() else {
        return Err(perr(path, 0, "no mesh in file: empty OFF file"));
    };
    let mut head = tokens(first);
    let kw = head.next().unwrap_or_default();
    header(kw).map_err(|m| perr(path, ln, m))?;
    if let Some(k) = keep.as_deref_mut() {
        k.attributes.keyword = String::from_utf8_lossy(kw).into_owned();
    }
    let mut counts: Vec<(usize, &[u8])> = head.map(|t| (ln, t)).collect();
    if counts
        .first()
        .is_some_and(|(_, t)| t.eq_ignore_ascii_case(b"BINARY"))
    {
        return Err(perr(path, ln, "binary OFF is not supported"));
    }
    while counts.len() < 2 {
        let Some((ln, l)) = it.next() else {
            return Err(perr(
                path,
                ln,
                "file ends before the vertex and face counts",
            ));
        };
        counts.extend(tokens(l).map(|t| (ln, t)));
    }
    let count = |k: usize| -> Result<usize, MeshError> {
        let (ln, t) = counts[k];
        parse_u64(t)
            .map(|v| v as usize)
            .ok_or_else(|| perr(path, ln, format!("bad element count {:?}", show(t))))
    };
    let (nv, nf) = (count(0)?, count(1)?);
    if nv > u32::MAX as usize || nf > u32::MAX as usize {
        return Err(perr(
            path,
            ln,
            format!("element counts too large: {nv} vertices, {nf} faces"),
        ));
    }
    let mut positions = Vec::with_capacity(nv.min(bytes.len() / 6));
    let mut last = ln;
    for v in 0..nv {
        let Some((ln, l)) = it.next() else {
            return Err(perr(
                path,
                last,
                format!("file ends after {v} of {nv} vertices"),
            ));
        };
        last = ln;
        let mut p = [0.0; 3];
        let mut tok = tokens(l);
        for (k, c) in p.iter_mut().enumerate() {
            let t = tok.next().ok_or_else(|| {
                perr(
                    path,
                    ln,
                    format!("vertex {v} has {k} coordinates, expected 3"),
                )
            })?;
            *c = parse_f64(t).ok_or_else(|| {
                perr(
                    path,
                    ln,
                    format!("vertex {v}: bad coordinate {:?}", show(t)),
                )
            })?;
            if !c.is_finite() {
                return Err(perr(
                    path,
                    ln,
                    format!("vertex {v}: non-finite coordinate {:?}", show(t)),
                ));
            }
        }
        positions.push(p);
        if let Some(k) = keep.as_deref_mut() {
            k.attributes.vertex_tails.push(tail_from(l, tok.next()));
        }
    }
    let mut faces = Vec::with_capacity(nf.min(bytes.len() / 6));
    let mut poly = Vec::with_capacity(8);
    for f in 0..nf {
        let Some((ln, l)) = it.next() else {
            return Err(perr(
                path,
                last,
                format!("file ends after {f} of {nf} faces"),
            ));
        };
        last = ln;
        let mut tok = tokens(l);
        let t = tok.next().unwrap_or_default();
        let n = parse_u64(t).ok_or_else(|| {
            perr(
                path,
                ln,
                format!("face {f}: bad corner count {:?}", show(t)),
            )
        })?;
        if n < 3 {
            return Err(perr(
                path,
                ln,
                format!("face {f} has {n} vertices, expected at least 3"),
            ));
        }
        poly.clear();
        for k in 0..n {
            let t = tok
                .next()
                .ok_or_else(|| perr(path, ln, format!("face {f} lists {k} of its {n} vertices")))?;
            let i = parse_u64(t).ok_or_else(|| {
                perr(
                    path,
                    ln,
                    format!("face {f}: bad vertex index {:?}", show(t)),
                )
            })?;
            if i as usize >= nv {
                return Err(perr(
                    path,
                    ln,
                    format!("face {f} refers to vertex {i} but the file has {nv} vertices"),
                ));
            }
            poly.push(i as u32);
        }
        fan(&poly, &mut faces);
        if let Some(k) = keep.as_deref_mut() {
            k.attributes.face_tails.push(tail_from(l, tok.next()));
            push_polygon_size(&mut k.polygon_sizes, poly.len(), path, ln)?;
        }
    }
    if let Some((ln, _)) = it.next() {
        return Err(perr(
            path,
            ln,
            format!("data after the {nv} vertices and {nf} faces the header announces"),
        ));
    }
    drop(it);
    if let Some(k) = keep {
        k.attributes.comments_dropped = comments;
    }
    Ok((positions, faces))
}

/// Checks the header keyword `[ST][C][N]OFF` (any case); the error says why not.
fn header(kw: &[u8]) -> Result<(), String> {
    let upper = kw.to_ascii_uppercase();
    let expected = || format!("expected an OFF header, found {:?}", show(kw));
    let prefix = upper.strip_suffix(b"OFF").ok_or_else(expected)?;
    // nOFF (lowercase n by the specification) is the dimension-n variant.
    if prefix.contains(&b'4') || kw[..prefix.len()].ends_with(b"n") {
        return Err(format!(
            "{:?}: only 3D OFF is supported (4OFF / nOFF are not)",
            show(kw)
        ));
    }
    let rest = prefix.strip_prefix(b"ST").unwrap_or(prefix);
    let rest = rest.strip_prefix(b"C").unwrap_or(rest);
    let rest = rest.strip_prefix(b"N").unwrap_or(rest);
    if rest.is_empty() {
        Ok(())
    } else {
        Err(expected())
    }
}

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> std::io::Result<()> {
    writeln!(w, "OFF\n{} {} 0", mesh.num_vertices(), mesh.num_faces())?;
    for p in &mesh.positions {
        writeln!(w, "{} {} {}", p[0], p[1], p[2])?;
    }
    for f in &mesh.faces {
        writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
    }
    Ok(())
}

/// Writes `mesh` with the header keyword, vertex tails and face tails of
/// `off` (a triangle of a triangulated polygon takes its polygon's); the
/// normals of an `NOFF` file are recomputed (area-weighted).
pub(super) fn write_with_attributes(
    w: &mut dyn Write,
    mesh: &Mesh,
    polygons: &Polygons,
    off: &OffAttributes,
) -> std::io::Result<()> {
    let keyword = if off.keyword.is_empty() {
        "OFF"
    } else {
        &off.keyword
    };
    writeln!(
        w,
        "{keyword}\n{} {} 0",
        mesh.num_vertices(),
        polygons.count()
    )?;
    let normals = off
        .has_vertex_normals()
        .then(|| crate::geometry::area_weighted_vertex_normals(mesh));
    for (v, p) in mesh.positions.iter().enumerate() {
        write!(w, "{} {} {}", p[0], p[1], p[2])?;
        let tail = off.vertex_tails.get(v).map(String::as_str).unwrap_or("");
        match &normals {
            Some(n) => {
                let n = n[v];
                let rest: Vec<&str> = tail.split_ascii_whitespace().skip(3).collect();
                write!(w, " {} {} {}", n[0], n[1], n[2])?;
                for t in rest {
                    write!(w, " {t}")?;
                }
            }
            None if !tail.is_empty() => write!(w, " {tail}")?,
            None => {}
        }
        writeln!(w)?;
    }
    for polygon in polygons.iter(&mesh.positions) {
        write!(w, "{}", polygon.vertices.len())?;
        for v in &polygon.vertices {
            write!(w, " {v}")?;
        }
        match off.face_tails.get(polygon.source) {
            Some(tail) if !tail.is_empty() => writeln!(w, " {tail}")?,
            _ => writeln!(w)?,
        }
    }
    Ok(())
}
