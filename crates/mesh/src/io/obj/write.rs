//! OBJ writers: [`write`] (positions and triangles only) and
//! [`write_with_attributes`] (every statement of the file read, in its
//! order, around new positions; normals recomputed, `mtllib` names
//! rewritten relative to the output's folder).

use super::{NO_INDEX, ObjAttributes, ObjStatement, split_library_names};
use crate::io::attributes::{Polygons, relative_path};
use crate::mesh::Mesh;
use crate::vec3;
use std::io::Write;
use std::path::Path;

/// `v` and `f` lines, after a `# N vertices, M faces` comment.
pub(in crate::io) fn write(w: &mut dyn Write, mesh: &Mesh) -> std::io::Result<()> {
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

/// Where `mtllib` names are resolved from (the input's folder) and written
/// relative to (the output's folder); either `None`: names kept as written.
pub(crate) struct LibraryPaths<'a> {
    /// the folder of the file read
    pub from: Option<&'a Path>,
    /// the folder of the file written
    pub to: Option<&'a Path>,
}

impl LibraryPaths<'_> {
    /// `names` (an `mtllib` statement's text) as seen from the output's folder.
    fn rewrite(&self, names: &str) -> String {
        let (Some(from), Some(to)) = (self.from, self.to) else {
            return names.to_string();
        };
        if from == to {
            return names.to_string();
        }
        split_library_names(names)
            .map(|name| {
                let target = from.join(name);
                relative_path(&target, to)
                    .unwrap_or(target)
                    .to_string_lossy()
                    .into_owned()
            })
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Normal `k` of the output: the normalised sum of the area-weighted
/// normals of the polygons with a corner using `vn k`; the file's own value
/// for a `vn` no corner uses.
fn recomputed_normals(mesh: &Mesh, polygons: &Polygons, obj: &ObjAttributes) -> Vec<[f64; 3]> {
    let mut sum = vec![[0.0; 3]; obj.normals.len()];
    let mut used = vec![false; obj.normals.len()];
    if !obj.corner_normals.is_empty() {
        for polygon in polygons.whole().iter(&mesh.positions) {
            for c in 0..polygon.corners.len() {
                let k = obj.corner_normals[polygon.first_corner + c];
                if k != NO_INDEX {
                    sum[k as usize] = vec3::add(sum[k as usize], polygon.weighted_normal);
                    used[k as usize] = true;
                }
            }
        }
    }
    sum.into_iter()
        .zip(used)
        .zip(&obj.normals)
        .map(|((s, used), read)| {
            if used {
                vec3::normalize_or_zero(s)
            } else {
                *read
            }
        })
        .collect()
}

/// Replays the statements of `obj` with the positions of `mesh` and the
/// normals recomputed from them.
pub(in crate::io) fn write_with_attributes(
    w: &mut dyn Write,
    mesh: &Mesh,
    polygons: &Polygons,
    obj: &ObjAttributes,
    libraries: &LibraryPaths,
) -> std::io::Result<()> {
    let normals = recomputed_normals(mesh, polygons, obj);
    let mut vertex = 0;
    let mut texture = 0;
    let mut normal = 0;
    let mut file_polygons = 0;
    let mut to_write = polygons.iter(&mesh.positions).peekable();
    for statement in &obj.statements {
        match statement {
            ObjStatement::Vertices(n) => {
                for v in vertex..vertex + *n as usize {
                    let p = mesh.positions[v];
                    write!(w, "v {} {} {}", p[0], p[1], p[2])?;
                    match obj.vertex_tails.get(v) {
                        Some(tail) if !tail.is_empty() => writeln!(w, " {tail}")?,
                        _ => writeln!(w)?,
                    }
                }
                vertex += *n as usize;
            }
            ObjStatement::TextureCoords(n) => {
                for t in &obj.texture_coords[texture..texture + *n as usize] {
                    w.write_all(b"vt")?;
                    for x in t {
                        write!(w, " {x}")?;
                    }
                    writeln!(w)?;
                }
                texture += *n as usize;
            }
            ObjStatement::Normals(n) => {
                for v in &normals[normal..normal + *n as usize] {
                    writeln!(w, "vn {} {} {}", v[0], v[1], v[2])?;
                }
                normal += *n as usize;
            }
            ObjStatement::Polygons(n) => {
                file_polygons += *n as usize;
                while let Some(polygon) = to_write.next_if(|p| p.source < file_polygons) {
                    w.write_all(b"f")?;
                    for (&c, &v) in polygon.corners.iter().zip(&polygon.vertices) {
                        let corner = polygon.first_corner + c;
                        let t = obj.corner_texture_coords.get(corner).copied();
                        let n = obj.corner_normals.get(corner).copied();
                        write!(w, " {}", v + 1)?;
                        match (t.filter(|&t| t != NO_INDEX), n.filter(|&n| n != NO_INDEX)) {
                            (None, None) => {}
                            (Some(t), None) => write!(w, "/{}", t + 1)?,
                            (None, Some(n)) => write!(w, "//{}", n + 1)?,
                            (Some(t), Some(n)) => write!(w, "/{}/{}", t + 1, n + 1)?,
                        }
                    }
                    writeln!(w)?;
                }
            }
            ObjStatement::MaterialLibrary(names) => {
                writeln!(w, "mtllib {}", libraries.rewrite(names))?;
            }
            ObjStatement::Verbatim(line) => {
                w.write_all(line)?;
                writeln!(w)?;
            }
        }
    }
    Ok(())
}
