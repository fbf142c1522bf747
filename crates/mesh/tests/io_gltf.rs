//! Issue 38, glTF 2.0 and GLB: a textured plate of two primitives (split at
//! a UV seam, each with NORMAL, TEXCOORD_0 and TANGENT, two materials, one
//! with a base-colour texture, under a TRS node tree) read as one welded
//! mesh, written back unchanged (same document, same buffer bytes) and
//! moved (positions back in local space, normals recomputed, tangents
//! dropped, everything else untouched), in both containers; its UVs and
//! colours per triangle corner of the welded mesh; and the errors of
//! broken files, each naming the file and the element.

use normalnet_mesh::io::attributes::{FormatAttributes, GltfAttributes, GltfCornerValues};
use normalnet_mesh::io::{
    FileWriteOptions, Format, MeshFile, NO_INDEX, encode_mesh_file, parse_mesh, parse_mesh_file,
    read_mesh_file, write_mesh_as, write_mesh_file, write_mesh_file_as,
};
use normalnet_mesh::{Mesh, Topology, vec3};
use serde_json::{Value, json};
use std::path::Path;

/// A 1 × 1 PNG (its bytes are never decoded, only carried).
const PNG: &[u8] = &[
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52,
    0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x1f, 0x15, 0xc4,
    0x89, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xcf, 0xc0, 0xf0,
    0x1f, 0x00, 0x05, 0x00, 0x01, 0xff, 0x89, 0x99, 0x3d, 0x1d, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45,
    0x4e, 0x44, 0xae, 0x42, 0x60, 0x82,
];

/// Vertices per side of the plate; the seam is column [`SEAM`].
const N: usize = 6;
const SEAM: usize = 3;

/// Buffer views and accessors laid into one buffer.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn floats<const K: usize>(&mut self, data: &[[f32; K]], kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(34962));
        let mut a =
            json!({ "bufferView": view, "componentType": 5126, "count": data.len(), "type": kind });
        if bounds {
            let lo: Vec<f32> = (0..K)
                .map(|c| data.iter().map(|v| v[c]).fold(f32::INFINITY, f32::min))
                .collect();
            let hi: Vec<f32> = (0..K)
                .map(|c| data.iter().map(|v| v[c]).fold(f32::NEG_INFINITY, f32::max))
                .collect();
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, triangles: &[[u32; 3]], component_type: u32) -> usize {
        let bytes: Vec<u8> = triangles
            .iter()
            .flatten()
            .flat_map(|&i| match component_type {
                5121 => vec![i as u8],
                5123 => (i as u16).to_le_bytes().to_vec(),
                _ => i.to_le_bytes().to_vec(),
            })
            .collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({
            "bufferView": view, "componentType": component_type,
            "count": 3 * triangles.len(), "type": "SCALAR"
        }));
        self.accessors.len() - 1
    }
}

/// The plate: a bumpy N × N grid, columns 0..=SEAM in primitive 0 (u16
/// indices, textured material 0), SEAM..N in primitive 1 (u8 indices,
/// material 1), the seam column in both; node 1 (the mesh) under node 0
/// (translation, a quarter turn about y, scale 2). `glb`: the image in a
/// buffer view, the buffer the BIN chunk; else the image `tex.png` and the
/// buffer `plate.bin` (the caller writes them).
fn plate(glb: bool) -> (Value, Vec<u8>) {
    let mut b = Builder::default();
    let mut primitives = Vec::new();
    for (p, columns) in [(0..SEAM + 1), (SEAM..N)].into_iter().enumerate() {
        let columns: Vec<usize> = columns.collect();
        let w = columns.len();
        let mut positions = Vec::new();
        let mut uvs = Vec::new();
        for y in 0..N {
            for &x in &columns {
                let z = 0.05 * (((7 * x + 13 * y) % 5) as f32 - 2.0);
                positions.push([x as f32 * 0.5, y as f32 * 0.5, z]);
                uvs.push([x as f32 / (N - 1) as f32, y as f32 / (N - 1) as f32]);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..N - 1 {
            for i in 0..w - 1 {
                let a = (y * w + i) as u32;
                let (b_, c, d) = (a + 1, a + w as u32 + 1, a + w as u32);
                triangles.push([a, b_, c]);
                triangles.push([a, c, d]);
            }
        }
        let count = positions.len();
        let position = b.floats(&positions, "VEC3", true);
        let normal = b.floats(&vec![[0.0, 0.0, 1.0]; count], "VEC3", false);
        let uv = b.floats(&uvs, "VEC2", false);
        let tangent = b.floats(&vec![[1.0, 0.0, 0.0, 1.0]; count], "VEC4", false);
        let indices = b.indices(&triangles, if p == 0 { 5123 } else { 5121 });
        primitives.push(json!({
            "attributes": { "POSITION": position, "NORMAL": normal, "TEXCOORD_0": uv, "TANGENT": tangent },
            "indices": indices,
            "material": p,
            "extras": { "part": p }
        }));
    }
    let image = if glb {
        let view = b.view(PNG, None);
        json!({ "bufferView": view, "mimeType": "image/png", "name": "tex" })
    } else {
        json!({ "uri": "tex.png", "name": "tex" })
    };
    while !b.bin.len().is_multiple_of(4) {
        b.bin.push(0);
    }
    let mut buffer = json!({ "byteLength": b.bin.len() });
    if !glb {
        buffer["uri"] = json!("plate.bin");
    }
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let doc = json!({
        "asset": { "version": "2.0", "generator": "io_gltf test", "x_unknown": [1, 2.5, "three"] },
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{ "nodes": [0], "name": "scene" }],
        "nodes": [
            { "name": "root", "children": [1], "translation": [1.0, 2.0, 3.0],
              "rotation": [0.0, h, 0.0, h], "scale": [2.0, 2.0, 2.0] },
            { "name": "plate", "mesh": 0, "translation": [0.5, 0.0, -0.25] }
        ],
        "meshes": [{ "name": "plate", "primitives": primitives }],
        "materials": [
            { "name": "textured", "pbrMetallicRoughness": {
                "baseColorTexture": { "index": 0, "extensions": {
                    "KHR_texture_transform": { "scale": [2.0, 2.0] } } },
                "metallicFactor": 0.0 } },
            { "name": "red", "pbrMetallicRoughness": { "baseColorFactor": [1.0, 0.0, 0.0, 1.0] },
              "doubleSided": true }
        ],
        "textures": [{ "source": 0, "sampler": 0 }],
        "images": [image],
        "samplers": [{ "magFilter": 9729, "minFilter": 9987 }],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [buffer],
        "extras": { "author": "test" }
    });
    (doc, b.bin)
}

/// A GLB file of `json` and `bin`.
fn glb_bytes(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// (JSON, BIN chunk) of a GLB file.
fn split_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(u32_at(8), bytes.len());
    let json_len = u32_at(12);
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let at = 20 + json_len;
    let bin_len = u32_at(at);
    assert_eq!(&bytes[at + 4..at + 8], b"BIN\0");
    (json, bytes[at + 8..at + 8 + bin_len].to_vec())
}

/// Writes the plate as `dir/plate.gltf` with `plate.bin` and `tex.png`.
fn write_plate_gltf(dir: &Path) -> std::path::PathBuf {
    let (doc, bin) = plate(false);
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("plate.bin"), &bin).unwrap();
    std::fs::write(dir.join("tex.png"), PNG).unwrap();
    let path = dir.join("plate.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

/// The elements of accessor `index` as f32 rows (FLOAT accessors only).
fn floats(json: &Value, bin: &[u8], index: usize) -> Vec<Vec<f32>> {
    let a = &json["accessors"][index];
    assert_eq!(a["componentType"], 5126);
    let k = match a["type"].as_str().unwrap() {
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        t => panic!("{t}"),
    };
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let stride = view["byteStride"].as_u64().map_or(4 * k, |s| s as usize);
    (0..a["count"].as_u64().unwrap() as usize)
        .map(|i| {
            (0..k)
                .map(|c| {
                    let at = start + i * stride + 4 * c;
                    f32::from_le_bytes(bin[at..at + 4].try_into().unwrap())
                })
                .collect()
        })
        .collect()
}

/// The bytes of buffer view `index`.
fn view_bytes<'a>(json: &Value, bin: &'a [u8], index: usize) -> &'a [u8] {
    let v = &json["bufferViews"][index];
    let start = v["byteOffset"].as_u64().unwrap_or(0) as usize;
    &bin[start..start + v["byteLength"].as_u64().unwrap() as usize]
}

fn gltf(file: &MeshFile) -> &GltfAttributes {
    match &file.attributes.content {
        FormatAttributes::Gltf(g) => g,
        other => panic!("not glTF: {other:?}"),
    }
}

/// `mesh` scaled by `s` about the origin (world space).
fn scaled(mesh: &Mesh, s: f64) -> Mesh {
    let positions = mesh.positions.iter().map(|p| vec3::scale(*p, s)).collect();
    Mesh::new(positions, mesh.faces.clone()).unwrap()
}

/// Number of edges with one face only.
fn boundary_edges(mesh: &Mesh) -> usize {
    let mut count = std::collections::HashMap::new();
    for f in &mesh.faces {
        for i in 0..3 {
            let (a, b) = (f[i], f[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    count.values().filter(|&&c| c == 1).count()
}

#[test]
fn primitives_are_welded_along_the_seam_in_world_space() {
    let (doc, bin) = plate(true);
    let file =
        parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("plate.glb")).unwrap();
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    let mesh = &file.mesh;
    // 4 + 3 columns, the seam column shared: N × N vertices, no seam edge open
    assert_eq!(mesh.num_vertices(), N * N);
    assert_eq!(mesh.num_faces(), 2 * (N - 1) * (N - 1));
    assert_eq!(boundary_edges(mesh), 4 * (N - 1));
    assert_eq!(
        Topology::new(mesh.num_vertices(), &mesh.faces).num_boundary_edges(),
        4 * (N - 1)
    );
    // local (0, 0, z0) → node 1: (0.5, 0, z0 − 0.25) → scale 2, a quarter
    // turn about y ((x, y, z) ↦ (z, y, −x)), + (1, 2, 3)
    let z0 = 0.05f32 * -2.0;
    let p = [0.5, 0.0, z0 as f64 - 0.25];
    let want = [1.0 + 2.0 * p[2], 2.0 + 2.0 * p[1], 3.0 - 2.0 * p[0]];
    let got = mesh.positions[0];
    assert!(vec3::dist2(got, want) < 1e-24, "{got:?} != {want:?}");
    // the welded mesh is what parse_mesh reads
    assert_eq!(
        &parse_mesh(&glb_bytes(&doc, &bin), Format::Glb, Path::new("p")).unwrap(),
        mesh
    );
    let g = gltf(&file);
    assert_eq!(g.primitives.len(), 2);
    assert_eq!(g.positions.len(), 2);
}

#[test]
fn gltf_written_back_unchanged_is_the_same_document_and_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let input = write_plate_gltf(&tmp.path().join("in"));
    let file = read_mesh_file(&input).unwrap();
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    let out_dir = tmp.path().join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let output = out_dir.join("clean.gltf");
    let warnings = write_mesh_file(
        &output,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let (mut want, bin) = plate(false);
    // the documented changes: the buffer is the output's, the image is
    // referenced from the output's folder
    want["buffers"][0]["uri"] = json!("clean.bin");
    want["images"][0]["uri"] = json!("../in/tex.png");
    let got: Value = serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    assert_eq!(got, want);
    // key order kept too
    assert_eq!(
        serde_json::to_string(&got).unwrap(),
        serde_json::to_string(&want).unwrap()
    );
    assert_eq!(std::fs::read(out_dir.join("clean.bin")).unwrap(), bin);
    // read again from there: the same mesh, the image found
    let again = read_mesh_file(&output).unwrap();
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
    assert_eq!(again.mesh, file.mesh);
}

#[test]
fn moved_vertices_go_back_in_local_space_with_new_normals_and_no_tangents() {
    let tmp = tempfile::tempdir().unwrap();
    let input = write_plate_gltf(&tmp.path().join("in"));
    let file = read_mesh_file(&input).unwrap();
    let moved = scaled(&file.mesh, 1.01);
    let output = tmp.path().join("in").join("moved.gltf");
    let warnings = write_mesh_file(
        &output,
        &moved,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    for (p, w) in warnings.iter().enumerate() {
        assert!(w.contains("moved.gltf"), "{w}");
        assert!(
            w.contains(&format!("meshes[0].primitives[{p}]: TANGENT dropped")),
            "{w}"
        );
    }
    let (before, before_bin) = plate(false);
    let after: Value = serde_json::from_slice(&std::fs::read(&output).unwrap()).unwrap();
    let after_bin = std::fs::read(tmp.path().join("in/moved.bin")).unwrap();
    assert_eq!(after["buffers"][0]["uri"], "moved.bin");
    assert_eq!(after["images"][0]["uri"], "tex.png", "same folder: kept");
    for key in [
        "materials",
        "textures",
        "images",
        "samplers",
        "nodes",
        "scenes",
        "bufferViews",
        "extras",
        "asset",
    ] {
        assert_eq!(after[key], before[key], "{key}");
    }
    assert_eq!(after_bin.len(), before_bin.len());

    // read back: the world positions are the moved ones (to f32 precision)
    let again = read_mesh_file(&output).unwrap();
    assert_eq!(again.mesh.faces, file.mesh.faces);
    for (a, b) in again.mesh.positions.iter().zip(&moved.positions) {
        assert!(vec3::dist2(*a, *b).sqrt() < 1e-5, "{a:?} != {b:?}");
    }
    for p in 0..2 {
        let prim = &after["meshes"][0]["primitives"][p];
        let old_prim = &before["meshes"][0]["primitives"][p];
        let attributes = prim["attributes"].as_object().unwrap();
        assert_eq!(
            attributes.keys().collect::<Vec<_>>(),
            ["POSITION", "NORMAL", "TEXCOORD_0"]
        );
        assert_eq!(prim["material"], old_prim["material"]);
        assert_eq!(prim["extras"], old_prim["extras"]);
        let view_of = |name: &str| {
            after["accessors"][attributes[name].as_u64().unwrap() as usize]["bufferView"]
                .as_u64()
                .unwrap() as usize
        };
        // UVs and indices: the same bytes
        for view in [
            view_of("TEXCOORD_0"),
            prim["indices"]
                .as_u64()
                .map(|i| {
                    after["accessors"][i as usize]["bufferView"]
                        .as_u64()
                        .unwrap() as usize
                })
                .unwrap(),
        ] {
            assert_eq!(
                view_bytes(&after, &after_bin, view),
                view_bytes(&before, &before_bin, view)
            );
        }
        // positions: moved, min/max their bounds
        let position = attributes["POSITION"].as_u64().unwrap() as usize;
        let local = floats(&after, &after_bin, position);
        let old_local = floats(&before, &before_bin, position);
        assert_ne!(local, old_local);
        for c in 0..3 {
            let lo = local.iter().map(|v| v[c]).fold(f32::INFINITY, f32::min);
            let hi = local.iter().map(|v| v[c]).fold(f32::NEG_INFINITY, f32::max);
            assert_eq!(
                after["accessors"][position]["min"][c].as_f64().unwrap() as f32,
                lo
            );
            assert_eq!(
                after["accessors"][position]["max"][c].as_f64().unwrap() as f32,
                hi
            );
        }
        // normals: the area-weighted vertex normals of the primitive, local
        let normal = attributes["NORMAL"].as_u64().unwrap() as usize;
        let normals = floats(&after, &after_bin, normal);
        let indices = prim["indices"].as_u64().unwrap() as usize;
        let index_view = view_bytes(
            &after,
            &after_bin,
            after["accessors"][indices]["bufferView"].as_u64().unwrap() as usize,
        );
        let index_list: Vec<usize> = if p == 0 {
            index_view
                .chunks(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize)
                .collect()
        } else {
            index_view.iter().map(|&i| i as usize).collect()
        };
        let mut want = vec![[0.0f64; 3]; local.len()];
        let v = |i: usize| [local[i][0] as f64, local[i][1] as f64, local[i][2] as f64];
        for t in index_list.chunks(3) {
            let n = vec3::cross(vec3::sub(v(t[1]), v(t[0])), vec3::sub(v(t[2]), v(t[0])));
            for &i in t {
                want[i] = vec3::add(want[i], n);
            }
        }
        for (got, want) in normals.iter().zip(&want) {
            let want = vec3::normalize_or_zero(*want);
            let got = [got[0] as f64, got[1] as f64, got[2] as f64];
            assert!(vec3::dist2(got, want) < 1e-12, "{got:?} != {want:?}");
        }
        assert!(
            normals.iter().any(|n| n != &vec![0.0, 0.0, 1.0]),
            "recomputed"
        );
    }
}

#[test]
fn glb_round_trip_unchanged_and_moved_keeps_the_texture() {
    let (doc, bin) = plate(true);
    let bytes = glb_bytes(&doc, &bin);
    let path = Path::new("plate.glb");
    let file = parse_mesh_file(&bytes, Format::Glb, path).unwrap();
    let same =
        encode_mesh_file(&file.mesh, &file.attributes, &FileWriteOptions::default()).unwrap();
    assert_eq!(same, bytes, "unchanged GLB: the same bytes");

    let moved = scaled(&file.mesh, 1.01);
    let out = encode_mesh_file(&moved, &file.attributes, &FileWriteOptions::default()).unwrap();
    let (json, out_bin) = split_glb(&out);
    assert_eq!(json["images"], doc["images"]);
    assert_eq!(json["materials"], doc["materials"]);
    let image_view = doc["images"][0]["bufferView"].as_u64().unwrap() as usize;
    assert_eq!(view_bytes(&json, &out_bin, image_view), PNG);
    let again = parse_mesh_file(&out, Format::Glb, path).unwrap();
    for (a, b) in again.mesh.positions.iter().zip(&moved.positions) {
        assert!(vec3::dist2(*a, *b).sqrt() < 1e-5);
    }
    assert!(
        json["meshes"][0]["primitives"][0]["attributes"]
            .get("TANGENT")
            .is_none()
    );
}

#[test]
fn gltf_and_glb_convert_into_each_other() {
    let tmp = tempfile::tempdir().unwrap();
    let input = write_plate_gltf(&tmp.path().join("in"));
    let file = read_mesh_file(&input).unwrap();
    let glb = tmp.path().join("plate.glb");
    let w = write_mesh_file(
        &glb,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert!(w.is_empty(), "{w:?}");
    let (json, bin) = split_glb(&std::fs::read(&glb).unwrap());
    assert!(json["buffers"][0].get("uri").is_none());
    assert_eq!(json["images"][0]["uri"], "in/tex.png");
    assert_eq!(bin, plate(false).1);
    let from_glb = read_mesh_file(&glb).unwrap();
    assert_eq!(from_glb.mesh, file.mesh);
    let back = tmp.path().join("back.gltf");
    write_mesh_file(
        &back,
        &from_glb.mesh,
        &from_glb.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    let json: Value = serde_json::from_slice(&std::fs::read(&back).unwrap()).unwrap();
    assert_eq!(json["buffers"][0]["uri"], "back.bin");
    assert_eq!(
        std::fs::read(tmp.path().join("back.bin")).unwrap(),
        plate(false).1
    );
    assert_eq!(read_mesh_file(&back).unwrap().mesh, file.mesh);
}

#[test]
fn data_uri_buffers_stay_data_uris() {
    let (mut doc, bin) = plate(true);
    doc["buffers"][0]["uri"] = json!(format!(
        "data:application/gltf-buffer;base64,{}",
        base64(&bin)
    ));
    let bytes = serde_json::to_vec(&doc).unwrap();
    let file = parse_mesh_file(&bytes, Format::Gltf, Path::new("d.gltf")).unwrap();
    let same =
        encode_mesh_file(&file.mesh, &file.attributes, &FileWriteOptions::default()).unwrap();
    assert_eq!(serde_json::from_slice::<Value>(&same).unwrap(), doc);
    let out = encode_mesh_file(
        &scaled(&file.mesh, 0.5),
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    let json: Value = serde_json::from_slice(&out).unwrap();
    let uri = json["buffers"][0]["uri"].as_str().unwrap();
    assert!(uri.starts_with("data:application/gltf-buffer;base64,"));
    assert_ne!(json["buffers"][0]["uri"], doc["buffers"][0]["uri"]);
    let again = parse_mesh_file(&out, Format::Gltf, Path::new("d.gltf")).unwrap();
    assert!(
        vec3::dist2(
            again.mesh.positions[3],
            vec3::scale(file.mesh.positions[3], 0.5)
        ) < 1e-10
    );
}

/// Base64 of the test's own (independent of the crate's codec).
fn base64(bytes: &[u8]) -> String {
    let alphabet = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for j in 0..4 {
            out.push(if j <= c.len() {
                alphabet[(n >> (18 - 6 * j) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

#[test]
fn another_format_gets_the_world_mesh_and_a_warning_naming_what_is_dropped() {
    let tmp = tempfile::tempdir().unwrap();
    let input = write_plate_gltf(&tmp.path().join("in"));
    let file = read_mesh_file(&input).unwrap();
    let obj = tmp.path().join("plate.obj");
    let w = write_mesh_file(
        &obj,
        &file.mesh,
        &file.attributes,
        &FileWriteOptions::default(),
    )
    .unwrap();
    assert_eq!(w.len(), 1, "{w:?}");
    for what in [
        "written as OBJ from glTF input",
        "materials",
        "textures",
        "texture coordinates",
        "normals",
        "tangents",
        "node transforms",
        "primitives",
    ] {
        assert!(w[0].contains(what), "{what}: {}", w[0]);
    }
    assert_eq!(read_mesh_file(&obj).unwrap().mesh, file.mesh);
    // and an OBJ written as GLB: a plain document of the mesh
    let glb = tmp.path().join("plain.glb");
    write_mesh_as(&glb, &file.mesh, Format::Glb, &Default::default()).unwrap();
    let plain = read_mesh_file(&glb).unwrap();
    assert_eq!(plain.mesh.faces, file.mesh.faces);
    for (a, b) in plain.mesh.positions.iter().zip(&file.mesh.positions) {
        assert_eq!(a.map(|x| x as f32), b.map(|x| x as f32));
    }
    let gltf_path = tmp.path().join("plain.gltf");
    write_mesh_file_as(
        &gltf_path,
        &plain.mesh,
        &plain.attributes,
        Format::Gltf,
        &Default::default(),
    )
    .unwrap();
    assert_eq!(read_mesh_file(&gltf_path).unwrap().mesh, plain.mesh);
}

#[test]
fn mirrored_nodes_turn_the_triangles_over_and_scenes_are_optional() {
    let (mut doc, bin) = plate(true);
    doc["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]);
    doc["nodes"][0]["rotation"] = json!([0.0, 0.0, 0.0, 1.0]);
    let file = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("m.glb")).unwrap();
    // the plate faces +z in local space; mirrored in x it still faces +z
    let normal = |mesh: &Mesh| {
        let [a, b, c] = mesh.corners(0);
        vec3::cross(vec3::sub(b, a), vec3::sub(c, a))
    };
    assert!(normal(&file.mesh)[2] > 0.0);
    // without scenes: every mesh, untransformed
    for key in ["scene", "scenes"] {
        doc.as_object_mut().unwrap().shift_remove(key);
    }
    let flat = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("m.glb")).unwrap();
    assert_eq!(flat.mesh.positions[2], [1.0, 0.0, (0.05f32 * 2.0) as f64]);
    assert!(normal(&flat.mesh)[2] > 0.0);
}

#[test]
fn instanced_and_unplaced_meshes_are_warned_about() {
    let (mut doc, bin) = plate(true);
    doc["nodes"][0]["children"] = json!([1, 2]);
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "mesh": 0, "translation": [9.0, 0.0, 0.0] }));
    let mut meshes = doc["meshes"].as_array().unwrap().clone();
    meshes.push(json!({ "primitives": [] }));
    doc["meshes"] = json!(meshes);
    let file = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("i.glb")).unwrap();
    assert_eq!(file.mesh.num_vertices(), N * N);
    assert_eq!(file.warnings.len(), 2, "{:?}", file.warnings);
    assert!(
        file.warnings
            .iter()
            .any(|w| w.contains("meshes[1] is placed by no node"))
    );
    assert!(
        file.warnings
            .iter()
            .any(|w| w.contains("meshes[0] is placed by nodes 1 and 2"))
    );
}

/// `parse_mesh_file` of `bytes` fails with a message naming the file and
/// containing `want`.
fn refused(bytes: &[u8], format: Format, want: &str) {
    let path = Path::new("broken.glb");
    let e = parse_mesh_file(bytes, format, path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("broken.glb"), "{e}");
    assert!(e.contains(want), "want {want:?}, got {e:?}");
    let e = parse_mesh(bytes, format, path).unwrap_err().to_string();
    assert!(e.contains(want), "want {want:?}, got {e:?}");
}

#[test]
fn broken_files_are_refused_naming_the_file_and_the_element() {
    let (doc, bin) = plate(true);
    let good = glb_bytes(&doc, &bin);
    refused(
        &good[..good.len() - 7],
        Format::Glb,
        "truncated GLB: the header says",
    );
    refused(&good[..10], Format::Glb, "truncated GLB: 10 bytes");
    let mut bad_chunk = good.clone();
    bad_chunk[16..20].copy_from_slice(b"XXXX");
    refused(
        &bad_chunk,
        Format::Glb,
        "GLB chunk 0 at byte 12 is of unknown type",
    );
    let mut long_chunk = good.clone();
    let json_len = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
    long_chunk[20 + json_len..24 + json_len].copy_from_slice(&(bin.len() as u32 + 8).to_le_bytes());
    refused(&long_chunk, Format::Glb, "GLB chunk 1 at byte");

    let with = |edit: &dyn Fn(&mut Value)| {
        let mut d = doc.clone();
        edit(&mut d);
        glb_bytes(&d, &bin)
    };
    refused(
        &with(&|d| d["accessors"][0]["count"] = json!(1000)),
        Format::Glb,
        "meshes[0].primitives[0]: POSITION: accessors[0] (1000 elements of 12 bytes, stride 12, from byte 0) is out of range: bufferViews[0] has",
    );
    refused(
        &with(&|d| d["bufferViews"][0]["byteLength"] = json!(1 << 20)),
        Format::Glb,
        "bufferViews[0] (bytes 0 + 1048576) runs past the end of buffers[0]",
    );
    refused(
        &with(&|d| d["meshes"][0]["primitives"][1]["mode"] = json!(1)),
        Format::Glb,
        "meshes[0].primitives[1] has mode 1 (lines): only triangles (mode 4) are read",
    );
    refused(
        &with(&|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(77)),
        Format::Glb,
        "accessors[77] does not exist",
    );
    refused(
        &with(&|d| d["accessors"][0]["componentType"] = json!(5123)),
        Format::Glb,
        "POSITION accessors[0] is not VEC3 of FLOAT",
    );
    refused(
        &with(&|d| d["accessors"][0]["sparse"] = json!({ "count": 1 })),
        Format::Glb,
        "accessors[0] is sparse",
    );
    refused(
        &with(&|d| d["meshes"][0]["primitives"][0]["targets"] = json!([{ "POSITION": 0 }])),
        Format::Glb,
        "meshes[0].primitives[0] has morph targets",
    );
    refused(
        &with(&|d| d["nodes"][1]["skin"] = json!(0)),
        Format::Glb,
        "nodes[1] is skinned",
    );
    refused(
        &with(&|d| d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])),
        Format::Glb,
        "requires KHR_draco_mesh_compression",
    );
    refused(
        &with(&|d| d["nodes"][0]["scale"] = json!([1.0, 0.0, 1.0])),
        Format::Glb,
        "nodes[1] (placing meshes[0].primitives[0]) has a singular transform",
    );
    refused(
        &with(&|d| d["nodes"][1]["children"] = json!([0])),
        Format::Glb,
        "nodes[0] is reached twice",
    );
    // found by fuzzing: a world position beyond f32, which no glTF holds
    refused(
        &with(&|d| d["nodes"][0]["translation"] = json!([1e39, 0.0, 0.0])),
        Format::Glb,
        "element 0 lies at",
    );
    refused(
        &with(&|d| d["asset"]["version"] = json!("1.0")),
        Format::Glb,
        "only glTF 2.0",
    );
    refused(
        &with(&|d| d["buffers"][0]["byteLength"] = json!(1 << 20)),
        Format::Glb,
        "buffers[0] has",
    );
    refused(b"{ not json", Format::Gltf, "JSON:");

    // an index out of range: the u8 indices of primitive 1 at byte 0 of their view
    let indices = doc["meshes"][0]["primitives"][1]["indices"]
        .as_u64()
        .unwrap() as usize;
    let view = doc["accessors"][indices]["bufferView"].as_u64().unwrap() as usize;
    let at = doc["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize;
    let mut bad_bin = bin.clone();
    bad_bin[at + 4] = 200;
    refused(
        &glb_bytes(&doc, &bad_bin),
        Format::Glb,
        &format!(
            "meshes[0].primitives[1]: index 200 (element 4 of accessors[{indices}]) is out of range: POSITION accessors[5] has 18 vertices"
        ),
    );

    // a .gltf with a buffer file cannot be parsed from memory
    let (doc, _) = plate(false);
    refused(
        &serde_json::to_vec(&doc).unwrap(),
        Format::Gltf,
        "buffers[0] is the file \"plate.bin\"",
    );
}

#[test]
fn missing_buffer_file_is_an_error_and_missing_image_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let input = write_plate_gltf(tmp.path());
    std::fs::remove_file(tmp.path().join("tex.png")).unwrap();
    let file = read_mesh_file(&input).unwrap();
    assert_eq!(file.warnings.len(), 1);
    assert!(
        file.warnings[0].contains("images[0] \"tex.png\" not found"),
        "{:?}",
        file.warnings
    );
    std::fs::remove_file(tmp.path().join("plate.bin")).unwrap();
    let e = read_mesh_file(&input).unwrap_err().to_string();
    assert!(
        e.contains("plate.gltf") && e.contains("buffers[0]: cannot read"),
        "{e}"
    );
}

/// Appends an accessor of `count` elements of `kind` stored as `bytes` to
/// the plate's document and buffer (a GLB's BIN chunk); returns its index.
fn append_accessor(
    doc: &mut Value,
    bin: &mut Vec<u8>,
    bytes: &[u8],
    (component_type, kind, count): (u32, &str, usize),
    normalized: bool,
) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
    let view = views.len() - 1;
    bin.extend_from_slice(bytes);
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    let accessors = doc["accessors"].as_array_mut().unwrap();
    let mut a = json!({
        "bufferView": view, "componentType": component_type, "count": count, "type": kind
    });
    if normalized {
        a["normalized"] = json!(true);
    }
    accessors.push(a);
    accessors.len() - 1
}

/// The accessor of attribute `name` of primitive `p` of the plate.
fn attribute_of(doc: &Value, p: usize, name: &str) -> usize {
    doc["meshes"][0]["primitives"][p]["attributes"][name]
        .as_u64()
        .unwrap() as usize
}

/// Checks that every corner's value is an element of its own primitive's
/// accessor, at the very element of the `POSITION` accessor that gave the
/// mesh vertex at that corner (winding included); returns, per primitive,
/// the index of its accessor's element 0 in `cv.values` (`None` without
/// the attribute).
fn check_corners(mesh: &Mesh, g: &GltfAttributes, cv: &GltfCornerValues) -> Vec<Option<u32>> {
    assert_eq!(cv.corners.len(), mesh.num_faces());
    let mut bases = Vec::new();
    let mut f = 0;
    for p in &g.primitives {
        let vertices = &g.positions[p.positions].vertices;
        let first = cv.corners[f][0];
        // corner 0 is the file's corner 0 (a mirror swaps 1 and 2)
        let base = (first != NO_INDEX).then(|| first - p.triangles[0][0]);
        for _ in &p.triangles {
            for k in 0..3 {
                match base {
                    None => assert_eq!(cv.corners[f][k], NO_INDEX),
                    Some(base) => {
                        let e = (cv.corners[f][k] - base) as usize;
                        assert_eq!(vertices[e], mesh.faces[f][k], "face {f} corner {k}");
                    }
                }
            }
            f += 1;
        }
        bases.push(base);
    }
    assert_eq!(f, mesh.num_faces());
    bases
}

/// The plate (GLB) with `COLOR_0` on primitive 1 only: normalized
/// unsigned bytes, RGBA `(e, 255, 0, 51)` for element `e`; the document,
/// the BIN chunk and the colour count.
fn coloured_plate() -> (Value, Vec<u8>, usize) {
    let (mut doc, mut bin) = plate(true);
    let count = (N - SEAM) * N;
    let colours: Vec<u8> = (0..count).flat_map(|e| [e as u8, 255, 0, 51]).collect();
    let colour = append_accessor(&mut doc, &mut bin, &colours, (5121, "VEC4", count), true);
    doc["meshes"][0]["primitives"][1]["attributes"]["COLOR_0"] = json!(colour);
    (doc, bin, count)
}

#[test]
fn uv_and_colours_per_corner_follow_the_welded_triangles() {
    let (doc, bin, count) = coloured_plate();
    let file = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("c.glb")).unwrap();
    let (mesh, g) = (&file.mesh, gltf(&file));

    let uv = g.corner_values("TEXCOORD_0").unwrap().unwrap();
    let bases = check_corners(mesh, g, &uv);
    assert_eq!(bases, [Some(0), Some(((SEAM + 1) * N) as u32)]);
    // the values are the accessors' elements, primitive 0's first
    let mut want: Vec<Vec<f64>> = Vec::new();
    for p in 0..2 {
        let elements = floats(&doc, &bin, attribute_of(&doc, p, "TEXCOORD_0"));
        want.extend(
            elements
                .iter()
                .map(|e| e.iter().map(|&x| f64::from(x)).collect()),
        );
    }
    assert_eq!(uv.values, want);
    // the seam column's vertices are at corners of both primitives, with two
    // value indices (one per primitive) and, the plate's UVs being
    // continuous, the same value
    let mut seen: std::collections::HashMap<u32, Vec<u32>> = Default::default();
    for (face, corners) in mesh.faces.iter().zip(&uv.corners) {
        for (v, c) in face.iter().zip(corners) {
            seen.entry(*v).or_default().push(*c);
        }
    }
    let mut seam = 0;
    for indices in seen.values() {
        let value = &uv.values[indices[0] as usize];
        assert!(indices.iter().all(|&i| &uv.values[i as usize] == value));
        seam += usize::from(indices.iter().any(|&i| i != indices[0]));
    }
    assert_eq!(seam, N);

    let colour = g.corner_values("COLOR_0").unwrap().unwrap();
    assert_eq!(check_corners(mesh, g, &colour), [None, Some(0)]);
    assert_eq!(colour.values.len(), count);
    for (e, value) in colour.values.iter().enumerate() {
        assert_eq!(value, &[e as f64 / 255.0, 1.0, 0.0, 0.2]);
    }
    assert_eq!(g.corner_values("COLOR_1").unwrap(), None);
    assert_eq!(g.corner_values("NORMAL").unwrap().unwrap().values.len(), 42);
}

#[test]
fn corner_values_turn_over_with_the_triangles_under_a_mirror() {
    let (mut doc, bin) = plate(true);
    doc["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]);
    let file = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("m.glb")).unwrap();
    let g = gltf(&file);
    let uv = g.corner_values("TEXCOORD_0").unwrap().unwrap();
    check_corners(&file.mesh, g, &uv);
    let [a, b, c] = g.primitives[0].triangles[0];
    assert_eq!(uv.corners[0], [a, c, b]);
}

#[test]
fn corner_values_of_a_glb_from_another_format_are_absent() {
    let mesh = parse_mesh(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        Format::Obj,
        Path::new("t.obj"),
    )
    .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let glb = tmp.path().join("t.glb");
    write_mesh_as(&glb, &mesh, Format::Glb, &Default::default()).unwrap();
    let file = read_mesh_file(&glb).unwrap();
    for name in ["TEXCOORD_0", "COLOR_0"] {
        assert_eq!(gltf(&file).corner_values(name).unwrap(), None);
    }
}

#[test]
fn broken_attribute_accessors_are_errors_naming_the_primitive() {
    let (doc, bin) = plate(true);
    let count = (N - SEAM) * N;
    for (bytes, layout, want) in [
        (
            vec![0u8; 4 * count],
            (5126, "SCALAR", count),
            "meshes[0].primitives[1]: TEXCOORD_0 accessors[10] has type \"SCALAR\", not VEC2, \
             VEC3 or VEC4",
        ),
        (
            vec![0u8; 8 * 3],
            (5126, "VEC2", 3),
            "meshes[0].primitives[1]: TEXCOORD_0 accessors[10] has 3 elements, its POSITION has 18",
        ),
        (
            vec![0u8; 8],
            (5126, "VEC2", count),
            "meshes[0].primitives[1]: TEXCOORD_0: accessors[10] (18 elements of 8 bytes",
        ),
    ] {
        let (mut doc, mut bin) = (doc.clone(), bin.clone());
        let index = append_accessor(&mut doc, &mut bin, &bytes, layout, false);
        assert_eq!(index, 10);
        doc["meshes"][0]["primitives"][1]["attributes"]["TEXCOORD_0"] = json!(index);
        let file =
            parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("b.glb")).unwrap();
        let e = gltf(&file)
            .corner_values("TEXCOORD_0")
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "want {want:?}, got {e:?}");
        // the mesh and the other attributes are still read
        assert!(gltf(&file).corner_values("NORMAL").unwrap().is_some());
    }
    // an accessor shared by primitives of different vertex counts
    let mut doc = doc;
    let shared = attribute_of(&doc, 0, "TEXCOORD_0");
    doc["meshes"][0]["primitives"][1]["attributes"]["TEXCOORD_0"] = json!(shared);
    let file = parse_mesh_file(&glb_bytes(&doc, &bin), Format::Glb, Path::new("s.glb")).unwrap();
    let e = gltf(&file)
        .corner_values("TEXCOORD_0")
        .unwrap_err()
        .to_string();
    let want = format!(
        "meshes[0].primitives[1]: TEXCOORD_0 accessors[{shared}] has {} elements, its POSITION \
         has {count}",
        (SEAM + 1) * N
    );
    assert!(e.contains(&want), "want {want:?}, got {e:?}");
}

/// Edited UVs and colours go back into their accessors (floats as f32,
/// normalized bytes as the nearest step), `min`/`max` follow, a `data:`
/// buffer is encoded anew, and the written file reads back with the edits;
/// values the accessors cannot hold are refused before anything changes.
#[test]
fn corner_values_written_back_into_the_accessors_read_back() {
    let (mut doc, bin, _) = coloured_plate();
    let uv0 = attribute_of(&doc, 0, "TEXCOORD_0");
    doc["accessors"][uv0]["min"] = json!([0.0, 0.0]);
    doc["accessors"][uv0]["max"] = json!([1.0, 1.0]);
    let tmp = tempfile::tempdir().unwrap();
    for glb in [true, false] {
        let bytes = if glb {
            glb_bytes(&doc, &bin)
        } else {
            // one .gltf with the buffer as a data: URI
            let mut d = doc.clone();
            d["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                base64(&bin)
            ));
            serde_json::to_vec(&d).unwrap()
        };
        let format = if glb { Format::Glb } else { Format::Gltf };
        let mut file = parse_mesh_file(&bytes, format, Path::new("e.glb")).unwrap();
        let FormatAttributes::Gltf(g) = &mut file.attributes.content else {
            panic!("glTF attributes")
        };
        let mut uv = g.corner_values("TEXCOORD_0").unwrap().unwrap();
        for v in &mut uv.values {
            *v = vec![2.0 * v[0] + 0.1, 0.5 - v[1]];
        }
        let mut colour = g.corner_values("COLOR_0").unwrap().unwrap();
        for v in &mut colour.values {
            v[1] = 0.5;
        }
        // refused, nothing written: too few elements, a non-finite value,
        // a normalized value beyond 1, a component too many
        let before = g.clone();
        let mut nan = colour.values.clone();
        nan[3][0] = f64::NAN;
        let mut beyond = colour.values.clone();
        beyond[3][0] = 1.5;
        let mut wide = colour.values.clone();
        wide[3] = vec![0.0; 5];
        for (name, values, want) in [
            ("TEXCOORD_0", &uv.values[1..], "elements given"),
            ("COLOR_0", &nan[..], "COLOR_0: element 3: NaN is not finite"),
            ("COLOR_0", &beyond[..], "outside the normalized range"),
            ("COLOR_0", &wide[..], "element 3 has 5 components"),
            ("COLOR_1", &wide[..], "no primitive has it"),
        ] {
            let e = g.set_corner_values(name, values).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
        assert_eq!(*g, before);

        g.set_corner_values("TEXCOORD_0", &uv.values).unwrap();
        g.set_corner_values("COLOR_0", &colour.values).unwrap();
        let out = tmp.path().join(if glb { "e.glb" } else { "e.gltf" });
        write_mesh_file(&out, &file.mesh, &file.attributes, &Default::default()).unwrap();
        let again = read_mesh_file(&out).unwrap();
        let g2 = gltf(&again);
        let read_uv = g2.corner_values("TEXCOORD_0").unwrap().unwrap();
        let f32s = |vs: &[Vec<f64>]| -> Vec<Vec<f64>> {
            vs.iter()
                .map(|v| v.iter().map(|&x| f64::from(x as f32)).collect())
                .collect()
        };
        assert_eq!(read_uv.values, f32s(&uv.values));
        assert_eq!(read_uv.corners, uv.corners);
        let read_colour = g2.corner_values("COLOR_0").unwrap().unwrap();
        for (e, v) in read_colour.values.iter().enumerate() {
            assert_eq!(v, &[e as f64 / 255.0, 128.0 / 255.0, 0.0, 0.2]);
        }
        let bounds = &g2.json["accessors"][uv0];
        // the shortest digits of the f32 bounds (glTF 2.0 §5.1.1)
        assert_eq!(bounds["min"][0].as_f64(), Some(0.1), "{bounds}");
        assert_eq!(bounds["max"][1].as_f64(), Some(0.5), "{bounds}");
        assert_eq!(again.mesh, file.mesh);
    }
}
