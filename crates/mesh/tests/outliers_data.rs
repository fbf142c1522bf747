//! Issue 14: the outlier detector reports nothing on clean meshes (the
//! shipped example and the models of `../shared/data`), and finds one stray
//! vertex added to each of them. Skips a model with a message when the
//! shared data is absent.

use normalnet_mesh::outliers::{OutlierParams, outlier_vertices};
use normalnet_mesh::{Mesh, read_mesh, vec3};
use std::path::{Path, PathBuf};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

fn meshes() -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = ["examples/clean-part.obj", "examples/noisy-part.obj"]
        .iter()
        .map(|p| Path::new(ROOT).join(p))
        .collect();
    let data = Path::new(DATA);
    if !data.exists() {
        eprintln!("SKIP: {} not found (shared data absent)", data.display());
        return paths;
    }
    // Every model of c3d, every gd pair, the first noise level of cnr.
    let list = |dir: PathBuf| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        v.sort();
        v
    };
    paths.extend(
        list(data.join("c3d"))
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "obj")),
    );
    for dir in list(data.join("gd")).into_iter().chain(
        list(data.join("cnr"))
            .into_iter()
            .filter(|d| d.to_string_lossy().ends_with("_n1")),
    ) {
        for name in ["Noisy.obj", "Original.obj"] {
            if dir.join(name).exists() {
                paths.push(dir.join(name));
            }
        }
    }
    paths
}

/// Largest `|x − m| / q` and largest shortest-incident-edge / median edge.
fn ratios(mesh: &Mesh) -> (f64, f64) {
    let o = outlier_vertices(mesh, &OutlierParams::default());
    let far = mesh
        .positions
        .iter()
        .map(|&p| vec3::dist2(p, o.centre).sqrt() / o.robust_radius)
        .fold(0.0, f64::max);
    let mut shortest = vec![f64::INFINITY; mesh.num_vertices()];
    for t in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let l = vec3::dist2(mesh.positions[a], mesh.positions[b]).sqrt();
            shortest[a] = shortest[a].min(l);
            shortest[b] = shortest[b].min(l);
        }
    }
    let spike = shortest
        .iter()
        .filter(|l| l.is_finite())
        .map(|l| l / o.median_edge_length)
        .fold(0.0, f64::max);
    (far, spike)
}

#[test]
fn issue_14_no_outliers_on_clean_meshes() {
    for path in meshes() {
        let mesh = read_mesh(&path).unwrap();
        let o = outlier_vertices(&mesh, &OutlierParams::default());
        let (far, spike) = ratios(&mesh);
        eprintln!(
            "{}: {} outliers, max distance {far:.2} q, max shortest edge {spike:.2} l_med",
            path.display(),
            o.count()
        );
        assert_eq!(o.count(), 0, "{}: {:?}", path.display(), o.vertices);
    }
}

#[test]
fn issue_14_a_stray_vertex_is_found_on_every_mesh() {
    for path in meshes() {
        let mesh = read_mesh(&path).unwrap();
        let (lo, hi) = mesh.bounding_box();
        let extent = vec3::norm(vec3::sub(hi, lo));
        let v = mesh.faces[mesh.num_faces() / 2][0] as usize;
        for far in [[1e30, 0.0, 0.0], [0.0, 1e6 * extent, 0.0]] {
            let mut m = mesh.clone();
            m.positions[v] = vec3::add(m.positions[v], far);
            let o = outlier_vertices(&m, &OutlierParams::default());
            assert_eq!(o.vertices, vec![v as u32], "{}", path.display());
        }
    }
}
