//! glTF 2.0, as JSON (`.gltf`, buffers in `data:` URIs or in files beside
//! it) or binary (`.glb`): the reader ([`read`]), the writers ([`write`]),
//! the containers ([`container`]), accessors ([`accessor`]) and node
//! transforms ([`transform`]), with what a glTF file holds beyond the
//! welded mesh the denoiser sees ([`GltfAttributes`], kept by
//! [`super::read_mesh_file`]) and its vertex attributes per triangle
//! corner of that mesh ([`GltfAttributes::corner_values`], in
//! [`corners`]: texture coordinates, colours).
//!
//! Reading: every triangle primitive (`mode` 4 or absent) of every mesh a
//! node of the scene (`scene`, else scene 0) places, each at its node's
//! world transform (matrices and TRS composed down the node tree), or of
//! every mesh, untransformed, when the file has no scene. Their vertices
//! are welded by exactly equal world positions into one mesh, so that
//! primitives split at material or UV seams share the seam's vertices; the
//! mesh's vertices are the welded positions in order of first appearance,
//! its triangles the primitives' in order (turned over under a mirroring
//! transform). A mesh placed by several nodes is read once, at its first
//! node (a warning names the others: they show the same result).
//!
//! Writing back ([`super::write_mesh_file`]) changes only what the new
//! positions make stale: each moved vertex goes back into its `POSITION`
//! accessor's bytes in place (inverse world transform, f32), the
//! accessor's `min`/`max` are updated, `NORMAL` accessors of the moved
//! primitives are recomputed in place (each element the normalised
//! area-weighted sum of the local-space normals of the triangles using it,
//! so hard edges stay hard; an element no triangle uses keeps its value)
//! and `TANGENT` is removed from those primitives (a warning names each
//! one; viewers recompute tangents). A vertex that did not move keeps its
//! bytes; a file read and written unchanged keeps every byte of its
//! buffers. Everything else is passed through: the JSON as read (key order
//! kept, numbers as parsed), every other accessor, buffer view, material,
//! texture, image, sampler, animation, extension and extra, the buffer
//! layout, further GLB chunks. Buffers in files are written beside the
//! output as `<stem>.bin` (then `<stem>_1.bin`, …; their `uri` updated),
//! `data:` buffers stay `data:` URIs, and relative image URIs are rewritten
//! relative to the output's folder (the images are not copied). `.gltf` ↔
//! `.glb` converts the container: GLB's BIN chunk becomes `<stem>.bin`, and
//! a `.gltf`'s first buffer becomes the BIN chunk.
//!
//! Refused with an error naming the element: sparse or non-float
//! `POSITION` accessors, indices that are no unsigned integers or out of
//! range, morph targets, skins, `KHR_draco_mesh_compression`,
//! `EXT_meshopt_compression`, points and lines and strips, a singular node
//! transform, an accessor or buffer view beyond its bytes, a `POSITION`
//! accessor that two primitives place differently.

pub(crate) mod accessor;
mod base64;
pub(crate) mod container;
pub(crate) mod corners;
mod read;
pub(crate) mod transform;
mod write;

pub use corners::GltfCornerValues;
pub(super) use read::{parse, parse_with_attributes};
pub(super) use write::{Output, check_range, encode_with_attributes, write};

/// The container a glTF document came in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GltfContainer {
    /// JSON text (`.gltf`)
    Json,
    /// binary GLB (`.glb`)
    Binary,
}

/// Where a buffer's bytes are stored.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GltfBufferSource {
    /// the BIN chunk of a GLB file (buffer 0, without `uri`)
    GlbChunk,
    /// a base64 `data:` URI; `prefix` is what precedes the base64 text
    /// (`data:application/octet-stream;base64,`)
    DataUri {
        /// the URI up to and including `;base64,`
        prefix: String,
    },
    /// a file named by a relative URI (as written in the document)
    File {
        /// the `uri`, as written (percent-encoded)
        uri: String,
    },
}

/// One buffer of the document: where it was stored and its bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GltfBuffer {
    /// where the bytes came from
    pub source: GltfBufferSource,
    /// the buffer's bytes as read (at least its `byteLength`)
    pub bytes: Vec<u8>,
}

/// A `POSITION` accessor the mesh was read from, at one world transform.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfPositions {
    /// index into the document's `accessors`
    pub accessor: usize,
    /// world transform of the primitives using it: 3 rows of `[m | t]`,
    /// `world = m · local + t`
    pub world: [[f64; 4]; 3],
    /// per accessor element, its (welded) mesh vertex (len = its count)
    pub vertices: Vec<u32>,
}

/// A triangle primitive the mesh was read from.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfPrimitive {
    /// index into the document's `meshes`
    pub mesh: usize,
    /// index into that mesh's `primitives`
    pub primitive: usize,
    /// the node placing it; `None` in a file without scenes
    pub node: Option<usize>,
    /// index into [`GltfAttributes::positions`] of its `POSITION` accessor
    pub positions: usize,
    /// its `NORMAL` accessor, if any (recomputed when a vertex moves)
    pub normal: Option<usize>,
    /// whether it has a `TANGENT` attribute (dropped when a vertex moves)
    pub tangent: bool,
    /// its triangles as elements of its `POSITION` accessor, in file
    /// winding (len = its triangles; they are consecutive faces of the mesh)
    pub triangles: Vec<[u32; 3]>,
}

/// Everything of a glTF file beyond the welded mesh: the document, its
/// buffers, and how the mesh was gathered from its primitives.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfAttributes {
    /// the container read
    pub container: GltfContainer,
    /// the JSON document as read (object key order kept)
    pub json: serde_json::Value,
    /// the buffers, in the order of the document's `buffers`
    pub buffers: Vec<GltfBuffer>,
    /// GLB chunks after the BIN chunk (type, bytes), kept verbatim
    pub glb_chunks: Vec<(u32, Vec<u8>)>,
    /// the `POSITION` accessors read, in order of first use
    pub positions: Vec<GltfPositions>,
    /// the triangle primitives read, in mesh order
    pub primitives: Vec<GltfPrimitive>,
}

impl GltfAttributes {
    /// What the file holds beyond positions and triangles, for the warning
    /// of a format change.
    pub(crate) fn describe(&self) -> Vec<String> {
        let mut held = Vec::new();
        let has = |name: &str| {
            accessor::root_array(&self.json, name).is_ok_and(|items| !items.is_empty())
        };
        let attribute = |prefix: &str| {
            accessor::root_array(&self.json, "meshes")
                .unwrap_or(&[])
                .iter()
                .filter_map(|m| m.get("primitives")?.as_array())
                .flatten()
                .filter_map(|p| p.get("attributes")?.as_object())
                .any(|a| a.keys().any(|k| k.starts_with(prefix)))
        };
        for (present, what) in [
            (has("materials"), "materials"),
            (has("textures") || has("images"), "textures"),
            (attribute("TEXCOORD_"), "texture coordinates"),
            (attribute("COLOR_"), "vertex colours"),
            (attribute("NORMAL"), "normals"),
            (attribute("TANGENT"), "tangents"),
            (has("animations"), "animations"),
            (
                self.primitives.len() > 1,
                "primitives (merged into one mesh)",
            ),
            (
                self.positions.iter().any(|p| {
                    p.world
                        != [
                            [1.0, 0.0, 0.0, 0.0],
                            [0.0, 1.0, 0.0, 0.0],
                            [0.0, 0.0, 1.0, 0.0],
                        ]
                }),
                "node transforms (positions written in world space)",
            ),
            (self.json.get("extensionsUsed").is_some(), "extensions"),
        ] {
            if present {
                held.push(what.to_string());
            }
        }
        held
    }
}

impl GltfPositions {
    /// The world transform as a map.
    pub(crate) fn transform(&self) -> transform::Affine {
        let w = &self.world;
        transform::Affine {
            m: [
                [w[0][0], w[0][1], w[0][2]],
                [w[1][0], w[1][1], w[1][2]],
                [w[2][0], w[2][1], w[2][2]],
            ],
            t: [w[0][3], w[1][3], w[2][3]],
        }
    }
}

impl transform::Affine {
    /// The 3 rows of `[m | t]` ([`GltfPositions::world`]).
    pub(crate) fn rows(&self) -> [[f64; 4]; 3] {
        std::array::from_fn(|r| [self.m[r][0], self.m[r][1], self.m[r][2], self.t[r]])
    }
}
