//! Object File Format: `[C][N][ST]OFF` header (counts may follow on the same
//! line), `#V #F #E`, one vertex per line (extra columns such as colours
//! ignored), one polygon per line `n i_1 … i_n [colour]` (0-based,
//! fan-triangulated). The header keyword is matched case-insensitively
//! (`OFF`, `off`, `COFF`, `NOFF`, `STCNOFF`, …); binary, 4D and n-dimensional
//! (`nOFF`) files are refused.

use super::{fan, lines, parse_f64, parse_u64, perr, show, tokens};
use crate::error::MeshError;
use crate::mesh::Mesh;
use std::io::Write;
use std::path::Path;

type Parsed = (Vec<[f64; 3]>, Vec<[u32; 3]>);

pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Parsed, MeshError> {
    // Non-empty, comment-stripped lines.
    let mut it = lines(bytes).filter_map(|(ln, l)| {
        let l = match l.iter().position(|&b| b == b'#') {
            Some(i) => &l[..i],
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
    }
    if let Some((ln, _)) = it.next() {
        return Err(perr(
            path,
            ln,
            format!("data after the {nv} vertices and {nf} faces the header announces"),
        ));
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
