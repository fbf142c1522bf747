//! OBJ reader: `v x y z [w]` and `f` with `i`, `i/t`, `i//n`, `i/t/n`
//! corners (1-based, negative = relative to the vertices read so far);
//! polygons fan-triangulated. [`parse`] ignores every other statement
//! (`vt`, `vn`, `g`, `usemtl`, vendor extensions, …); [`parse_with_attributes`]
//! keeps them ([`ObjAttributes`]). `v`, `f` and `fo` are matched
//! case-insensitively; a line that does not start with a keyword (a letter
//! followed by letters, digits or `_`) is refused with its line number.

use super::{NO_INDEX, ObjAttributes, ObjStatement};
use crate::error::MeshError;
use crate::io::attributes::{ParsedWith, push_polygon_size};
use crate::io::{fan, is_integer, lines, parse_f64, parse_i64, perr, show, tokens};
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// Positions and fan triangles of an OBJ file.
pub(in crate::io) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    parse_into(bytes, path, None)
}

/// Positions, fan triangles, polygon sizes and the other statements.
pub(in crate::io) fn parse_with_attributes(
    bytes: &[u8],
    path: &Path,
) -> Result<ParsedWith<ObjAttributes>, MeshError> {
    let mut keep = Collector::default();
    let (positions, faces) = parse_into(bytes, path, Some(&mut keep))?;
    let attributes = keep.finish(path)?;
    Ok((positions, faces, attributes))
}

/// What [`parse_with_attributes`] gathers besides positions and triangles.
#[derive(Default)]
struct Collector {
    attributes: ObjAttributes,
    polygon_sizes: Vec<u32>,
    /// whether any vertex has a tail / any corner a texture or normal index
    any_tail: bool,
    any_texture: bool,
    any_normal: bool,
    /// corners whose texture / normal index reaches beyond the statements
    /// read so far: `(line, index)`, checked at the end
    forward_texture: Vec<(usize, u32)>,
    forward_normal: Vec<(usize, u32)>,
}

impl Collector {
    /// Counts one more statement of a run kind (`make` is the variant).
    fn run(&mut self, make: fn(u32) -> ObjStatement) {
        let statements = &mut self.attributes.statements;
        let kind = std::mem::discriminant(&make(0));
        let same_kind = statements
            .last()
            .is_some_and(|last| std::mem::discriminant(last) == kind);
        if same_kind
            && let Some(
                ObjStatement::Vertices(n)
                | ObjStatement::TextureCoords(n)
                | ObjStatement::Normals(n)
                | ObjStatement::Polygons(n),
            ) = statements.last_mut()
            && *n < u32::MAX
        {
            *n += 1;
            return;
        }
        statements.push(make(1));
    }

    /// A `vt` or `vn` statement: 1..=3 (`vt`) or exactly 3 (`vn`) numbers.
    fn values<'a>(
        line: &[u8],
        rest: &mut impl Iterator<Item = &'a [u8]>,
        what: &str,
        path: &Path,
        ln: usize,
    ) -> Result<Vec<f64>, MeshError> {
        let v: Vec<f64> = rest
            .map(|t| {
                parse_f64(t)
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| perr(path, ln, format!("{what}: bad number {:?}", show(t))))
            })
            .collect::<Result<_, _>>()?;
        let ok = match what {
            "texture coordinate" => (1..=3).contains(&v.len()),
            _ => v.len() == 3,
        };
        if !ok {
            return Err(perr(
                path,
                ln,
                format!("{what} has {} values: {:?}", v.len(), show(line)),
            ));
        }
        Ok(v)
    }

    /// Resolves a corner's texture or normal index (1-based, negative =
    /// relative to the `count` read so far) to 0-based.
    fn index(
        tok: &[u8],
        count: usize,
        what: &str,
        path: &Path,
        ln: usize,
        face: usize,
    ) -> Result<u32, MeshError> {
        let bad = || {
            perr(
                path,
                ln,
                format!("face {face}: bad {what} index {:?}", show(tok)),
            )
        };
        let i = parse_i64(tok).ok_or_else(bad)?;
        let abs = match i {
            0 => return Err(bad()),
            i if i > 0 => i - 1,
            i => count as i64 + i,
        };
        if abs < 0 || abs >= NO_INDEX as i64 {
            return Err(perr(
                path,
                ln,
                format!("face {face}: {what} index {i} out of range ({count} read so far)"),
            ));
        }
        Ok(abs as u32)
    }

    /// Any statement but `v`, `f` and comments: `vt` and `vn` parsed,
    /// `mtllib` kept as its names, everything else verbatim.
    fn statement<'a>(
        &mut self,
        kw: &[u8],
        line: &[u8],
        rest: &mut impl Iterator<Item = &'a [u8]>,
        path: &Path,
        ln: usize,
    ) -> Result<(), MeshError> {
        match kw {
            b"vt" => {
                let v = Collector::values(line, rest, "texture coordinate", path, ln)?;
                self.attributes.texture_coords.push(v);
                self.run(ObjStatement::TextureCoords);
            }
            b"vn" => {
                let v = Collector::values(line, rest, "normal", path, ln)?;
                self.attributes.normals.push([v[0], v[1], v[2]]);
                self.run(ObjStatement::Normals);
            }
            b"mtllib" => {
                let names = &line[line.len() - rest_len(line, kw)..];
                self.attributes
                    .statements
                    .push(ObjStatement::MaterialLibrary(
                        String::from_utf8_lossy(names.trim_ascii()).into_owned(),
                    ));
            }
            _ => self
                .attributes
                .statements
                .push(ObjStatement::Verbatim(line.to_vec())),
        }
        Ok(())
    }

    /// The texture and normal parts of a face corner `v/t/n` (after the
    /// vertex part), resolved against the statements read so far.
    fn corner<'a>(
        &mut self,
        parts: &mut impl Iterator<Item = &'a [u8]>,
        path: &Path,
        ln: usize,
        face: usize,
    ) -> Result<(), MeshError> {
        let texture = parts.next().filter(|p| !p.is_empty());
        let normal = parts.next().filter(|p| !p.is_empty());
        let resolve = |part: Option<&[u8]>, count: usize, what: &str, forward: &mut Vec<_>| {
            let Some(part) = part else {
                return Ok(NO_INDEX);
            };
            let i = Collector::index(part, count, what, path, ln, face)?;
            if i as usize >= count {
                forward.push((ln, i));
            }
            Ok::<u32, MeshError>(i)
        };
        let t = resolve(
            texture,
            self.attributes.texture_coords.len(),
            "texture coordinate",
            &mut self.forward_texture,
        )?;
        let n = resolve(
            normal,
            self.attributes.normals.len(),
            "normal",
            &mut self.forward_normal,
        )?;
        self.any_texture |= t != NO_INDEX;
        self.any_normal |= n != NO_INDEX;
        self.attributes.corner_texture_coords.push(t);
        self.attributes.corner_normals.push(n);
        Ok(())
    }

    fn finish(mut self, path: &Path) -> Result<(Vec<u32>, ObjAttributes), MeshError> {
        let a = &mut self.attributes;
        for (forward, count, what) in [
            (
                &self.forward_texture,
                a.texture_coords.len(),
                "texture coordinate",
            ),
            (&self.forward_normal, a.normals.len(), "normal"),
        ] {
            if let Some(&(ln, i)) = forward.iter().find(|(_, i)| *i as usize >= count) {
                return Err(perr(
                    path,
                    ln,
                    format!("refers to {what} {} but the file has {count}", i + 1),
                ));
            }
        }
        if !self.any_tail {
            a.vertex_tails = Vec::new();
        }
        if !self.any_texture {
            a.corner_texture_coords = Vec::new();
        }
        if !self.any_normal {
            a.corner_normals = Vec::new();
        }
        Ok((self.polygon_sizes, self.attributes))
    }
}

/// The one OBJ parser; `keep` gathers the attributes when given.
fn parse_into(
    bytes: &[u8],
    path: &Path,
    mut keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(bytes.len() / 64);
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(bytes.len() / 32);
    // Faces with a corner beyond the vertices read so far (forward
    // references): checked once all vertices are known.
    let mut forward: Vec<(usize, usize, u64)> = Vec::new();
    let mut poly: Vec<u32> = Vec::with_capacity(8);
    for (ln, line) in lines(bytes) {
        let mut tok = tokens(line);
        let Some(kw) = tok.next() else { continue };
        if kw[0] == b'#' {
            if let Some(k) = keep.as_deref_mut() {
                k.attributes
                    .statements
                    .push(ObjStatement::Verbatim(line.to_vec()));
            }
            continue;
        }
        let kw = match kw {
            [b'v' | b'V'] => b"v".as_slice(),
            [b'f' | b'F'] => b"f",
            [b'f' | b'F', b'o' | b'O'] => b"f",
            _ if is_keyword(kw) => {
                if let Some(k) = keep.as_deref_mut() {
                    k.statement(kw, line, &mut tok, path, ln)?;
                }
                continue;
            }
            _ => {
                return Err(perr(
                    path,
                    ln,
                    format!(
                        "unexpected {:?} at the start of the line, expected an OBJ statement (v, f, vt, ...)",
                        show(kw)
                    ),
                ));
            }
        };
        match kw {
            b"v" => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let t = tok.next().ok_or_else(|| {
                        perr(
                            path,
                            ln,
                            format!("vertex {} has {k} coordinates, expected 3", positions.len()),
                        )
                    })?;
                    *c = parse_f64(t).ok_or_else(|| {
                        perr(
                            path,
                            ln,
                            format!("vertex {}: bad coordinate {:?}", positions.len(), show(t)),
                        )
                    })?;
                    if !c.is_finite() {
                        return Err(perr(
                            path,
                            ln,
                            format!(
                                "vertex {}: non-finite coordinate {:?}",
                                positions.len(),
                                show(t)
                            ),
                        ));
                    }
                }
                positions.push(p);
                if let Some(k) = keep.as_deref_mut() {
                    let tail = match tok.next() {
                        Some(t) => {
                            let start = t.as_ptr() as usize - line.as_ptr() as usize;
                            String::from_utf8_lossy(line[start..].trim_ascii()).into_owned()
                        }
                        None => String::new(),
                    };
                    k.any_tail |= !tail.is_empty();
                    k.attributes.vertex_tails.push(tail);
                    k.run(ObjStatement::Vertices);
                }
            }
            _ => {
                poly.clear();
                let nv = positions.len() as i64;
                for t in tok {
                    let mut parts = t.split(|&b| b == b'/');
                    let idx = parts.next().unwrap_or(t);
                    if let Some(k) = keep.as_deref_mut() {
                        k.corner(&mut parts, path, ln, faces.len())?;
                    }
                    let i = parse_i64(idx).ok_or_else(|| {
                        let what = if is_integer(idx) {
                            "vertex index out of range"
                        } else {
                            "bad vertex index"
                        };
                        perr(
                            path,
                            ln,
                            format!("face {}: {what} {:?}", faces.len(), show(t)),
                        )
                    })?;
                    let abs = if i > 0 {
                        i - 1
                    } else if i < 0 {
                        nv + i
                    } else {
                        return Err(perr(
                            path,
                            ln,
                            format!(
                                "face {}: vertex index 0 (OBJ indices start at 1)",
                                faces.len()
                            ),
                        ));
                    };
                    if abs < 0 {
                        return Err(perr(
                            path,
                            ln,
                            format!(
                                "face {}: relative index {i} reaches before the first vertex ({nv} read so far)",
                                faces.len()
                            ),
                        ));
                    }
                    if abs > u32::MAX as i64 - 1 {
                        return Err(perr(
                            path,
                            ln,
                            format!(
                                "face {}: vertex index out of range {:?}",
                                faces.len(),
                                show(t)
                            ),
                        ));
                    }
                    if abs >= nv {
                        forward.push((ln, faces.len(), abs as u64));
                    }
                    poly.push(abs as u32);
                }
                if poly.len() < 3 {
                    return Err(perr(
                        path,
                        ln,
                        format!(
                            "face {} has {} vertices, expected at least 3",
                            faces.len(),
                            poly.len()
                        ),
                    ));
                }
                fan(&poly, &mut faces);
                if let Some(k) = keep.as_deref_mut() {
                    push_polygon_size(&mut k.polygon_sizes, poly.len(), path, ln)?;
                    k.run(ObjStatement::Polygons);
                }
            }
        }
    }
    let nv = positions.len();
    if let Some(&(ln, face, index)) = forward.iter().find(|(_, _, i)| *i as usize >= nv) {
        return Err(perr(
            path,
            ln,
            format!(
                "face {face} refers to vertex {} but the file has {nv} vertices",
                index + 1
            ),
        ));
    }
    Ok((positions, faces))
}

/// An OBJ statement keyword: an ASCII letter, then letters, digits or `_`.
fn is_keyword(tok: &[u8]) -> bool {
    tok[0].is_ascii_alphabetic() && tok.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'_')
}

/// Length of what follows the keyword `kw` at the start of `line`.
fn rest_len(line: &[u8], kw: &[u8]) -> usize {
    let start = kw.as_ptr() as usize - line.as_ptr() as usize;
    line.len() - start - kw.len()
}
