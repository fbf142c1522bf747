//! PLY reader: ASCII, binary little endian and binary big endian. Vertex
//! positions come from the `x`, `y`, `z` properties of element `vertex`
//! (any scalar type), faces from the list property `vertex_indices` (or
//! `vertex_index`) of element `face` (any integer count and index type),
//! fan-triangulated. [`parse`] reads past every other element and
//! property; [`parse_with_attributes`] keeps them ([`PlyAttributes`]).

use super::{PlyAttributes, PlyColumn, PlyElement, PlyEncoding, PlyHeaderLine, PlyProperty};
use crate::error::MeshError;
use crate::io::attributes::{ParsedWith, push_polygon_size};
use crate::io::{fan, perr, show};
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// A PLY scalar type (every value of it is exactly an `f64`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// `char` / `int8`
    I8,
    /// `uchar` / `uint8`
    U8,
    /// `short` / `int16`
    I16,
    /// `ushort` / `uint16`
    U16,
    /// `int` / `int32`
    I32,
    /// `uint` / `uint32`
    U32,
    /// `float` / `float32`
    F32,
    /// `double` / `float64`
    F64,
}

impl Scalar {
    fn from_name(s: &[u8]) -> Option<Scalar> {
        Some(match s {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Whether the type is an integer type.
    pub fn is_int(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The type's name in a header (the older of the two spellings).
    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    /// Whether a value read from text is in the type's range (as the binary
    /// form could hold it; NaN and infinities pass for the float types, where
    /// the caller decides).
    fn holds(self, v: f64) -> bool {
        let (lo, hi) = match self {
            Scalar::I8 => (i8::MIN as f64, i8::MAX as f64),
            Scalar::U8 => (0.0, u8::MAX as f64),
            Scalar::I16 => (i16::MIN as f64, i16::MAX as f64),
            Scalar::U16 => (0.0, u16::MAX as f64),
            Scalar::I32 => (i32::MIN as f64, i32::MAX as f64),
            Scalar::U32 => (0.0, u32::MAX as f64),
            Scalar::F32 => (f32::MIN as f64, f32::MAX as f64),
            Scalar::F64 => return true,
        };
        !(v < lo || v > hi)
    }

    /// Bytes of one value in a binary file.
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

/// The type of a PLY property.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// one value
    Scalar(Scalar),
    /// `list COUNT ITEM`: a count, then that many items
    List(Scalar, Scalar),
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
    /// the header line as written
    line: Vec<u8>,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

impl Element {
    /// The fewest bytes one instance can take: each binary value's size (a
    /// list's count only, as it may be empty); in ASCII one character per
    /// value.
    fn smallest_instance(&self, encoding: Encoding) -> usize {
        self.props
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 1,
                (_, Kind::Scalar(t) | Kind::List(t, _)) => t.size(),
            })
            .sum()
    }
}

type Encoding = PlyEncoding;

struct Header {
    encoding: Encoding,
    /// comments, `obj_info` and elements in header order
    lines_in_order: Vec<PlyHeaderLine>,
    /// the line end: `\n` (also for `\r\n`), or `\r` (old Mac files)
    eol: u8,
    elements: Vec<Element>,
    /// byte offset of the data
    data_start: usize,
    /// number of header lines (ASCII data line numbers continue from here)
    lines: usize,
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, MeshError> {
    if bytes.is_empty() {
        return Err(perr(path, 0, "no mesh in file: empty PLY file"));
    }
    // The first line says how lines end: `ply\n`, `ply\r\n` or `ply\r`.
    let eol = if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
        b'\n'
    } else if bytes.starts_with(b"ply\r") {
        b'\r'
    } else {
        return Err(perr(path, 1, "not a PLY file (first line must be \"ply\")"));
    };
    let mut pos = 0;
    let mut ln = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut lines_in_order = Vec::new();
    loop {
        let Some(nl) = bytes[pos..].iter().position(|&b| b == eol) else {
            return Err(perr(path, ln + 1, "header ends without end_header"));
        };
        let line = &bytes[pos..pos + nl];
        let line = crate::io::without_trailing_cr(line);
        pos += nl + 1;
        ln += 1;
        let mut tok = crate::io::tokens(line);
        let kw = tok.next().unwrap_or_default();
        match kw {
            b"ply" if ln == 1 => {}
            b"comment" | b"obj_info" => lines_in_order.push(PlyHeaderLine::Verbatim(line.to_vec())),
            b"" => {}
            b"format" => {
                let f = tok.next().unwrap_or_default();
                encoding = Some(match f {
                    b"ascii" => Encoding::Ascii,
                    b"binary_little_endian" => Encoding::BinaryLittleEndian,
                    b"binary_big_endian" => Encoding::BinaryBigEndian,
                    _ => return Err(perr(path, ln, format!("unknown PLY format {:?}", show(f)))),
                });
            }
            b"element" => {
                let name = tok.next().unwrap_or_default();
                let c = tok.next().unwrap_or_default();
                let count = crate::io::parse_u64(c)
                    .filter(|&c| c <= u32::MAX as u64)
                    .ok_or_else(|| {
                        perr(
                            path,
                            ln,
                            format!("element {:?}: bad count {:?}", show(name), show(c)),
                        )
                    })?;
                lines_in_order.push(PlyHeaderLine::Element(elements.len()));
                elements.push(Element {
                    name: String::from_utf8_lossy(name).into_owned(),
                    count: count as usize,
                    props: Vec::new(),
                });
            }
            b"property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(perr(path, ln, "property before any element"));
                };
                let t = tok.next().unwrap_or_default();
                let ty = |t: &[u8]| {
                    Scalar::from_name(t).ok_or_else(|| {
                        perr(path, ln, format!("unknown property type {:?}", show(t)))
                    })
                };
                let kind = if t == b"list" {
                    let c = ty(tok.next().unwrap_or_default())?;
                    if !c.is_int() {
                        return Err(perr(path, ln, "list count type must be an integer type"));
                    }
                    Kind::List(c, ty(tok.next().unwrap_or_default())?)
                } else {
                    Kind::Scalar(ty(t)?)
                };
                let name = tok
                    .next()
                    .ok_or_else(|| perr(path, ln, "property without a name"))?;
                el.props.push(Property {
                    name: String::from_utf8_lossy(name).into_owned(),
                    kind,
                    line: line.trim_ascii().to_vec(),
                });
            }
            b"end_header" => break,
            _ => {
                return Err(perr(
                    path,
                    ln,
                    format!("unexpected header line {:?}", show(line)),
                ));
            }
        }
    }
    let encoding = encoding.ok_or_else(|| perr(path, ln, "header has no format line"))?;
    Ok(Header {
        encoding,
        lines_in_order,
        eol,
        elements,
        data_start: pos,
        lines: ln,
    })
}

/// Where the mesh lives inside the elements.
struct Layout {
    vertex: usize,
    xyz: [usize; 3],
    face: Option<(usize, usize)>,
}

fn layout(h: &Header, path: &Path) -> Result<Layout, MeshError> {
    let vertex = h
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| perr(path, 0, "no mesh in file: PLY header has no vertex element"))?;
    let mut xyz = [usize::MAX; 3];
    for (k, n) in ["x", "y", "z"].iter().enumerate() {
        let p = h.elements[vertex]
            .props
            .iter()
            .position(|p| p.name == *n)
            .ok_or_else(|| perr(path, 0, format!("vertex element has no property {n}")))?;
        if !matches!(h.elements[vertex].props[p].kind, Kind::Scalar(_)) {
            return Err(perr(path, 0, format!("vertex property {n} is a list")));
        }
        xyz[k] = p;
    }
    let face = match h.elements.iter().position(|e| e.name == "face") {
        None => None,
        Some(fe) => {
            let p = h.elements[fe]
                .props
                .iter()
                .position(|p| {
                    (p.name == "vertex_indices" || p.name == "vertex_index")
                        && matches!(p.kind, Kind::List(..))
                })
                .ok_or_else(|| perr(path, 0, "face element has no list property vertex_indices"))?;
            if let Kind::List(_, t) = h.elements[fe].props[p].kind
                && !t.is_int()
            {
                return Err(perr(
                    path,
                    0,
                    "face vertex_indices must have an integer type",
                ));
            }
            Some((fe, p))
        }
    };
    Ok(Layout { vertex, xyz, face })
}

/// Positions and fan triangles of a PLY file.
pub(in crate::io) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    let h = parse_header(bytes, path)?;
    let lay = layout(&h, path)?;
    parse_into(bytes, path, &h, &lay, None)
}

/// Positions, fan triangles, polygon sizes and every other element and
/// property of a PLY file.
pub(in crate::io) fn parse_with_attributes(
    bytes: &[u8],
    path: &Path,
) -> Result<ParsedWith<PlyAttributes>, MeshError> {
    let h = parse_header(bytes, path)?;
    let lay = layout(&h, path)?;
    let elements = h
        .elements
        .iter()
        .enumerate()
        .map(|(ei, el)| PlyElement {
            name: el.name.clone(),
            count: el.count,
            properties: el
                .props
                .iter()
                .enumerate()
                .map(|(pi, p)| PlyProperty {
                    name: p.name.clone(),
                    kind: p.kind,
                    line: p.line.clone(),
                    column: column_for(&h, &lay, ei, pi),
                })
                .collect(),
        })
        .collect();
    let mut keep = Collector {
        attributes: PlyAttributes {
            encoding: h.encoding,
            header: h.lines_in_order.clone(),
            elements,
            vertex_element: lay.vertex,
            face_element: lay.face.map(|(e, _)| e),
        },
        polygon_sizes: Vec::new(),
    };
    let (positions, faces) = parse_into(bytes, path, &h, &lay, Some(&mut keep))?;
    Ok((positions, faces, (keep.polygon_sizes, keep.attributes)))
}

/// What [`parse_with_attributes`] gathers on the way.
struct Collector {
    attributes: PlyAttributes,
    polygon_sizes: Vec<u32>,
}

/// Where the values of property `pi` of element `ei` go.
fn column_for(h: &Header, lay: &Layout, ei: usize, pi: usize) -> PlyColumn {
    let prop = &h.elements[ei].props[pi];
    let is_vertex = ei == lay.vertex;
    let is_face = lay.face.is_some_and(|(fe, _)| fe == ei);
    if is_vertex && let Some(k) = lay.xyz.iter().position(|&x| x == pi) {
        return PlyColumn::Position(k);
    }
    if lay.face == Some((ei, pi)) {
        return PlyColumn::FaceIndices;
    }
    if (is_vertex || is_face) && matches!(prop.kind, Kind::Scalar(_)) {
        let normal = ["nx", "ny", "nz"].iter().position(|n| *n == prop.name);
        if let Some(k) = normal {
            return PlyColumn::Normal(k);
        }
    }
    match prop.kind {
        Kind::Scalar(_) => {
            PlyColumn::Scalars(Vec::with_capacity(h.elements[ei].count.min(1 << 24)))
        }
        Kind::List(..) => PlyColumn::Lists {
            lengths: Vec::new(),
            items: Vec::new(),
        },
    }
}

/// The one PLY data parser; `keep` gathers the attributes when given.
fn parse_into(
    bytes: &[u8],
    path: &Path,
    h: &Header,
    lay: &Layout,
    mut keep: Option<&mut Collector>,
) -> Result<Parsed, MeshError> {
    let nv = h.elements[lay.vertex].count;
    let mut positions = Vec::with_capacity(nv.min(bytes.len() / 3));
    let mut faces = Vec::new();
    let mut src: Box<dyn Source> = match h.encoding {
        Encoding::Ascii => Box::new(Ascii {
            data: bytes,
            pos: h.data_start,
            line: h.lines + 1,
            eol: h.eol,
        }),
        e => Box::new(Binary {
            data: bytes,
            pos: h.data_start,
            be: e == Encoding::BinaryBigEndian,
        }),
    };
    let mut poly: Vec<u32> = Vec::with_capacity(8);
    for (ei, el) in h.elements.iter().enumerate() {
        let ctx = |src: &dyn Source, i: usize, what: &str| {
            let (line, at) = src.place();
            perr(path, line, format!("element {} {i}{at}: {what}", el.name))
        };
        // An element without properties carries no data; a count the rest
        // of the file cannot hold is refused before looping over it.
        if el.props.is_empty() {
            continue;
        }
        let smallest = el.smallest_instance(h.encoding);
        if el.count.saturating_mul(smallest) > src.remaining() {
            let (line, at) = src.place();
            return Err(perr(
                path,
                line,
                format!(
                    "element {}{at}: data ends early: the header declares {} instances of at least \
                     {smallest} bytes each, but {} bytes follow (truncated file or wrong element count)",
                    el.name,
                    el.count,
                    src.remaining()
                ),
            ));
        }
        for i in 0..el.count {
            let mut p = [0.0; 3];
            for (pi, prop) in el.props.iter().enumerate() {
                match prop.kind {
                    Kind::Scalar(t) => {
                        let v = src
                            .scalar(t)
                            .map_err(|m| ctx(&*src, i, &format!("property {}: {m}", prop.name)))?;
                        if let Some(k) = keep.as_deref_mut()
                            && let PlyColumn::Scalars(values) =
                                &mut k.attributes.elements[ei].properties[pi].column
                        {
                            values.push(v);
                        }
                        if ei == lay.vertex
                            && let Some(k) = lay.xyz.iter().position(|&x| x == pi)
                        {
                            if !v.is_finite() {
                                return Err(ctx(
                                    &*src,
                                    i,
                                    &format!("non-finite coordinate {} = {v}", prop.name),
                                ));
                            }
                            p[k] = v;
                        }
                    }
                    Kind::List(ct, it) => {
                        let n = src.scalar(ct).map_err(|m| {
                            ctx(&*src, i, &format!("list {} count: {m}", prop.name))
                        })?;
                        if !(n >= 0.0 && n <= u32::MAX as f64) {
                            return Err(ctx(
                                &*src,
                                i,
                                &format!("list {} has bad length {n}", prop.name),
                            ));
                        }
                        let n = n as usize;
                        let is_face = lay.face == Some((ei, pi));
                        let mut list = match keep.as_deref_mut() {
                            Some(k) => match &mut k.attributes.elements[ei].properties[pi].column {
                                PlyColumn::Lists { lengths, items } => {
                                    lengths.push(n as u32);
                                    Some(items)
                                }
                                _ => None,
                            },
                            None => None,
                        };
                        if is_face {
                            poly.clear();
                        }
                        for k in 0..n {
                            let v = src.scalar(it).map_err(|m| {
                                ctx(&*src, i, &format!("list {} item {k}: {m}", prop.name))
                            })?;
                            if let Some(items) = list.as_deref_mut() {
                                items.push(v);
                            }
                            if is_face {
                                if !(v >= 0.0 && v < nv as f64) {
                                    return Err(ctx(
                                        &*src,
                                        i,
                                        &format!(
                                            "refers to vertex {v} but the file has {nv} vertices"
                                        ),
                                    ));
                                }
                                poly.push(v as u32);
                            }
                        }
                        if is_face {
                            if n < 3 {
                                return Err(ctx(
                                    &*src,
                                    i,
                                    &format!("has {n} vertices, expected at least 3"),
                                ));
                            }
                            fan(&poly, &mut faces);
                            if let Some(k) = keep.as_deref_mut() {
                                let (line, _) = src.place();
                                push_polygon_size(&mut k.polygon_sizes, n, path, line)?;
                            }
                        }
                    }
                }
            }
            if ei == lay.vertex {
                positions.push(p);
            }
            src.end_instance().map_err(|m| ctx(&*src, i, &m))?;
        }
    }
    if let Some(extra) = src.leftover() {
        let (line, at) = src.place();
        return Err(perr(
            path,
            line,
            format!(
                "{extra} after the last element{at}: the element counts in the header do not match the data"
            ),
        ));
    }
    Ok((positions, faces))
}

/// A stream of property values.
trait Source {
    /// Next scalar of type `t` (integers exactly, as f64).
    fn scalar(&mut self, t: Scalar) -> Result<f64, String>;
    /// End of one element instance (ASCII: the line must end).
    fn end_instance(&mut self) -> Result<(), String> {
        Ok(())
    }
    /// `(line, " (byte offset N)")` for error messages.
    fn place(&self) -> (usize, String);
    /// Description of data left after the last element, if any.
    fn leftover(&mut self) -> Option<String>;
    /// Bytes not read yet.
    fn remaining(&self) -> usize;
}

struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    be: bool,
}

impl Binary<'_> {
    #[inline]
    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let end = self.pos + N;
        if end > self.data.len() {
            return Err("data ends early (truncated file or wrong element count)".into());
        }
        let mut a = [0u8; N];
        a.copy_from_slice(&self.data[self.pos..end]);
        if self.be {
            a.reverse();
        }
        self.pos = end;
        Ok(a)
    }
}

impl Source for Binary<'_> {
    #[inline]
    fn scalar(&mut self, t: Scalar) -> Result<f64, String> {
        Ok(match t {
            Scalar::I8 => i8::from_le_bytes(self.take()?) as f64,
            Scalar::U8 => u8::from_le_bytes(self.take()?) as f64,
            Scalar::I16 => i16::from_le_bytes(self.take()?) as f64,
            Scalar::U16 => u16::from_le_bytes(self.take()?) as f64,
            Scalar::I32 => i32::from_le_bytes(self.take()?) as f64,
            Scalar::U32 => u32::from_le_bytes(self.take()?) as f64,
            Scalar::F32 => f32::from_le_bytes(self.take()?) as f64,
            Scalar::F64 => f64::from_le_bytes(self.take()?),
        })
    }

    fn place(&self) -> (usize, String) {
        (0, format!(" (byte offset {})", self.pos))
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn leftover(&mut self) -> Option<String> {
        let rest = &self.data[self.pos..];
        // Tolerate trailing line breaks / padding some writers add.
        if rest.iter().all(|b| b.is_ascii_whitespace() || *b == 0) {
            None
        } else {
            Some(format!("{} bytes of data", rest.len()))
        }
    }
}

struct Ascii<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
    /// the line end of the header (`\r\n` counts as `\n`)
    eol: u8,
}

impl<'a> Ascii<'a> {
    /// Next token on the current line, or None at the end of the line.
    fn token_on_line(&mut self) -> Option<&'a [u8]> {
        // a `\r` is blank space before `\n`, or the line end itself
        while self.pos < self.data.len()
            && self.data[self.pos] != self.eol
            && matches!(self.data[self.pos], b' ' | b'\t' | b'\r')
        {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if self.pos > start {
            Some(&self.data[start..self.pos])
        } else {
            None
        }
    }

    /// Skips blank lines; false at the end of data.
    fn skip_blank_lines(&mut self) -> bool {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            if self.data[self.pos] == self.eol {
                self.line += 1;
            }
            self.pos += 1;
        }
        self.pos < self.data.len()
    }
}

impl Source for Ascii<'_> {
    fn scalar(&mut self, t: Scalar) -> Result<f64, String> {
        let at_line_start = self.pos == 0 || self.data[self.pos - 1] == self.eol;
        if at_line_start && !self.skip_blank_lines() {
            return Err("data ends early (truncated file or wrong element count)".into());
        }
        let tok = self
            .token_on_line()
            .ok_or_else(|| "line ends early (too few values)".to_string())?;
        let v = crate::io::parse_f64(tok).ok_or_else(|| format!("bad number {:?}", show(tok)))?;
        if t.is_int() && v.fract() != 0.0 {
            return Err(format!("{:?} is not an integer", show(tok)));
        }
        if !t.holds(v) {
            return Err(format!(
                "{:?} does not fit the property's type {}",
                show(tok),
                t.name()
            ));
        }
        Ok(v)
    }

    fn end_instance(&mut self) -> Result<(), String> {
        if let Some(t) = self.token_on_line() {
            return Err(format!("unexpected extra value {:?} on the line", show(t)));
        }
        if self.pos < self.data.len() {
            // at the line end
            self.pos += 1;
            self.line += 1;
        }
        Ok(())
    }

    fn place(&self) -> (usize, String) {
        (self.line, String::new())
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn leftover(&mut self) -> Option<String> {
        if self.skip_blank_lines() {
            Some("more data".into())
        } else {
            None
        }
    }
}
