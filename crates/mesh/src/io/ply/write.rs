//! PLY writers: [`write`] (positions as doubles and triangles, binary little
//! endian or ASCII) and [`write_with_attributes`] (every element and
//! property of the file read, in its types and encoding, around new
//! positions; normals recomputed).

use super::read::{Kind, Scalar};
use super::{PlyAttributes, PlyColumn, PlyEncoding, PlyHeaderLine};
use crate::io::attributes::{Polygon, Polygons};
use crate::mesh::Mesh;
use crate::vec3;
use std::io::Write;

/// Positions as `double`, faces as `list uchar int` (`uint` past i32).
pub(in crate::io) fn write(w: &mut dyn Write, mesh: &Mesh, ascii: bool) -> std::io::Result<()> {
    let index_type = if mesh.num_vertices() > i32::MAX as usize {
        "uint"
    } else {
        "int"
    };
    write!(
        w,
        "ply\nformat {} 1.0\ncomment written by normalnet\nelement vertex {}\n\
         property double x\nproperty double y\nproperty double z\nelement face {}\n\
         property list uchar {index_type} vertex_indices\nend_header\n",
        if ascii {
            "ascii"
        } else {
            "binary_little_endian"
        },
        mesh.num_vertices(),
        mesh.num_faces()
    )?;
    if ascii {
        for p in &mesh.positions {
            writeln!(w, "{} {} {}", p[0], p[1], p[2])?;
        }
        for f in &mesh.faces {
            writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
        }
    } else {
        let mut buf = Vec::with_capacity(24 * 4096);
        for chunk in mesh.positions.chunks(4096) {
            buf.clear();
            for p in chunk {
                for c in p {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            w.write_all(&buf)?;
        }
        for chunk in mesh.faces.chunks(4096) {
            buf.clear();
            for f in chunk {
                buf.push(3);
                for i in f {
                    buf.extend_from_slice(&i.to_le_bytes());
                }
            }
            w.write_all(&buf)?;
        }
    }
    Ok(())
}

/// Writes values of PLY types in one encoding into a buffer.
struct Values {
    encoding: PlyEncoding,
    buf: Vec<u8>,
    /// ASCII: whether a value is already on the line
    on_line: bool,
}

impl Values {
    /// One value `v` of type `t` (integers rounded and clamped to the type).
    fn push(&mut self, t: Scalar, v: f64) {
        macro_rules! int {
            ($ty:ty) => {{
                let x = v.round() as $ty;
                match self.encoding {
                    PlyEncoding::Ascii => self.text(format_args!("{x}")),
                    PlyEncoding::BinaryLittleEndian => self.buf.extend_from_slice(&x.to_le_bytes()),
                    PlyEncoding::BinaryBigEndian => self.buf.extend_from_slice(&x.to_be_bytes()),
                }
            }};
        }
        macro_rules! float {
            ($ty:ty) => {{
                let x = v as $ty;
                match self.encoding {
                    PlyEncoding::Ascii => self.text(format_args!("{x}")),
                    PlyEncoding::BinaryLittleEndian => self.buf.extend_from_slice(&x.to_le_bytes()),
                    PlyEncoding::BinaryBigEndian => self.buf.extend_from_slice(&x.to_be_bytes()),
                }
            }};
        }
        match t {
            Scalar::I8 => int!(i8),
            Scalar::U8 => int!(u8),
            Scalar::I16 => int!(i16),
            Scalar::U16 => int!(u16),
            Scalar::I32 => int!(i32),
            Scalar::U32 => int!(u32),
            // ASCII writes the shortest digits that read back as `v` (the
            // reader keeps every digit of a `float` column, as rply does):
            // an f32's where they do, else a double's (a computed value, or
            // an f32 such as 55555552 whose short digits 55555550 read as
            // another double)
            Scalar::F32 if self.encoding == PlyEncoding::Ascii => {
                let short = (v as f32).to_string();
                if v as f32 as f64 == v && short.parse::<f64>() == Ok(v) {
                    self.text(format_args!("{short}"));
                } else {
                    self.text(format_args!("{v}"));
                }
            }
            Scalar::F32 => float!(f32),
            Scalar::F64 => float!(f64),
        }
    }

    fn text(&mut self, value: std::fmt::Arguments) {
        if self.on_line {
            self.buf.push(b' ');
        }
        self.buf.write_fmt(value).expect("writing to a Vec");
        self.on_line = true;
    }

    /// Ends an element instance (ASCII: the line).
    fn end_instance(&mut self) {
        if self.encoding == PlyEncoding::Ascii {
            self.buf.push(b'\n');
            self.on_line = false;
        }
    }

    /// Writes the buffer out once it is large.
    fn flush_if_full(&mut self, w: &mut dyn Write) -> std::io::Result<()> {
        if self.buf.len() >= 1 << 20 {
            w.write_all(&self.buf)?;
            self.buf.clear();
        }
        Ok(())
    }
}

/// Start of each instance's items in a list column (len #instances + 1).
fn list_offsets(lengths: &[u32]) -> Vec<usize> {
    let mut offsets = Vec::with_capacity(lengths.len() + 1);
    let mut at = 0;
    offsets.push(0);
    for &n in lengths {
        at += n as usize;
        offsets.push(at);
    }
    offsets
}

/// Writes every element of `ply` with the positions of `mesh`, its
/// polygons, and the normals recomputed from them; ASCII when `ascii`, else
/// the encoding of the file read.
pub(in crate::io) fn write_with_attributes(
    w: &mut dyn Write,
    mesh: &Mesh,
    polygons: &Polygons,
    ply: &PlyAttributes,
    ascii: bool,
) -> std::io::Result<()> {
    let encoding = if ascii {
        PlyEncoding::Ascii
    } else {
        ply.encoding
    };
    let count_of = |ei: usize| {
        if Some(ei) == ply.face_element {
            polygons.count()
        } else {
            ply.elements[ei].count
        }
    };
    writeln!(w, "ply")?;
    writeln!(
        w,
        "format {} 1.0",
        match encoding {
            PlyEncoding::Ascii => "ascii",
            PlyEncoding::BinaryLittleEndian => "binary_little_endian",
            PlyEncoding::BinaryBigEndian => "binary_big_endian",
        }
    )?;
    for line in &ply.header {
        match line {
            PlyHeaderLine::Verbatim(text) => {
                w.write_all(text)?;
                writeln!(w)?;
            }
            &PlyHeaderLine::Element(ei) => {
                writeln!(w, "element {} {}", ply.elements[ei].name, count_of(ei))?;
                for p in &ply.elements[ei].properties {
                    w.write_all(&p.line)?;
                    writeln!(w)?;
                }
            }
        }
    }
    writeln!(w, "end_header")?;
    let vertex_normals = ply.elements[ply.vertex_element]
        .properties
        .iter()
        .any(|p| matches!(p.column, PlyColumn::Normal(_)))
        .then(|| crate::geometry::area_weighted_vertex_normals(mesh));
    let mut out = Values {
        encoding,
        buf: Vec::with_capacity(1 << 20),
        on_line: false,
    };
    for (ei, el) in ply.elements.iter().enumerate() {
        if el.properties.is_empty() {
            continue; // no data to write, however many instances
        }
        let offsets: Vec<Option<Vec<usize>>> = el
            .properties
            .iter()
            .map(|p| match &p.column {
                PlyColumn::Lists { lengths, .. } => Some(list_offsets(lengths)),
                _ => None,
            })
            .collect();
        // one instance: `i` of the file, the polygon written when a face
        let instance = |out: &mut Values, i: usize, polygon: Option<&Polygon>| {
            for (p, offsets) in el.properties.iter().zip(&offsets) {
                match (&p.column, p.kind) {
                    (PlyColumn::Position(k), Kind::Scalar(t)) => out.push(t, mesh.positions[i][*k]),
                    (PlyColumn::Normal(k), Kind::Scalar(t)) => {
                        let n = match (polygon, &vertex_normals) {
                            (Some(poly), _) => vec3::normalize_or_zero(poly.weighted_normal),
                            (None, Some(normals)) => normals[i],
                            (None, None) => [0.0; 3],
                        };
                        out.push(t, n[*k]);
                    }
                    (PlyColumn::FaceIndices, Kind::List(ct, it)) => {
                        let vertices = polygon.map(|p| p.vertices.as_slice()).unwrap_or(&[]);
                        out.push(ct, vertices.len() as f64);
                        for &v in vertices {
                            out.push(it, v as f64);
                        }
                    }
                    (PlyColumn::Scalars(values), Kind::Scalar(t)) => out.push(t, values[i]),
                    (PlyColumn::Lists { items, .. }, Kind::List(ct, it)) => {
                        let offsets = offsets.as_ref().expect("offsets of every list column");
                        let items = &items[offsets[i]..offsets[i + 1]];
                        out.push(ct, items.len() as f64);
                        for &v in items {
                            out.push(it, v);
                        }
                    }
                    // the reader pairs every column with its kind
                    _ => unreachable!("PLY column {:?} of kind {:?}", p.column, p.kind),
                }
            }
            out.end_instance();
        };
        if Some(ei) == ply.face_element {
            for polygon in polygons.iter(&mesh.positions) {
                instance(&mut out, polygon.source, Some(&polygon));
                out.flush_if_full(w)?;
            }
        } else {
            for i in 0..el.count {
                instance(&mut out, i, None);
                out.flush_if_full(w)?;
            }
        }
    }
    w.write_all(&out.buf)
}
