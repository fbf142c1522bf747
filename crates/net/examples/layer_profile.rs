//! Microseconds per sample in every layer of the shipped lite network 1
//! (every default: int8 blocks, stem and shortcuts), one thread, on the
//! real grids of a mesh's faces (every 6th face, first iteration):
//! `cargo run --release -p normalnet-net --example layer_profile -- [mesh.obj] [f32-shortcuts]`
//! (default mesh: `../shared/data/gd/Fandisk0.3/Noisy.obj`). The head runs
//! per sample here (batched in `normalnet denoise`), and the grids are dense
//! (gathered; the voxelizer hands sparse ones to `normalnet denoise`).
#![allow(missing_docs)]

use normalnet_cnn::Arithmetic;
use normalnet_mesh::Topology;
use normalnet_voxel::{Scratch, Voxelizer};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let default = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gd/Fandisk0.3/Noisy.obj"
    );
    let path = args.get(1).map_or(default, String::as_str);
    let mesh = normalnet_mesh::io::read_mesh(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut bundle = normalnet_net::embedded::lite().expect("built-in model");
    bundle.set_arithmetic(Arithmetic {
        int8_shortcut: args.get(2).is_none_or(|a| a != "f32-shortcuts"),
        ..Arithmetic::INT8
    });
    let params = bundle.voxel_params();
    let vox = Voxelizer::new(&mesh, &topo, params).expect("voxelizer");
    let len = params.grid_len();
    let faces: Vec<usize> = (0..mesh.num_faces()).step_by(6).collect();
    let mut grids = vec![0.0f32; faces.len() * len];
    let mut scratch = Scratch::new();
    for (&f, grid) in faces.iter().zip(grids.chunks_exact_mut(len)) {
        vox.voxelize_face_with(&mut scratch, f, 0.0, grid);
    }
    let cnn = &bundle.engines[0];
    let mut out = vec![0.0f32; faces.len() * cnn.outputs()];
    // the best of three runs per layer
    let mut best: Vec<(String, f64)> = Vec::new();
    for _ in 0..3 {
        let times = cnn
            .forward_profiled(&grids, &mut out)
            .expect("forward")
            .named();
        best = match best.is_empty() {
            true => times,
            false => best
                .into_iter()
                .zip(times)
                .map(|(a, b)| (a.0, a.1.min(b.1)))
                .collect(),
        };
    }
    let per_sample = |s: f64| s * 1e6 / faces.len() as f64;
    for (name, s) in &best {
        println!("{name:40} {:7.1} µs", per_sample(*s));
    }
    let total: f64 = best.iter().map(|b| b.1).sum();
    println!(
        "{:40} {:7.1} µs ({} samples of {path})",
        "total",
        per_sample(total),
        faces.len()
    );
}
