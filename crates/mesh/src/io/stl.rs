//! STL, binary (80-byte header, u32 count, 50 bytes per triangle) and ASCII
//! (`solid … facet normal … outer loop vertex ×3 endloop endfacet … endsolid`).
//! STL stores each triangle's corners separately: bit-identical corners are
//! merged into one vertex (first appearance order); nothing else is merged.
//! The stored facet normals are ignored. [`parse_with_attributes`] also
//! keeps the binary header and each facet's 2-byte attribute, or the ASCII
//! solid's name and each facet's corner count ([`StlAttributes`]);
//! [`write_with_attributes`] writes them back, normals recomputed.
//!
//! Binary or ASCII is decided by the size rule first (a binary file has
//! exactly 84 + 50·n bytes, whatever its header says), then by the content
//! (`solid`/`SOLID`, text, a `facet` or `endsolid` keyword). A binary file
//! with less than one record of padding after its n triangles is read (the
//! padding ignored); a shorter one is refused as truncated. ASCII keywords
//! are matched in any case; every line must be the next statement of the
//! grammar, and the file must end after an `endsolid`.

use super::attributes::{ParsedWith, Polygons, push_polygon_size};
use super::{lines, parse_f64, perr, show, strip_bom, tokens};
use crate::error::MeshError;
use crate::geometry::triangle_normal;
use crate::mesh::Mesh;
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// Merges bit-identical corners.
struct Welder {
    map: HashMap<[u64; 3], u32>,
    positions: Vec<[f64; 3]>,
}

impl Welder {
    fn new(capacity: usize) -> Welder {
        Welder {
            map: HashMap::with_capacity(capacity),
            positions: Vec::with_capacity(capacity),
        }
    }

    fn index(&mut self, p: [f64; 3]) -> u32 {
        let key = p.map(f64::to_bits);
        let next = self.positions.len() as u32;
        *self.map.entry(key).or_insert_with(|| {
            self.positions.push(p);
            next
        })
    }
}

/// How an STL file was stored, with what that encoding carries.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StlEncoding {
    /// binary, with its 80-byte header
    Binary {
        /// the header as read
        header: Vec<u8>,
    },
    /// ASCII, with the name after the first `solid` (trimmed; may be empty)
    Ascii {
        /// the solid's name
        name: String,
    },
}

/// What an STL file holds beyond its triangles.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StlAttributes {
    /// binary with its header, or ASCII with its solid's name
    pub encoding: StlEncoding,
    /// binary: each facet's 2-byte attribute (len #F; colour in some
    /// writers); ASCII: empty
    pub facet_attributes: Vec<u16>,
    /// ASCII: number of `solid` blocks after the first, merged into it
    pub solids_merged: usize,
    /// binary: bytes of padding after the last facet, read past
    pub padding_dropped: usize,
}

/// What [`parse_with_attributes`] gathers on the way.
struct Collector {
    attributes: StlAttributes,
    polygon_sizes: Vec<u32>,
}

/// Positions (welded), fan triangles, facet corner counts and the
/// attributes of an STL file.
pub(super) fn parse_with_attributes(
    bytes: &[u8],
    path: &Path,
) -> Result<ParsedWith<StlAttributes>, MeshError> {
    let mut keep = Collector {
        attributes: StlAttributes {
            encoding: StlEncoding::Ascii {
                name: String::new(),
            },
            facet_attributes: Vec::new(),
            solids_merged: 0,
            padding_dropped: 0,
        },
        polygon_sizes: Vec::new(),
    };
    let (positions, faces) = parse_into(bytes, path, Some(&mut keep))?;
    Ok((positions, faces, (keep.polygon_sizes, keep.attributes)))
}

/// Positions (welded) and triangles of an STL file.
pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    parse_into(bytes, path, None)
}

/// The one STL parser; `keep` gathers the attributes when given.
fn parse_into(
    bytes: &[u8],
    path: &Path,
    keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    if bytes.is_empty() {
        return Err(perr(path, 0, "no mesh in file: empty STL file"));
    }
    // The size rule first: a binary header may well start with "solid".
    let count = announced(bytes);
    if let Some(n) = count
        && bytes.len() == binary_len(n)
    {
        return parse_binary(bytes, n, path, keep);
    }
    let text = strip_bom(bytes);
    if looks_ascii(text) {
        return parse_ascii(text, path, keep);
    }
    let Some(n) = count else {
        return Err(perr(
            path,
            0,
            format!(
                "binary STL truncated: {} bytes, the header alone is 84",
                bytes.len()
            ),
        ));
    };
    let want = binary_len(n);
    if bytes.len() > want && bytes.len() - want < RECORD {
        // Padding some writers add after the last triangle: less than one
        // more record, so no triangle can be lost by ignoring it.
        let mut keep = keep;
        if let Some(k) = keep.as_deref_mut() {
            k.attributes.padding_dropped = bytes.len() - want;
        }
        return parse_binary(&bytes[..want], n, path, keep);
    }
    Err(perr(
        path,
        0,
        format!(
            "binary STL header announces {n} triangles ({want} bytes) but the file has {} bytes{}",
            bytes.len(),
            if bytes.len() < want {
                " (truncated)"
            } else {
                " (wrong triangle count, or not an STL file)"
            }
        ),
    ))
}

/// Bytes per binary triangle record (normal, 3 corners, attribute count).
const RECORD: usize = 50;

/// The triangle count of a binary header, if the file is long enough to have one.
fn announced(bytes: &[u8]) -> Option<usize> {
    let c = bytes.get(80..84)?;
    Some(u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize)
}

/// Size of a binary STL with `n` triangles.
fn binary_len(n: usize) -> usize {
    84 + RECORD * n
}

/// ASCII STL: starts with `solid` (any case) and its first 512 bytes are
/// text (no control bytes but whitespace) containing a `facet` or `endsolid`
/// keyword. Binary coordinates practically always contain other bytes.
fn looks_ascii(text: &[u8]) -> bool {
    let head = &text[..text.len().min(512)];
    let keyword = |t: &[u8], k: &[u8]| t.eq_ignore_ascii_case(k);
    tokens(head).next().is_some_and(|t| keyword(t, b"solid"))
        && head
            .iter()
            .all(|&b| b.is_ascii_graphic() || b.is_ascii_whitespace())
        && tokens(head).any(|t| keyword(t, b"facet") || keyword(t, b"endsolid"))
}

fn parse_binary(
    bytes: &[u8],
    n: usize,
    path: &Path,
    mut keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    if let Some(k) = keep.as_deref_mut() {
        k.attributes.encoding = StlEncoding::Binary {
            header: bytes[..80].to_vec(),
        };
        k.attributes.facet_attributes = Vec::with_capacity(n);
        k.polygon_sizes = vec![3; n];
    }
    let mut weld = Welder::new(n / 2 + 3);
    let mut faces = Vec::with_capacity(n);
    for (t, rec) in bytes[84..].chunks_exact(50).enumerate() {
        let mut tri = [0u32; 3];
        for (k, idx) in tri.iter_mut().enumerate() {
            let mut p = [0.0; 3];
            for (c, x) in p.iter_mut().enumerate() {
                let o = 12 + 12 * k + 4 * c;
                *x = f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]) as f64;
                if !x.is_finite() {
                    return Err(perr(
                        path,
                        0,
                        format!(
                            "triangle {t} (byte offset {}): non-finite coordinate {x}",
                            84 + 50 * t + o
                        ),
                    ));
                }
            }
            *idx = weld.index(p);
        }
        faces.push(tri);
        if let Some(k) = keep.as_deref_mut() {
            k.attributes
                .facet_attributes
                .push(u16::from_le_bytes([rec[48], rec[49]]));
        }
    }
    Ok((weld.positions, faces))
}

/// Where the ASCII reader is in `solid { facet { outer loop { vertex } endloop } endfacet } endsolid`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum State {
    Outside,
    Solid,
    Facet,
    Loop,
    /// after `endloop`, before `endfacet`
    FacetDone,
}

fn parse_ascii(
    bytes: &[u8],
    path: &Path,
    mut keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    let mut solids = 0;
    let mut weld = Welder::new(bytes.len() / 200 + 3);
    let mut faces = Vec::with_capacity(bytes.len() / 250);
    let mut poly: Vec<u32> = Vec::with_capacity(4);
    let mut state = State::Outside;
    let mut last = 0;
    for (ln, line) in lines(bytes) {
        let mut tok = tokens(line);
        let Some(kw) = tok.next() else { continue };
        last = ln;
        let kw = kw.to_ascii_lowercase();
        let unexpected = |expected: &str| {
            perr(
                path,
                ln,
                format!(
                    "unexpected {:?}, expected {expected}",
                    show(line.trim_ascii())
                ),
            )
        };
        state = match (state, kw.as_slice()) {
            (State::Outside, b"solid") => {
                if let Some(k) = keep.as_deref_mut() {
                    if solids == 0 {
                        let start = line.len() - line.trim_ascii_start().len() + 5;
                        k.attributes.encoding = StlEncoding::Ascii {
                            name: String::from_utf8_lossy(line[start..].trim_ascii()).into_owned(),
                        };
                    } else {
                        k.attributes.solids_merged += 1;
                    }
                }
                solids += 1;
                State::Solid
            }
            (State::Outside, _) => return Err(unexpected("solid")),
            (State::Solid, b"facet") => State::Facet,
            (State::Solid, b"endsolid") => State::Outside,
            (State::Solid, _) => return Err(unexpected("facet or endsolid")),
            (State::Facet, b"outer") => {
                poly.clear();
                State::Loop
            }
            (State::Facet, _) => return Err(unexpected("outer loop")),
            (State::Loop, b"vertex") => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let t = tok.next().ok_or_else(|| {
                        perr(path, ln, format!("vertex has {k} coordinates, expected 3"))
                    })?;
                    *c = parse_f64(t)
                        .ok_or_else(|| perr(path, ln, format!("bad coordinate {:?}", show(t))))?;
                    if !c.is_finite() {
                        return Err(perr(
                            path,
                            ln,
                            format!("non-finite coordinate {:?}", show(t)),
                        ));
                    }
                    // STL is f32 by definition (binary files cannot hold
                    // more); a text value beyond it could not be written back
                    if (*c as f32).is_infinite() {
                        return Err(perr(
                            path,
                            ln,
                            format!(
                                "coordinate {:?} is beyond the range of STL's 32-bit floats",
                                show(t)
                            ),
                        ));
                    }
                }
                poly.push(weld.index(p));
                State::Loop
            }
            (State::Loop, b"endloop") => {
                if poly.len() < 3 {
                    return Err(perr(
                        path,
                        ln,
                        format!(
                            "facet {} has {} vertices, expected 3",
                            faces.len(),
                            poly.len()
                        ),
                    ));
                }
                super::fan(&poly, &mut faces);
                if let Some(k) = keep.as_deref_mut() {
                    push_polygon_size(&mut k.polygon_sizes, poly.len(), path, ln)?;
                }
                State::FacetDone
            }
            (State::Loop, _) => return Err(unexpected("vertex or endloop")),
            (State::FacetDone, b"endfacet") => State::Solid,
            (State::FacetDone, _) => return Err(unexpected("endfacet")),
        };
    }
    match state {
        State::Outside => Ok((weld.positions, faces)),
        State::Solid => Err(perr(path, last, "file ends without endsolid (truncated)")),
        _ => Err(perr(path, last, "file ends inside a facet (truncated)")),
    }
}

/// Checks that every coordinate fits STL's f32: one beyond its range would
/// be written as an infinity that no reader (ours included) accepts.
pub(super) fn check_range(mesh: &Mesh) -> std::io::Result<()> {
    for (v, p) in mesh.positions.iter().enumerate() {
        if let Some(x) = p.iter().find(|x| (**x as f32).is_infinite()) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "vertex {v} has coordinate {x:e}, beyond the range of STL's 32-bit floats \
                     (|x| <= {:e}); write OBJ, OFF or PLY instead",
                    f32::MAX
                ),
            ));
        }
    }
    Ok(())
}

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> std::io::Result<()> {
    check_range(mesh)?;
    let mut header = [b' '; 80];
    let text = b"binary STL written by normalnet";
    header[..text.len()].copy_from_slice(text);
    w.write_all(&header)?;
    w.write_all(&(mesh.num_faces() as u32).to_le_bytes())?;
    let mut rec = Vec::with_capacity(50);
    for f in 0..mesh.num_faces() {
        let [a, b, c] = mesh.corners(f);
        rec.clear();
        for v in [triangle_normal(a, b, c), a, b, c] {
            for x in v {
                rec.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        rec.extend_from_slice(&[0, 0]);
        w.write_all(&rec)?;
    }
    Ok(())
}

/// Writes `mesh` in the encoding of `stl`: binary with its header and each
/// facet's attribute bytes (a triangle of a triangulated polygon takes its
/// polygon's), or ASCII with its solid's name; facet normals recomputed.
pub(super) fn write_with_attributes(
    w: &mut dyn Write,
    mesh: &Mesh,
    polygons: &Polygons,
    stl: &StlAttributes,
) -> std::io::Result<()> {
    check_range(mesh)?;
    let normal = |n: [f64; 3]| crate::vec3::normalize_or_zero(n);
    match &stl.encoding {
        StlEncoding::Binary { header } => {
            let mut head = [b' '; 80];
            head[..header.len().min(80)].copy_from_slice(&header[..header.len().min(80)]);
            w.write_all(&head)?;
            // binary facets are triangles: polygons and triangles are the same
            w.write_all(&(mesh.num_faces() as u32).to_le_bytes())?;
            let mut rec = Vec::with_capacity(RECORD);
            for polygon in polygons.iter(&mesh.positions) {
                for t in 1..polygon.vertices.len() - 1 {
                    let corners =
                        [0, t, t + 1].map(|k| mesh.positions[polygon.vertices[k] as usize]);
                    rec.clear();
                    let [a, b, c] = corners;
                    for v in [triangle_normal(a, b, c), a, b, c] {
                        for x in v {
                            rec.extend_from_slice(&(x as f32).to_le_bytes());
                        }
                    }
                    let attribute = stl.facet_attributes.get(polygon.source).copied();
                    rec.extend_from_slice(&attribute.unwrap_or(0).to_le_bytes());
                    w.write_all(&rec)?;
                }
            }
        }
        StlEncoding::Ascii { name } => {
            writeln!(w, "solid {name}")?;
            for polygon in polygons.iter(&mesh.positions) {
                let n = normal(polygon.weighted_normal);
                writeln!(w, "facet normal {} {} {}", n[0], n[1], n[2])?;
                writeln!(w, "  outer loop")?;
                for &v in &polygon.vertices {
                    let p = mesh.positions[v as usize];
                    writeln!(w, "    vertex {} {} {}", p[0], p[1], p[2])?;
                }
                writeln!(w, "  endloop")?;
                writeln!(w, "endfacet")?;
            }
            writeln!(w, "endsolid {name}")?;
        }
    }
    Ok(())
}
