//! Wavefront OBJ: `v x y z [w]` and `f` with `i`, `i/t`, `i//n`, `i/t/n`
//! corners (1-based, negative = relative to the vertices read so far);
//! polygons fan-triangulated; every other statement (`vt`, `vn`, `g`,
//! `usemtl`, vendor extensions, …) ignored. `v`, `f` and `fo` are matched
//! case-insensitively; a line that does not start with a keyword (a letter
//! followed by letters, digits or `_`) is refused with its line number.

use super::{fan, is_integer, lines, parse_f64, parse_i64, perr, show, tokens};
use crate::error::MeshError;
use crate::mesh::Mesh;
use std::io::Write;
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
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
            continue;
        }
        let kw = match kw {
            [b'v' | b'V'] => b"v".as_slice(),
            [b'f' | b'F'] => b"f",
            [b'f' | b'F', b'o' | b'O'] => b"f",
            _ if is_keyword(kw) => continue,
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
            }
            _ => {
                poly.clear();
                let nv = positions.len() as i64;
                for t in tok {
                    let idx = t.split(|&b| b == b'/').next().unwrap_or(t);
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

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> std::io::Result<()> {
    writeln!(
        w,
        "# {} vertices, {} faces",
        mesh.num_vertices(),
        mesh.num_faces()
    )?;
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for f in &mesh.faces {
        writeln!(w, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
    }
    Ok(())
}
