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

/// Pixels of a picture that are clearly red, blue and green: their counts
/// and mean (column, row).
fn colour_pixels(png: &std::path::Path) -> [(usize, [f64; 2]); 3] {
    let image = normalnet_render::Image::decode_png(&std::fs::read(png).unwrap()).unwrap();
    let mut found = [(0, [0.0, 0.0]); 3];
    for y in 0..image.height() {
        for x in 0..image.width() {
            let [r, g, b] = image.get(x, y).unwrap().map(i32::from);
            for (k, strong) in [r, b, g].into_iter().enumerate() {
                let others = r + g + b - strong;
                if strong > 120 && 2 * strong > others + 80 {
                    found[k].0 += 1;
                    found[k].1[0] += x as f64;
                    found[k].1[1] += y as f64;
                }
            }
        }
    }
    found.map(|(n, sum)| (n, sum.map(|c| c / n.max(1) as f64)))
}

/// Issue 38: a textured OBJ, denoised, is drawn by `render` with its
/// texture in place (the denoised file keeps `vt`, corner indices and its
/// `mtllib`, rewritten to reach the input's library from the output folder)
/// and its materials' colours; `--no-texture` and a missing image draw the
/// base colour.
#[test]
fn render_draws_a_denoised_obj_with_its_texture_and_material_colours() {
    let tmp = tempfile::tempdir().unwrap();
    let (input_dir, output_dir) = (tmp.path().join("in"), tmp.path().join("out"));
    std::fs::create_dir_all(&input_dir).unwrap();
    std::fs::create_dir_all(&output_dir).unwrap();
    // left half red, right half blue; the second material plain green
    let mut texture = normalnet_render::Image::new(16, 16, [230, 20, 20]);
    texture.fill_rect(8, 0, 8, 16, [20, 20, 230]);
    texture.write_png(input_dir.join("halves.png")).unwrap();
    std::fs::write(
        input_dir.join("plate.mtl"),
        "newmtl m0\nmap_Kd halves.png\nnewmtl m3\nKd 0.1 0.9 0.1\n",
    )
    .unwrap();
    let input = input_dir.join("plate.obj");
    std::fs::write(&input, quad_plate()).unwrap();
    let output = output_dir.join("plate.obj");
    let out = normalnet(&["-q", "denoise", s(&input), s(&output), "-m", "gnf"]);
    assert!(out.status.success(), "{}", stderr(&out));

    let picture = |name: &str, extra: &[&str]| {
        let png = tmp.path().join(name);
        let mut args = vec![
            "-q",
            "render",
            s(&output),
            "-o",
            s(&png),
            "--size",
            "300x300",
        ];
        args.extend_from_slice(extra);
        let out = normalnet(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        (colour_pixels(&png), stderr(&out))
    };
    // face-on (eye on +z): x to the right, y up. Rows y 0..3 of the plate
    // use the texture (u = x / 6: red left, blue right), rows 3..6 green.
    let ([(red, at_red), (blue, at_blue), (green, at_green)], _) =
        picture("textured.png", &["--view", "0,0"]);
    assert!(
        red > 5000 && blue > 5000 && green > 10000,
        "{red} {blue} {green}"
    );
    assert!(
        at_red[0] + 50.0 < at_blue[0],
        "red {at_red:?} left of blue {at_blue:?}"
    );
    assert!(
        at_green[1] + 50.0 < at_red[1],
        "green {at_green:?} above red {at_red:?}"
    );
    let plain = |found: [(usize, [f64; 2]); 3]| found.map(|(n, _)| n);
    let (found, _) = picture("plain.png", &["--no-texture"]);
    assert_eq!(plain(found), [0, 0, 0]);
    std::fs::remove_file(input_dir.join("halves.png")).unwrap();
    let (found, warning) = picture("missing.png", &[]);
    assert_eq!(plain(found), [0, 0, 0]);
    assert!(warning.contains("halves.png"), "{warning}");
}
