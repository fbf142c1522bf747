//! The glTF reader: container → JSON document and buffers → the scene's
//! triangle primitives, at their world transforms → one mesh welded by
//! exactly equal world positions (the policy is in [`super`]).

use super::accessor::{
    self, FLOAT, Layout, UNSIGNED_BYTE, UNSIGNED_INT, UNSIGNED_SHORT, item, root_array, uint,
};
use super::container::{self, Uri};
use super::transform::Affine;
use super::{
    GltfAttributes, GltfBuffer, GltfBufferSource, GltfContainer, GltfPositions, GltfPrimitive,
};
use crate::error::MeshError;
use crate::io::attributes::ParsedWith;
use crate::io::{perr, strip_bom};
use crate::vec3::Vec3;
use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;

/// Extensions that store geometry elsewhere than the accessors this reader
/// reads and writes: a file requiring one is refused.
const UNSUPPORTED_EXTENSIONS: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// The positions and triangles of a glTF or GLB file (the container is
/// told by the content: GLB starts with `glTF`). `dir` is the folder
/// external buffers are read from; `None` refuses them.
pub(crate) fn parse(
    bytes: &[u8],
    path: &Path,
    dir: Option<&Path>,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), MeshError> {
    let ((positions, faces, _), _) = parse_with_attributes(bytes, path, dir)?;
    Ok((positions, faces))
}

/// [`parse`], with the document and how the mesh was gathered, and the
/// reader's warnings.
pub(crate) fn parse_with_attributes(
    bytes: &[u8],
    path: &Path,
    dir: Option<&Path>,
) -> Result<(ParsedWith<GltfAttributes>, Vec<String>), MeshError> {
    let fail = |message: String| perr(path, 0, message);
    let mut warnings = Vec::new();
    let is_glb = bytes.len() >= 4 && bytes[..4] == container::GLB_MAGIC.to_le_bytes();
    let (json_bytes, bin, glb_chunks, kind) = if is_glb {
        let glb = container::split_glb(bytes).map_err(fail)?;
        (glb.json, glb.bin, glb.other, GltfContainer::Binary)
    } else {
        (strip_bom(bytes), None, Vec::new(), GltfContainer::Json)
    };
    // GLB pads the JSON chunk with spaces; some writers pad with zeros
    let end = json_bytes
        .iter()
        .rposition(|&b| b != 0)
        .map_or(0, |i| i + 1);
    let json: Value =
        serde_json::from_slice(&json_bytes[..end]).map_err(|e| fail(format!("JSON: {e}")))?;
    if !json.is_object() {
        return Err(fail("the JSON document is not an object".into()));
    }
    let version = json
        .get("asset")
        .and_then(|a| a.get("version"))
        .and_then(Value::as_str)
        .ok_or_else(|| fail("no asset.version: not a glTF 2.0 document".into()))?;
    if !version.starts_with("2.") {
        return Err(fail(format!(
            "asset.version is {version:?}: only glTF 2.0 is read"
        )));
    }
    for name in root_array(&json, "extensionsRequired").map_err(fail)? {
        if let Some(name) = name.as_str().filter(|n| UNSUPPORTED_EXTENSIONS.contains(n)) {
            return Err(fail(format!(
                "the file requires {name}: compressed geometry is not supported"
            )));
        }
    }
    let buffers = load_buffers(&json, bin, dir).map_err(fail)?;
    let buffer_lengths: Vec<usize> = buffers.iter().map(|b| b.bytes.len()).collect();
    let (instances, unplaced) = instances(&json).map_err(fail)?;
    if let Some(unplaced) = unplaced {
        warnings.extend(unplaced.iter().map(|m| {
            format!(
                "{}: meshes[{m}] is placed by no node of the scene: kept as read, not denoised",
                path.display()
            )
        }));
    }

    let mut gather = Gather {
        json: &json,
        buffers: &buffers,
        buffer_lengths: &buffer_lengths,
        positions: Vec::new(),
        sets: Vec::new(),
        weld: HashMap::new(),
        faces: Vec::new(),
        primitives: Vec::new(),
    };
    let mut first_node: HashMap<usize, Option<usize>> = HashMap::new();
    for (node, mesh, world) in instances {
        if let Some(&first) = first_node.get(&mesh) {
            let first = first.map_or("-".to_string(), |n| n.to_string());
            warnings.push(format!(
                "{}: meshes[{mesh}] is placed by nodes {first} and {}: denoised once, at node \
                 {first} (every instance shows the result)",
                path.display(),
                node.map_or("-".to_string(), |n| n.to_string()),
            ));
            continue;
        }
        first_node.insert(mesh, node);
        gather
            .mesh(mesh, node, &world, &mut warnings, path)
            .map_err(fail)?;
    }
    if let Some(dir) = dir {
        warnings.extend(missing_images(&json, dir, path));
    }
    let Gather {
        positions,
        faces,
        sets,
        primitives,
        ..
    } = gather;
    let sizes = vec![3; faces.len()];
    let attributes = GltfAttributes {
        container: kind,
        json,
        buffers,
        glb_chunks,
        positions: sets,
        primitives,
    };
    Ok(((positions, faces, (sizes, attributes)), warnings))
}

/// The buffers' bytes: the GLB BIN chunk, decoded `data:` URIs, files read
/// from `dir`.
fn load_buffers(
    json: &Value,
    bin: Option<&[u8]>,
    dir: Option<&Path>,
) -> Result<Vec<GltfBuffer>, String> {
    let mut out = Vec::new();
    for (i, b) in root_array(json, "buffers")?.iter().enumerate() {
        let what = format!("buffers[{i}]");
        let b = b
            .as_object()
            .ok_or_else(|| format!("{what} is not an object"))?;
        let length =
            uint(b, "byteLength", &what)?.ok_or_else(|| format!("{what} has no byteLength"))?;
        let (source, bytes) = match b.get("uri") {
            None => match bin {
                Some(bin) if i == 0 => (GltfBufferSource::GlbChunk, bin.to_vec()),
                _ => {
                    return Err(format!(
                        "{what} has no uri and is not the BIN chunk of a GLB file"
                    ));
                }
            },
            Some(uri) => {
                let uri = uri
                    .as_str()
                    .ok_or_else(|| format!("{what}.uri is not a string"))?;
                match container::classify(uri) {
                    Uri::Data { prefix, base64 } => (
                        GltfBufferSource::DataUri {
                            prefix: prefix.to_string(),
                        },
                        container::decode_data(base64)
                            .map_err(|e| format!("{what}: data URI: {e}"))?,
                    ),
                    Uri::File(name) => {
                        let Some(dir) = dir else {
                            return Err(format!(
                                "{what} is the file {uri:?}: a .gltf with external buffers is read \
                                 from its file, not from memory"
                            ));
                        };
                        let file = dir.join(&name);
                        let bytes = std::fs::read(&file)
                            .map_err(|e| format!("{what}: cannot read {}: {e}", file.display()))?;
                        (
                            GltfBufferSource::File {
                                uri: uri.to_string(),
                            },
                            bytes,
                        )
                    }
                    Uri::Other => {
                        let shown: String = uri.chars().take(60).collect();
                        return Err(format!(
                            "{what} has uri {shown:?}: only data: URIs (base64) and relative file \
                             names are read"
                        ));
                    }
                }
            }
        };
        if bytes.len() < length {
            return Err(format!(
                "{what} has {} bytes, its byteLength says {length}",
                bytes.len()
            ));
        }
        out.push(GltfBuffer { source, bytes });
    }
    Ok(out)
}

/// The meshes to read, as (node, mesh, world transform) in scene order
/// (depth first, children in order); with the meshes no node of the scene
/// places (`None` in a file without scenes: then every mesh, untransformed).
#[allow(clippy::type_complexity)]
fn instances(
    json: &Value,
) -> Result<(Vec<(Option<usize>, usize, Affine)>, Option<Vec<usize>>), String> {
    let meshes = root_array(json, "meshes")?.len();
    let scenes = root_array(json, "scenes")?;
    if scenes.is_empty() {
        return Ok((
            (0..meshes).map(|m| (None, m, Affine::IDENTITY)).collect(),
            None,
        ));
    }
    let root = json
        .as_object()
        .ok_or("the JSON document is not an object")?;
    let scene = uint(root, "scene", "document")?.unwrap_or(0);
    let what = format!("scenes[{scene}]");
    let roots = match item(json, "scenes", scene)?.get("nodes") {
        None => Vec::new(),
        Some(Value::Array(nodes)) => nodes.clone(),
        Some(_) => return Err(format!("{what}.nodes is not an array")),
    };
    let num_nodes = root_array(json, "nodes")?.len();
    let mut reached = vec![false; num_nodes];
    let mut out = Vec::new();
    // (node, parent's world transform), popped in depth-first order
    let mut stack: Vec<(Value, Affine)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Affine::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        let n = node
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(|| format!("{what} lists node {node}, not an index"))?;
        let obj = item(json, "nodes", n)?;
        if std::mem::replace(&mut reached[n], true) {
            return Err(format!(
                "nodes[{n}] is reached twice in the node tree (a node has at most one parent)"
            ));
        }
        let node_what = format!("nodes[{n}]");
        let world = parent.then_inner(&local_transform(obj, &node_what)?);
        if let Some(mesh) = uint(obj, "mesh", &node_what)? {
            if mesh >= meshes {
                return Err(format!(
                    "{node_what}.mesh is {mesh}, the file has {meshes} meshes"
                ));
            }
            if obj.contains_key("skin") {
                return Err(format!(
                    "{node_what} is skinned: skinned meshes are not supported"
                ));
            }
            out.push((Some(n), mesh, world));
        }
        match obj.get("children") {
            None => {}
            Some(Value::Array(children)) => {
                stack.extend(children.iter().rev().map(|c| (c.clone(), world)));
            }
            Some(_) => return Err(format!("{node_what}.children is not an array")),
        }
    }
    let mut placed = vec![false; meshes];
    for &(_, m, _) in &out {
        placed[m] = true;
    }
    let unplaced = (0..meshes).filter(|&m| !placed[m]).collect();
    Ok((out, Some(unplaced)))
}

/// The numbers of `key` (exactly `N` of them), `None` when absent.
fn numbers<const N: usize>(
    node: &serde_json::Map<String, Value>,
    key: &str,
    what: &str,
) -> Result<Option<[f64; N]>, String> {
    let Some(v) = node.get(key) else {
        return Ok(None);
    };
    let bad = || format!("{what}.{key} is not {N} numbers");
    let items = v.as_array().filter(|a| a.len() == N).ok_or_else(bad)?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(items) {
        *o = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(Some(out))
}

/// A node's local transform: its `matrix`, else `T · R · S`.
fn local_transform(node: &serde_json::Map<String, Value>, what: &str) -> Result<Affine, String> {
    if let Some(m) = numbers::<16>(node, "matrix", what)? {
        return Affine::from_column_major(&m).map_err(|e| format!("{what}: {e}"));
    }
    let t = numbers::<3>(node, "translation", what)?.unwrap_or([0.0; 3]);
    let r = numbers::<4>(node, "rotation", what)?.unwrap_or([0.0, 0.0, 0.0, 1.0]);
    let s = numbers::<3>(node, "scale", what)?.unwrap_or([1.0; 3]);
    Ok(Affine::from_trs(t, r, s))
}

/// The welded mesh being gathered from the primitives.
struct Gather<'a> {
    json: &'a Value,
    buffers: &'a [GltfBuffer],
    buffer_lengths: &'a [usize],
    /// welded world positions
    positions: Vec<Vec3>,
    /// the `POSITION` accessors read so far
    sets: Vec<GltfPositions>,
    /// welded vertex of each world position (bits, −0 as +0)
    weld: HashMap<[u64; 3], u32>,
    faces: Vec<[u32; 3]>,
    primitives: Vec<GltfPrimitive>,
}

/// The mode names of glTF 2.0 §3.7.2.1, for messages.
fn mode_name(mode: u64) -> &'static str {
    match mode {
        0 => "points",
        1 => "lines",
        2 => "line loop",
        3 => "line strip",
        5 => "triangle strip",
        6 => "triangle fan",
        _ => "no mode of glTF",
    }
}

impl Gather<'_> {
    /// Reads every primitive of `meshes[mesh]`, placed by `node` at `world`.
    fn mesh(
        &mut self,
        mesh: usize,
        node: Option<usize>,
        world: &Affine,
        warnings: &mut Vec<String>,
        path: &Path,
    ) -> Result<(), String> {
        let mesh_obj = item(self.json, "meshes", mesh)?;
        let primitives = match mesh_obj.get("primitives") {
            Some(Value::Array(p)) => p,
            _ => return Err(format!("meshes[{mesh}] has no primitives array")),
        };
        for (p, prim) in primitives.iter().enumerate() {
            let what = format!("meshes[{mesh}].primitives[{p}]");
            let prim = prim
                .as_object()
                .ok_or_else(|| format!("{what} is not an object"))?;
            let mode = match prim.get("mode") {
                None => 4,
                Some(m) => m
                    .as_u64()
                    .ok_or_else(|| format!("{what}.mode is {m}, not a mode"))?,
            };
            if mode != 4 {
                return Err(format!(
                    "{what} has mode {mode} ({}): only triangles (mode 4) are read",
                    mode_name(mode)
                ));
            }
            if let Some(ext) = prim
                .get("extensions")
                .and_then(Value::as_object)
                .and_then(|e| {
                    e.keys()
                        .find(|k| UNSUPPORTED_EXTENSIONS.contains(&k.as_str()))
                })
            {
                return Err(format!(
                    "{what} is compressed with {ext}, which is not supported"
                ));
            }
            if prim
                .get("targets")
                .and_then(Value::as_array)
                .is_some_and(|t| !t.is_empty())
            {
                return Err(format!("{what} has morph targets, which are not supported"));
            }
            let attributes = match prim.get("attributes") {
                Some(Value::Object(a)) => a,
                _ => return Err(format!("{what} has no attributes object")),
            };
            let attribute = |name: &str| uint(attributes, name, &format!("{what}.attributes"));
            let Some(position) = attribute("POSITION")? else {
                warnings.push(format!(
                    "{}: {what} has no POSITION: kept as read, not denoised",
                    path.display()
                ));
                continue;
            };
            let normal = attribute("NORMAL")?;
            let tangent = attribute("TANGENT")?.is_some();
            let set = self.position_set(position, node, world, &what)?;
            let count = self.sets[set].vertices.len();
            let triangles = self.triangles(prim, count, position, &what)?;
            let mirrored = world.determinant() < 0.0;
            let vertices = &self.sets[set].vertices;
            self.faces.extend(triangles.iter().map(|t| {
                let [a, b, c] = t.map(|e| vertices[e as usize]);
                if mirrored { [a, c, b] } else { [a, b, c] }
            }));
            self.primitives.push(GltfPrimitive {
                mesh,
                primitive: p,
                node,
                positions: set,
                normal,
                tangent,
                triangles,
            });
        }
        Ok(())
    }

    /// The index into `sets` of `accessors[accessor]` at `world`: read and
    /// welded on first use.
    fn position_set(
        &mut self,
        accessor: usize,
        node: Option<usize>,
        world: &Affine,
        what: &str,
    ) -> Result<usize, String> {
        let rows = world.rows();
        if let Some(i) = self.sets.iter().position(|s| s.accessor == accessor) {
            if self.sets[i].world != rows {
                return Err(format!(
                    "accessors[{accessor}] is the POSITION of primitives at different transforms \
                     (the second: {what}): not supported"
                ));
            }
            return Ok(i);
        }
        let layout = self.float3(accessor, "POSITION", what)?;
        if world.inverse().is_none() {
            let node = node.map_or("-".to_string(), |n| n.to_string());
            return Err(format!(
                "nodes[{node}] (placing {what}) has a singular transform (a zero scale)"
            ));
        }
        let buffer = &self.buffers[layout.buffer].bytes;
        let mut vertices = Vec::with_capacity(layout.count);
        for i in 0..layout.count {
            let local = accessor::read_vec3(buffer, &layout, i);
            if !local.iter().all(|x| x.is_finite()) {
                return Err(format!(
                    "accessors[{accessor}] (POSITION of {what}) element {i} is not finite: {local:?}"
                ));
            }
            let p = world.apply(local.map(f64::from));
            // a mesh of glTF is one of f32 coordinates, in world space too
            // (what the plain writer stores)
            if !p.iter().all(|x| (*x as f32).is_finite()) {
                return Err(format!(
                    "accessors[{accessor}] (POSITION of {what}) element {i} lies at {p:?} in \
                     world space, beyond the range of glTF's 32-bit floats"
                ));
            }
            let key = p.map(|x| if x == 0.0 { 0u64 } else { x.to_bits() });
            let next = self.positions.len();
            if next >= u32::MAX as usize {
                return Err("more than 2^32 − 1 vertices".into());
            }
            let v = *self.weld.entry(key).or_insert_with(|| {
                self.positions.push(p);
                next as u32
            });
            vertices.push(v);
        }
        self.sets.push(GltfPositions {
            accessor,
            world: rows,
            vertices,
        });
        Ok(self.sets.len() - 1)
    }

    /// The layout of a `VEC3` `FLOAT` accessor used as `name` by `what`.
    fn float3(&self, index: usize, name: &str, what: &str) -> Result<Layout, String> {
        let layout = accessor::layout(self.json, self.buffer_lengths, index)
            .map_err(|e| format!("{what}: {name}: {e}"))?;
        if layout.component_type != FLOAT || layout.components != 3 {
            return Err(format!(
                "{what}: {name} accessors[{index}] is not VEC3 of FLOAT (componentType {}, {} \
                 components; KHR_mesh_quantization is not supported)",
                layout.component_type, layout.components
            ));
        }
        Ok(layout)
    }

    /// The triangles of a primitive with `count` vertices, as elements of
    /// its `POSITION` accessor: from its indices, else `(0 1 2) (3 4 5) …`.
    fn triangles(
        &self,
        prim: &serde_json::Map<String, Value>,
        count: usize,
        position: usize,
        what: &str,
    ) -> Result<Vec<[u32; 3]>, String> {
        let Some(indices) = uint(prim, "indices", what)? else {
            if !count.is_multiple_of(3) {
                return Err(format!(
                    "{what} has no indices and {count} vertices, not a multiple of 3"
                ));
            }
            return Ok((0..count as u32 / 3)
                .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                .collect());
        };
        let layout = accessor::layout(self.json, self.buffer_lengths, indices)
            .map_err(|e| format!("{what}: indices: {e}"))?;
        if layout.components != 1
            || ![UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT].contains(&layout.component_type)
        {
            return Err(format!(
                "{what}: indices accessors[{indices}] is not SCALAR of unsigned integers \
                 (componentType {}, {} components)",
                layout.component_type, layout.components
            ));
        }
        if !layout.count.is_multiple_of(3) {
            return Err(format!(
                "{what}: indices accessors[{indices}] has {} indices, not a multiple of 3",
                layout.count
            ));
        }
        let buffer = &self.buffers[layout.buffer].bytes;
        let mut out = Vec::with_capacity(layout.count / 3);
        for t in 0..layout.count / 3 {
            let mut tri = [0u32; 3];
            for (c, v) in tri.iter_mut().enumerate() {
                let i = 3 * t + c;
                *v = accessor::read_index(buffer, &layout, i);
                if *v as usize >= count {
                    return Err(format!(
                        "{what}: index {} (element {i} of accessors[{indices}]) is out of range: \
                         POSITION accessors[{position}] has {count} vertices",
                        *v
                    ));
                }
            }
            out.push(tri);
        }
        Ok(out)
    }
}

/// Warnings for the images whose relative `uri` names no file in `dir`.
fn missing_images(json: &Value, dir: &Path, path: &Path) -> Vec<String> {
    let images = root_array(json, "images").unwrap_or(&[]);
    images
        .iter()
        .enumerate()
        .filter_map(|(i, image)| {
            let uri = image.get("uri")?.as_str()?;
            let Uri::File(name) = container::classify(uri) else {
                return None;
            };
            (!dir.join(&name).is_file()).then(|| {
                format!(
                    "{}: images[{i}] {uri:?} not found in {}: its uri is kept as written",
                    path.display(),
                    dir.display()
                )
            })
        })
        .collect()
}
