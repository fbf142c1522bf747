//! The glTF writers: a mesh back into the document it was read from (new
//! positions into their `POSITION` accessors in place, normals recomputed,
//! tangents dropped; the policy is in [`super`]), and a plain document of
//! positions and triangles for a mesh from another format.

use super::accessor::{self, item};
use super::container;
use super::{GltfAttributes, GltfBufferSource, GltfContainer};
use crate::io::attributes::relative_path;
use crate::mesh::Mesh;
use crate::vec3::{self, Vec3};
use serde_json::{Value, json};
use std::io::{self, Write};
use std::path::Path;

/// Where and how [`encode_with_attributes`] writes.
pub(crate) struct Output<'a> {
    /// the container to write (another than the input's converts it)
    pub container: GltfContainer,
    /// the output's file stem: buffers stored in files are written as
    /// `<stem>.bin`, `<stem>_1.bin`, …; `None` embeds them as `data:` URIs
    pub stem: Option<&'a str>,
    /// the input's folder (relative image URIs are resolved from it)
    pub from: Option<&'a Path>,
    /// the output's folder (relative image URIs are rewritten relative to
    /// it); either `None`: image URIs kept as written
    pub to: Option<&'a Path>,
}

/// A written glTF: the main file, the buffer files to write beside it, and
/// what went stale.
pub(crate) struct Encoded {
    /// the `.gltf` or `.glb` bytes
    pub main: Vec<u8>,
    /// (file name, bytes) of each buffer file, in the output's folder
    pub files: Vec<(String, Vec<u8>)>,
    /// one line per dropped attribute or attribute kept stale
    pub warnings: Vec<String>,
}

fn invalid(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, message)
}

/// Checks that every coordinate of `mesh` fits glTF's 32-bit floats.
///
/// # Errors
/// `InvalidData` naming the first vertex out of range.
pub(crate) fn check_range(mesh: &Mesh) -> io::Result<()> {
    for (v, p) in mesh.positions.iter().enumerate() {
        if let Some(x) = p.iter().find(|x| (**x as f32).is_infinite()) {
            return Err(invalid(format!(
                "vertex {v} has coordinate {x:e}, beyond the range of glTF's 32-bit floats \
                 (|x| <= {:e})",
                f32::MAX
            )));
        }
    }
    Ok(())
}

/// `mesh` (the welded mesh of `gltf`, new positions) in the document it
/// was read from.
///
/// # Errors
/// `InvalidData` when the attributes no longer describe their document
/// (edited), or a new position does not fit f32 in its accessor's space.
pub(crate) fn encode_with_attributes(
    mesh: &Mesh,
    gltf: &GltfAttributes,
    out: &Output,
) -> io::Result<Encoded> {
    let mut json = gltf.json.clone();
    let mut buffers: Vec<Vec<u8>> = gltf.buffers.iter().map(|b| b.bytes.clone()).collect();
    let lengths: Vec<usize> = buffers.iter().map(Vec::len).collect();
    let mut warnings = Vec::new();

    // positions, in place
    let mut moved = vec![false; gltf.positions.len()];
    for (s, set) in gltf.positions.iter().enumerate() {
        let layout = accessor::layout(&json, &lengths, set.accessor).map_err(invalid)?;
        if layout.count != set.vertices.len() {
            return Err(invalid(format!(
                "accessors[{}] has {} elements, the attributes {}",
                set.accessor,
                layout.count,
                set.vertices.len()
            )));
        }
        let world = set.transform();
        let inverse = world
            .inverse()
            .ok_or_else(|| invalid(format!("accessors[{}]: singular transform", set.accessor)))?;
        let buffer = &mut buffers[layout.buffer];
        let mut values = Vec::with_capacity(layout.count);
        for (i, &v) in set.vertices.iter().enumerate() {
            let old = accessor::read_vec3(buffer, &layout, i);
            let new = mesh.positions[v as usize];
            let value = if bits(world.apply(old.map(f64::from))) == bits(new) {
                old
            } else {
                let local = inverse.apply(new).map(|x| x as f32);
                if !local.iter().all(|x| x.is_finite()) {
                    return Err(invalid(format!(
                        "vertex {v} at {new:?} is beyond the range of the 32-bit floats of \
                         accessors[{}] (element {i})",
                        set.accessor
                    )));
                }
                if local.map(f32::to_bits) != old.map(f32::to_bits) {
                    moved[s] = true;
                    accessor::write_vec3(buffer, &layout, i, local);
                }
                local
            };
            values.push(value);
        }
        if moved[s] {
            accessor::set_bounds(&mut json, set.accessor, &values);
        }
    }

    // tangents dropped, normals recomputed, where a vertex moved
    let mut normal_groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for (k, prim) in gltf.primitives.iter().enumerate() {
        if let Some(n) = prim.normal {
            match normal_groups.iter_mut().find(|(a, _)| *a == n) {
                Some((_, members)) => members.push(k),
                None => normal_groups.push((n, vec![k])),
            }
        }
        if prim.tangent && moved[prim.positions] {
            let what = format!("meshes[{}].primitives[{}]", prim.mesh, prim.primitive);
            if let Some(Value::Object(a)) = json.pointer_mut(&format!(
                "/meshes/{}/primitives/{}/attributes",
                prim.mesh, prim.primitive
            )) {
                a.shift_remove("TANGENT");
            }
            warnings.push(format!(
                "{what}: TANGENT dropped (stale once vertices move; viewers recompute tangents)"
            ));
        }
    }
    for (normal, members) in normal_groups {
        if !members.iter().any(|&k| moved[gltf.primitives[k].positions]) {
            continue;
        }
        if let Err(why) =
            recompute_normals(&mut json, &mut buffers, &lengths, gltf, normal, &members)
        {
            warnings.push(format!(
                "accessors[{normal}] (NORMAL) kept as read, stale: {why}"
            ));
        }
    }

    rewrite_image_uris(&mut json, out);
    let (bin, files) = store_buffers(&mut json, gltf, &buffers, out)?;
    let main = match out.container {
        GltfContainer::Json => {
            let mut text = serde_json::to_vec_pretty(&json).map_err(io::Error::other)?;
            text.push(b'\n');
            text
        }
        GltfContainer::Binary => {
            let text = serde_json::to_vec(&json).map_err(io::Error::other)?;
            container::join_glb(&text, bin.as_deref(), &gltf.glb_chunks)
        }
    };
    if out.container == GltfContainer::Json && !gltf.glb_chunks.is_empty() {
        warnings.push(format!(
            "{} GLB chunks after the BIN chunk dropped (a .gltf has no chunks)",
            gltf.glb_chunks.len()
        ));
    }
    Ok(Encoded {
        main,
        files,
        warnings,
    })
}

/// The bits of a position, −0 as +0 (the weld key of the reader).
fn bits(p: Vec3) -> [u64; 3] {
    p.map(|x| if x == 0.0 { 0 } else { x.to_bits() })
}

/// Recomputes `accessors[normal]` from the (new) local positions of the
/// primitives `members` that use it; `Err` says why it cannot be written.
fn recompute_normals(
    json: &mut Value,
    buffers: &mut [Vec<u8>],
    lengths: &[usize],
    gltf: &GltfAttributes,
    normal: usize,
    members: &[usize],
) -> Result<(), String> {
    let layout = accessor::layout(json, lengths, normal)?;
    if layout.component_type != accessor::FLOAT || layout.components != 3 {
        return Err("not VEC3 of FLOAT".into());
    }
    let mut sum = vec![[0.0f64; 3]; layout.count];
    for &k in members {
        let prim = &gltf.primitives[k];
        let set = &gltf.positions[prim.positions];
        if set.vertices.len() != layout.count {
            return Err(format!(
                "meshes[{}].primitives[{}] has {} positions and {} normals",
                prim.mesh,
                prim.primitive,
                set.vertices.len(),
                layout.count
            ));
        }
        let positions = accessor::layout(json, lengths, set.accessor)?;
        let buffer = &buffers[positions.buffer];
        let local = |e: u32| accessor::read_vec3(buffer, &positions, e as usize).map(f64::from);
        for t in &prim.triangles {
            let [a, b, c] = t.map(local);
            let n = vec3::cross(vec3::sub(b, a), vec3::sub(c, a));
            for &e in t {
                sum[e as usize] = vec3::add(sum[e as usize], n);
            }
        }
    }
    let buffer = &mut buffers[layout.buffer];
    let mut values = Vec::with_capacity(layout.count);
    for (i, s) in sum.iter().enumerate() {
        let n = vec3::normalize_or_zero(*s);
        let value = if n == [0.0; 3] {
            accessor::read_vec3(buffer, &layout, i)
        } else {
            let n = n.map(|x| x as f32);
            accessor::write_vec3(buffer, &layout, i, n);
            n
        };
        values.push(value);
    }
    let has_bounds = item(json, "accessors", normal).is_ok_and(|a| a.contains_key("min"));
    if has_bounds {
        accessor::set_bounds(json, normal, &values);
    }
    Ok(())
}

/// Relative image URIs, resolved from the input's folder, rewritten
/// relative to the output's (as OBJ `mtllib` names are).
fn rewrite_image_uris(json: &mut Value, out: &Output) {
    let (Some(from), Some(to)) = (out.from, out.to) else {
        return;
    };
    if from == to {
        return;
    }
    let Some(Value::Array(images)) = json.get_mut("images") else {
        return;
    };
    for image in images {
        let Some(Value::String(uri)) = image.get_mut("uri") else {
            continue;
        };
        if let container::Uri::File(name) = container::classify(uri) {
            let target = from.join(name);
            *uri = match relative_path(&target, to) {
                Some(relative) => container::path_to_uri(&relative),
                None => container::path_to_uri(&target),
            };
        }
    }
}

/// The output's buffers: each buffer's `uri` set for the output container
/// (the BIN chunk's bytes returned, buffer files listed), `data:` URIs
/// re-encoded where their bytes changed.
#[allow(clippy::type_complexity)]
fn store_buffers(
    json: &mut Value,
    gltf: &GltfAttributes,
    buffers: &[Vec<u8>],
    out: &Output,
) -> io::Result<(Option<Vec<u8>>, Vec<(String, Vec<u8>)>)> {
    let chunk = match out.container {
        GltfContainer::Binary => {
            let glb = gltf
                .buffers
                .iter()
                .position(|b| b.source == GltfBufferSource::GlbChunk);
            glb.or((!buffers.is_empty()).then_some(0))
        }
        GltfContainer::Json => None,
    };
    let mut bin = None;
    let mut files = Vec::new();
    let octets = "data:application/octet-stream;base64,";
    for (i, (buffer, bytes)) in gltf.buffers.iter().zip(buffers).enumerate() {
        let Some(Value::Object(entry)) = json.pointer_mut(&format!("/buffers/{i}")) else {
            return Err(invalid(format!(
                "buffers[{i}] is missing from the document"
            )));
        };
        if chunk == Some(i) {
            entry.shift_remove("uri");
            bin = Some(bytes.clone());
            continue;
        }
        let uri = match (&buffer.source, out.stem) {
            (GltfBufferSource::DataUri { prefix }, _) => {
                if *bytes == buffer.bytes {
                    continue;
                }
                container::encode_data(prefix, bytes)
            }
            (GltfBufferSource::GlbChunk | GltfBufferSource::File { .. }, Some(stem)) => {
                let name = match files.len() {
                    0 => format!("{stem}.bin"),
                    k => format!("{stem}_{k}.bin"),
                };
                let uri = container::path_to_uri(Path::new(&name));
                files.push((name, bytes.clone()));
                uri
            }
            (GltfBufferSource::GlbChunk | GltfBufferSource::File { .. }, None) => {
                container::encode_data(octets, bytes)
            }
        };
        entry.insert("uri".into(), Value::String(uri));
    }
    Ok((bin, files))
}

/// A plain glTF of `mesh`: one node, one mesh, one primitive with f32
/// positions and u32 indices, its buffer in the BIN chunk (GLB) or a
/// `data:` URI (`.gltf`).
///
/// # Errors
/// A coordinate beyond f32's range; the errors of `w`.
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, kind: GltfContainer) -> io::Result<()> {
    check_range(mesh)?;
    let mut bytes = Vec::with_capacity(12 * mesh.num_vertices() + 12 * mesh.num_faces());
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for c in 0..3 {
            let x = p[c] as f32;
            lo[c] = lo[c].min(x);
            hi[c] = hi[c].max(x);
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let positions_length = bytes.len();
    for f in &mesh.faces {
        for v in f {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut buffer = json!({ "byteLength": bytes.len() });
    if kind == GltfContainer::Json {
        buffer["uri"] = Value::String(container::encode_data(
            "data:application/octet-stream;base64,",
            &bytes,
        ));
    }
    let document = json!({
        "asset": { "version": "2.0", "generator": "normalnet" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "mode": 4 }] }],
        "accessors": [
            {
                "bufferView": 0, "componentType": accessor::FLOAT, "count": mesh.num_vertices(),
                "type": "VEC3", "min": lo.map(accessor::json_f32), "max": hi.map(accessor::json_f32)
            },
            {
                "bufferView": 1, "componentType": accessor::UNSIGNED_INT,
                "count": 3 * mesh.num_faces(), "type": "SCALAR"
            }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": positions_length, "target": 34962 },
            {
                "buffer": 0, "byteOffset": positions_length,
                "byteLength": bytes.len() - positions_length, "target": 34963
            }
        ],
        "buffers": [buffer]
    });
    match kind {
        GltfContainer::Json => {
            serde_json::to_writer_pretty(&mut *w, &document).map_err(io::Error::other)?;
            w.write_all(b"\n")
        }
        GltfContainer::Binary => {
            let text = serde_json::to_vec(&document).map_err(io::Error::other)?;
            w.write_all(&container::join_glb(&text, Some(&bytes), &[]))
        }
    }
}
