//! STL, binary (80-byte header, u32 count, 50 bytes per triangle) and ASCII
//! (`solid … facet normal … outer loop vertex ×3 endloop endfacet … endsolid`).
//! STL stores each triangle's corners separately: bit-identical corners are
//! merged into one vertex (first appearance order); nothing else is merged.
//! The stored facet normals are ignored.

use super::{lines, parse_f64, perr, show, tokens};
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

pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    if bytes.is_empty() {
        return Err(perr(path, 0, "no mesh in file: empty STL file"));
    }
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if bytes.len() == 84 + 50 * n {
            return parse_binary(bytes, n, path);
        }
    }
    let head = &bytes[..bytes.len().min(512)];
    let ascii = tokens(head).next() == Some(b"solid".as_slice())
        && tokens(head).any(|t| t == b"facet" || t == b"endsolid");
    if ascii {
        return parse_ascii(bytes, path);
    }
    if bytes.len() < 84 {
        return Err(perr(
            path,
            0,
            format!(
                "binary STL truncated: {} bytes, the header alone is 84",
                bytes.len()
            ),
        ));
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    Err(perr(
        path,
        0,
        format!(
            "binary STL header announces {n} triangles ({} bytes) but the file has {} bytes",
            84 + 50 * n,
            bytes.len()
        ),
    ))
}

fn parse_binary(bytes: &[u8], n: usize, path: &Path) -> Result<Parsed, MeshError> {
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
    }
    Ok((weld.positions, faces))
}

fn parse_ascii(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    let mut weld = Welder::new(bytes.len() / 200 + 3);
    let mut faces = Vec::with_capacity(bytes.len() / 250);
    let mut poly: Vec<u32> = Vec::with_capacity(4);
    let mut in_loop = false;
    let mut last = 0;
    for (ln, line) in lines(bytes) {
        last = ln;
        let mut tok = tokens(line);
        match tok.next() {
            Some(b"vertex") => {
                if !in_loop {
                    return Err(perr(path, ln, "vertex outside an outer loop"));
                }
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
                }
                poly.push(weld.index(p));
            }
            Some(b"outer") => {
                in_loop = true;
                poly.clear();
            }
            Some(b"endloop") => {
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
                in_loop = false;
            }
            _ => {}
        }
    }
    if in_loop {
        return Err(perr(path, last, "file ends inside a facet (truncated)"));
    }
    Ok((weld.positions, faces))
}

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> std::io::Result<()> {
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
