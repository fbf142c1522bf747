//! The rasterizer against analytic pixel coverage: a unit cube seen along
//! its body diagonal projects to a regular hexagon of area √3 whose bounding
//! box is √2 × 4/√6, so with the camera fit we know exactly how many pixels
//! it must cover. Also a real mesh from `../shared/data` when present.

use normalnet_mesh::Mesh;
use normalnet_render::{Image, Projection, RenderOptions, Shading, error_colors, render};

fn cube() -> Mesh {
    let positions = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let faces = vec![
        [0, 2, 1],
        [0, 3, 2],
        [4, 5, 6],
        [4, 6, 7],
        [0, 1, 5],
        [0, 5, 4],
        [3, 6, 2],
        [3, 7, 6],
        [0, 4, 7],
        [0, 7, 3],
        [1, 2, 6],
        [1, 6, 5],
    ];
    Mesh::new(positions, faces).unwrap()
}

fn covered(img: &Image, bg: [u8; 3]) -> usize {
    img.pixels().chunks(3).filter(|p| *p != bg).count()
}

#[test]
fn cube_along_its_diagonal_covers_a_hexagon() {
    let bg = [0, 0, 0];
    let (w, h, margin) = (300u32, 300u32, 0.05);
    for shading in [Shading::Flat, Shading::Smooth] {
        let opts = RenderOptions {
            width: w,
            height: h,
            azimuth_deg: 45.0,
            elevation_deg: (1.0f64 / 2.0f64.sqrt()).atan().to_degrees(), // 35.26°: eye on (1,1,1)
            margin,
            background: bg,
            shading,
            ..Default::default()
        };
        let img = render(&cube(), &opts).unwrap();
        // projected extent: √2 wide, 4/√6 tall; the fit scales the larger ratio
        let (ex, ey) = (2f64.sqrt(), 4.0 / 6f64.sqrt());
        let usable = 1.0 - 2.0 * margin;
        let scale = (w as f64 * usable / ex).min(h as f64 * usable / ey);
        let expected = 3f64.sqrt() * scale * scale;
        let got = covered(&img, bg) as f64;
        let rel = (got - expected).abs() / expected;
        println!(
            "{shading:?}: covered {got} px, analytic {expected:.1} px ({:.3} %)",
            100.0 * rel
        );
        assert!(
            rel < 0.01,
            "{shading:?}: covered {got} px, expected {expected:.0} ({rel:.4})"
        );
        // three visible faces, three distinct flat intensities are equal by
        // symmetry: every lit pixel has the same grey in flat mode
        if shading == Shading::Flat {
            let centre = img.get(w / 2, h / 2 - 20).unwrap();
            assert!(img.pixels().chunks(3).all(|p| p == bg || p == centre));
        }
    }
}

#[test]
fn perspective_cube_is_smaller_than_the_fitted_box_but_visible() {
    let bg = [0, 0, 0];
    let opts = RenderOptions {
        width: 200,
        height: 200,
        azimuth_deg: 30.0,
        elevation_deg: 25.0,
        projection: Projection::Perspective { fov_deg: 35.0 },
        background: bg,
        ..Default::default()
    };
    let img = render(&cube(), &opts).unwrap();
    let c = covered(&img, bg);
    assert!(c > 200 * 200 / 5 && c < 200 * 200 * 9 / 10, "{c}");
}

#[test]
fn face_colours_show_up_in_the_image() {
    let bg = [255, 255, 255];
    let errors: Vec<f64> = (0..12).map(|f| f as f64).collect();
    let opts = RenderOptions {
        width: 120,
        height: 120,
        azimuth_deg: 45.0,
        elevation_deg: 35.26,
        background: bg,
        ambient: 1.0, // no shading: colours exact
        face_colors: Some(error_colors(&errors, 11.0)),
        ..Default::default()
    };
    let img = render(&cube(), &opts).unwrap();
    let colours = opts.face_colors.as_ref().unwrap();
    // visible faces from (1,1,1): +z (2,3), +y (6,7), +x (10,11)
    for f in [2usize, 3, 6, 7, 10, 11] {
        assert!(
            img.pixels().chunks(3).any(|p| p == colours[f]),
            "face {f} not visible"
        );
    }
    for f in [0usize, 1, 4, 5, 8, 9] {
        assert!(
            !img.pixels().chunks(3).any(|p| p == colours[f]),
            "hidden face {f} drawn"
        );
    }
}

#[test]
fn real_scan_renders_when_data_present() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gd/Fandisk0.3/Noisy.obj"
    );
    if !std::path::Path::new(path).exists() {
        println!("skipping: {path} not found");
        return;
    }
    let mesh = normalnet_mesh::read_mesh(path).unwrap();
    let bg = [255, 255, 255];
    let img = render(
        &mesh,
        &RenderOptions {
            width: 320,
            height: 240,
            ..Default::default()
        },
    )
    .unwrap();
    let c = covered(&img, bg);
    assert!(c > 320 * 240 / 10, "only {c} pixels covered");
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Any triangle in the plane z = 0, seen head-on with the camera fitted
        /// to the unit square (so 1 unit = 100 px), covers its area in pixels
        /// up to the pixels its edges cut.
        #[test]
        fn triangle_covers_its_area(
            pts in proptest::collection::vec((0.0f64..1.0, 0.0f64..1.0), 3),
        ) {
            let p: Vec<[f64; 3]> = pts.iter().map(|&(x, y)| [x, y, 0.0]).collect();
            let mesh = Mesh::new(p.clone(), vec![[0, 1, 2]]).unwrap();
            let bg = [0, 0, 0];
            let opts = RenderOptions {
                width: 100,
                height: 100,
                azimuth_deg: 0.0,
                elevation_deg: 0.0,
                margin: 0.0,
                background: bg,
                bounds: Some(([0.0, 0.0, 0.0], [1.0, 1.0, 0.0])),
                ..Default::default()
            };
            let img = render(&mesh, &opts).unwrap();
            let area = 0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0])).abs() * 1e4;
            let d = |a: [f64; 3], b: [f64; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() * 100.0;
            let perimeter = d(p[0], p[1]) + d(p[1], p[2]) + d(p[2], p[0]);
            let got = covered(&img, bg) as f64;
            prop_assert!((got - area).abs() <= perimeter + 4.0, "covered {got}, area {area:.1}, perimeter {perimeter:.1}");
        }
    }
}
