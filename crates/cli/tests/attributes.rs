//! Issue 38 end to end: `denoise`, `batch` and `noise` write their result
//! with what the input file carries (polygons, texture coordinates,
//! materials, groups, colours, extra PLY properties).

mod common;

use common::{normalnet, s, stderr};
use normalnet_mesh::io::attributes::{FormatAttributes, ObjAttributes};
use normalnet_mesh::io::{Attributes, read_mesh_file};

/// A bumpy 6 × 6 grid of quads with colours, texture coordinates, one
/// normal per vertex, two groups with their materials.
fn quad_plate() -> String {
    let n = 7;
    let mut lines = vec!["mtllib plate.mtl".to_string(), "o plate".to_string()];
    for y in 0..n {
        for x in 0..n {
            let z = 0.03 * (((7 * x + 13 * y) % 5) as f64 - 2.0);
            lines.push(format!("v {x} {y} {z} 0.5 0.25 1"));
        }
    }
    for y in 0..n {
        for x in 0..n {
            lines.push(format!("vt {} {}", x as f64 / 6.0, y as f64 / 6.0));
            lines.push("vn 0 0 1".into());
        }
    }
    for y in 0..n - 1 {
        if y % 3 == 0 {
            lines.push(format!("g part{y}"));
            lines.push(format!("usemtl m{y}"));
        }
        for x in 0..n - 1 {
            let a = y * n + x + 1;
            let corners = [a, a + 1, a + n + 1, a + n].map(|i| format!("{i}/{i}/{i}"));
            lines.push(format!("f {}", corners.join(" ")));
        }
    }
    lines.join("\n") + "\n"
}

fn obj(attributes: &Attributes) -> &ObjAttributes {
    match &attributes.content {
        FormatAttributes::Obj(o) => o,
        other => panic!("not OBJ: {other:?}"),
    }
}

#[test]
fn denoise_batch_and_noise_keep_the_inputs_attributes() {
    let tmp = tempfile::tempdir().unwrap();
    let input_dir = tmp.path().join("in");
    let output_dir = tmp.path().join("out");
    std::fs::create_dir_all(&input_dir).unwrap();
    std::fs::create_dir_all(&output_dir).unwrap();
    std::fs::write(input_dir.join("plate.mtl"), "newmtl m0\nnewmtl m3\n").unwrap();
    let input = input_dir.join("plate.obj");
    std::fs::write(&input, quad_plate()).unwrap();
    let read = read_mesh_file(&input).unwrap();
    let want = obj(&read.attributes);

    let output = output_dir.join("plate.obj");
    let o = normalnet(&["denoise", "-m", "gnf", s(&input), s(&output)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = read_mesh_file(&output).unwrap();
    assert!(got.warnings.is_empty(), "{:?}", got.warnings);
    assert_ne!(got.mesh.positions, read.mesh.positions, "denoised");
    assert_eq!(got.mesh.faces, read.mesh.faces);
    assert_eq!(got.attributes.polygon_sizes, vec![4; 36]);
    let got_obj = obj(&got.attributes);
    assert_eq!(got_obj.vertex_tails, want.vertex_tails);
    assert_eq!(got_obj.texture_coords, want.texture_coords);
    assert_eq!(got_obj.corner_texture_coords, want.corner_texture_coords);
    assert_eq!(got_obj.corner_normals, want.corner_normals);
    assert_eq!(got_obj.material_libraries(), vec!["../in/plate.mtl"]);
    assert_ne!(got_obj.normals, want.normals, "normals recomputed");
    let text = std::fs::read_to_string(&output).unwrap();
    assert!(text.contains("\ng part3\nusemtl m3\nf 22/22/22 "), "{text}");

    let triangles = output_dir.join("triangles.obj");
    let o = normalnet(&[
        "denoise",
        "-m",
        "gnf",
        "--triangulate",
        s(&input),
        s(&triangles),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = read_mesh_file(&triangles).unwrap();
    assert_eq!(got.attributes.polygon_sizes, vec![3; 72]);

    // --remove-outliers changes the vertices: no attributes, and stderr says so
    let far = input_dir.join("far.obj");
    std::fs::write(&far, quad_plate() + "v 1e6 1e6 1e6\n").unwrap();
    let o = normalnet(&[
        "denoise",
        "-m",
        "gnf",
        "--remove-outliers",
        s(&far),
        s(&output_dir.join("far.obj")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("written without the attributes"),
        "{}",
        stderr(&o)
    );

    let batch_out = tmp.path().join("batch");
    let o = normalnet(&["batch", s(&input), "--out", s(&batch_out), "-m", "gnf"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = read_mesh_file(batch_out.join("plate.obj")).unwrap();
    assert_eq!(obj(&got.attributes).texture_coords, want.texture_coords);
    assert_eq!(got.attributes.polygon_sizes, vec![4; 36]);

    // noise on a PLY with a custom property: kept, in the input's encoding
    let ply_in = input_dir.join("quality.ply");
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 49\nproperty double x\nproperty double y\n\
         property double z\nproperty float quality\nelement face 36\n\
         property list uchar int vertex_indices\nend_header\n",
    );
    for v in 0..49 {
        ply += &format!("{} {} 0 {}\n", v % 7, v / 7, v as f64 * 0.5);
    }
    for y in 0..6 {
        for x in 0..6 {
            let a = y * 7 + x;
            ply += &format!("4 {a} {} {} {}\n", a + 1, a + 8, a + 7);
        }
    }
    std::fs::write(&ply_in, &ply).unwrap();
    let ply_out = output_dir.join("noisy.ply");
    let o = normalnet(&["noise", "--seed", "3", s(&ply_in), s(&ply_out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&ply_out).unwrap();
    assert!(text.starts_with("ply\nformat ascii 1.0\n"), "{text}");
    assert!(
        text.contains("property float quality\nelement face 36\n"),
        "{text}"
    );
    assert!(text.contains(" 24\n4 0 1 8 7\n"), "{text}");
}
