//! Issue 38, glTF end to end: `normalnet denoise` and `batch` on a textured
//! GLB (two primitives split at a seam, TEXCOORD_0, TANGENT, a material
//! whose base colour is a PNG in a buffer view, a TRS node) keep the
//! texture, the material and the UVs byte for byte, move the positions,
//! and say that the tangents were dropped; a `.gltf` with its `.bin` and
//! image gets its own `.bin` and an image URI that still finds the image.

mod common;

use common::{bumpy_sphere, normalnet, s, stderr};
use normalnet_mesh::Mesh;
use normalnet_mesh::io::read_mesh_file;
use serde_json::{Value, json};
use std::path::Path;

/// Stands in for a texture: a PNG signature and a few bytes, never decoded.
const PNG: &[u8] = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR tiny texture";

/// One buffer of views and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, data: &[u8]) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len() }));
        self.bytes.extend_from_slice(data);
        self.views.len() - 1
    }

    fn accessor(&mut self, data: &[u8], component_type: u32, count: usize, kind: &str) -> usize {
        let view = self.view(data);
        self.accessors.push(json!({
            "bufferView": view, "componentType": component_type, "count": count, "type": kind
        }));
        self.accessors.len() - 1
    }
}

fn f32_bytes(values: impl IntoIterator<Item = f64>) -> Vec<u8> {
    values
        .into_iter()
        .flat_map(|x| (x as f32).to_le_bytes())
        .collect()
}

/// `mesh` as a glTF document: its faces in two halves, each a primitive
/// with its own vertices (the seam duplicated), UVs, tangents, u32 indices;
/// under a node with translation and scale; the texture a PNG in a view.
fn textured(mesh: &Mesh) -> (Value, Vec<u8>) {
    let mut bin = Bin::default();
    let half = mesh.num_faces() / 2;
    let mut primitives = Vec::new();
    for (p, faces) in [&mesh.faces[..half], &mesh.faces[half..]]
        .into_iter()
        .enumerate()
    {
        let mut local = std::collections::HashMap::new();
        let mut used = Vec::new();
        let mut indices = Vec::new();
        for &v in faces.iter().flatten() {
            let i = *local.entry(v).or_insert_with(|| {
                used.push(v);
                used.len() as u32 - 1
            });
            indices.push(i);
        }
        let positions = f32_bytes(used.iter().flat_map(|&v| mesh.positions[v as usize]));
        let uvs = f32_bytes(used.iter().flat_map(|&v| {
            let [x, y, z] = mesh.positions[v as usize];
            [0.5 + y.atan2(x) / std::f64::consts::TAU, 0.5 + 0.5 * z]
        }));
        let tangents = f32_bytes(used.iter().flat_map(|_| [1.0, 0.0, 0.0, 1.0]));
        let n = used.len();
        let position = bin.accessor(&positions, 5126, n, "VEC3");
        let uv = bin.accessor(&uvs, 5126, n, "VEC2");
        let tangent = bin.accessor(&tangents, 5126, n, "VEC4");
        let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let index = bin.accessor(&index_bytes, 5125, indices.len(), "SCALAR");
        primitives.push(json!({
            "attributes": { "POSITION": position, "TEXCOORD_0": uv, "TANGENT": tangent },
            "indices": index, "material": p
        }));
    }
    let image_view = bin.view(PNG);
    while !bin.bytes.len().is_multiple_of(4) {
        bin.bytes.push(0);
    }
    let doc = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "translation": [3.0, 0.0, -1.0], "scale": [0.5, 0.5, 0.5] }],
        "meshes": [{ "primitives": primitives }],
        "materials": [
            { "name": "skin", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } },
            { "name": "plain", "pbrMetallicRoughness": { "baseColorFactor": [0.2, 0.4, 0.6, 1.0] } }
        ],
        "textures": [{ "source": 0 }],
        "images": [{ "bufferView": image_view, "mimeType": "image/png" }],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.bytes.len() }]
    });
    (doc, bin.bytes)
}

fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(doc).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((28 + text.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

fn split(bytes: &[u8]) -> (Value, Vec<u8>) {
    let n = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&bytes[20..20 + n]).unwrap();
    (json, bytes[28 + n..].to_vec())
}

fn view<'a>(doc: &Value, bin: &'a [u8], index: u64) -> &'a [u8] {
    let v = &doc["bufferViews"][index as usize];
    let at = v["byteOffset"].as_u64().unwrap() as usize;
    &bin[at..at + v["byteLength"].as_u64().unwrap() as usize]
}

/// The buffer view of the accessor attribute `name` of primitive `p`.
fn attribute_view(doc: &Value, p: usize, name: &str) -> u64 {
    let a = doc["meshes"][0]["primitives"][p]["attributes"][name]
        .as_u64()
        .unwrap();
    doc["accessors"][a as usize]["bufferView"].as_u64().unwrap()
}

fn check_kept(input: &(Value, Vec<u8>), output: &Path) {
    let (doc, bin) = input;
    let (got, got_bin) = split(&std::fs::read(output).unwrap());
    for key in ["materials", "textures", "images", "nodes", "scenes"] {
        assert_eq!(got[key], doc[key], "{key}");
    }
    let image = doc["images"][0]["bufferView"].as_u64().unwrap();
    assert_eq!(view(&got, &got_bin, image), PNG, "texture kept");
    for p in 0..2 {
        let uv = attribute_view(doc, p, "TEXCOORD_0");
        assert_eq!(view(&got, &got_bin, uv), view(doc, bin, uv), "UVs kept");
        let position = attribute_view(doc, p, "POSITION");
        assert_ne!(
            view(&got, &got_bin, position),
            view(doc, bin, position),
            "denoised"
        );
        assert!(
            got["meshes"][0]["primitives"][p]["attributes"]
                .get("TANGENT")
                .is_none()
        );
        assert_eq!(got["meshes"][0]["primitives"][p]["material"], p);
    }
}

#[test]
fn denoise_and_batch_keep_a_glbs_texture_and_materials() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("scan.glb");
    let document = textured(&bumpy_sphere(12, 16, 0.03));
    std::fs::write(&input, glb(&document.0, &document.1)).unwrap();
    let read = read_mesh_file(&input).unwrap();
    assert!(read.warnings.is_empty(), "{:?}", read.warnings);

    let output = tmp.path().join("clean.glb");
    let o = normalnet(&["denoise", "-m", "gnf", s(&input), s(&output)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("meshes[0].primitives[1]: TANGENT dropped"),
        "{}",
        stderr(&o)
    );
    check_kept(&document, &output);
    let got = read_mesh_file(&output).unwrap();
    assert_eq!(
        got.mesh.faces, read.mesh.faces,
        "one welded mesh, same triangles"
    );
    assert_ne!(got.mesh.positions, read.mesh.positions);

    let out_dir = tmp.path().join("batch");
    let o = normalnet(&["batch", s(&input), "--out", s(&out_dir), "-m", "gnf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    check_kept(&document, &out_dir.join("scan.glb"));
}

#[test]
fn denoise_gltf_writes_its_own_bin_and_finds_the_image() {
    let tmp = tempfile::tempdir().unwrap();
    let in_dir = tmp.path().join("in");
    std::fs::create_dir_all(&in_dir).unwrap();
    let (mut doc, bin) = textured(&bumpy_sphere(10, 12, 0.03));
    doc["images"][0] = json!({ "uri": "tex.png" });
    doc["buffers"][0]["uri"] = json!("scan.bin");
    std::fs::write(in_dir.join("scan.bin"), &bin).unwrap();
    std::fs::write(in_dir.join("tex.png"), PNG).unwrap();
    let input = in_dir.join("scan.gltf");
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    let output = tmp.path().join("clean.gltf");
    let o = normalnet(&["denoise", "-m", "gnf", s(&input), s(&output)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got: Value = serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    assert_eq!(got["buffers"][0]["uri"], "clean.bin");
    assert_eq!(got["images"][0]["uri"], "in/tex.png");
    assert_eq!(got["materials"], doc["materials"]);
    let again = read_mesh_file(&output).unwrap();
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
    assert_eq!(
        std::fs::read(in_dir.join("scan.bin")).unwrap(),
        bin,
        "input untouched"
    );

    // another format: the mesh, and a warning naming what is dropped
    let obj = tmp.path().join("clean.obj");
    let o = normalnet(&["denoise", "-m", "gnf", s(&input), s(&obj)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("written as OBJ from glTF input"),
        "{}",
        stderr(&o)
    );
    assert!(
        stderr(&o).contains("materials, textures, texture coordinates"),
        "{}",
        stderr(&o)
    );
}
