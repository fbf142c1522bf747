//! NormalNet inference speed (issue 12): face-passes per second of the whole
//! pipeline, and of its two stages run one after the other (voxelizer, CNN),
//! on Fandisk0.3 (when ../shared/data is present) and on a generated noisy
//! 100k-face shape, with the f32 and (where the CPU has AVX2 or VNNI) int8 engines;
//! then the denoising of Fandisk0.3 end to end: the defaults (int8, freeze
//! 0.5, flat skip 15°) and the shortcuts off. With `NORMALNET_TORCH_PYTHON` set
//! to a Python that has torch, the same lite network in PyTorch CPU f32
//! (`../shared/tools/torch_bench/bench.py`, forward, 2 threads) runs in the
//! same process run as the ratio anchor.
//!
//! `cargo bench -p normalnet-denoise --bench normalnet_speed` (a few
//! minutes; `NORMALNET_SPEED_QUICK=1` skips the end-to-end runs). One JSON
//! object per line. Timings are wall-clock on whatever the machine is doing:
//! compare figures of one run, on idle cores.

use normalnet_denoise::{Denoiser, Params};
use normalnet_mesh::noise::{NoiseParams, add_noise};
use normalnet_mesh::{Mesh, NoProgress, Topology, compare, read_mesh};
use normalnet_net::bundle::network_for_iteration;
use normalnet_net::pipeline::filtered_normals;
use normalnet_net::{Arithmetic, Bundle, NUM_OUTPUTS};
use normalnet_voxel::Voxelizer;
use serde_json::{Value, json};
use std::time::Instant;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");
const TORCH_BENCH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/tools/torch_bench/bench.py"
);

fn meshes() -> Vec<(String, Mesh, Option<Mesh>)> {
    let mut out = Vec::new();
    let dir = format!("{DATA}/gd/Fandisk0.3");
    match (
        read_mesh(format!("{dir}/Noisy.obj")),
        read_mesh(format!("{dir}/Original.obj")),
    ) {
        (Ok(noisy), Ok(gt)) => out.push(("Fandisk0.3".into(), noisy, Some(gt))),
        _ => eprintln!("{dir} not found: Fandisk0.3 skipped"),
    }
    let clean = normalnet_voxel::shapes::generate_seeded(46, 100_000).expect("shape");
    let noisy = add_noise(&clean, &NoiseParams::default()).expect("noise");
    out.push(("shape46-100k".into(), noisy, Some(clean)));
    out
}

/// One pass of network 1 over every face: the pipeline as it runs
/// (voxelizer and CNN overlapping), then the two stages alone.
fn one_pass(name: &str, mesh: &Mesh, bundle: &Bundle, precision: &str) {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let n = mesh.num_faces();
    let net = &bundle.engines[network_for_iteration(1)];
    let t = Instant::now();
    filtered_normals(
        mesh,
        &topology,
        net,
        bundle.manifest.networks[0].residual,
        bundle.voxel_params(),
        0,
        256,
        None,
        &NoProgress,
    )
    .expect("pass");
    let pipeline = t.elapsed().as_secs_f64();

    let voxelizer = Voxelizer::new(mesh, &topology, bundle.voxel_params()).expect("voxelizer");
    let grid_len = bundle.voxel_params().grid_len();
    let mut buf = vec![0.0f32; 256 * grid_len];
    let mut out = vec![0.0f32; 256 * NUM_OUTPUTS];
    let (mut vox_s, mut cnn_s) = (0.0, 0.0);
    let faces: Vec<u32> = (0..n as u32).collect();
    for chunk in faces.chunks(256) {
        let grids = &mut buf[..chunk.len() * grid_len];
        let t = Instant::now();
        grids.fill(0.0);
        voxelizer.voxelize_batch(chunk, grids);
        vox_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        net.forward(grids, &mut out[..chunk.len() * NUM_OUTPUTS])
            .expect("forward");
        cnn_s += t.elapsed().as_secs_f64();
    }
    // per layer, one thread, on the first 512 faces' grids
    let first: Vec<u32> = faces.iter().copied().take(512).collect();
    let mut grids = vec![0.0f32; first.len() * grid_len];
    voxelizer.voxelize_batch(&first, &mut grids);
    let mut out = vec![0.0f32; first.len() * NUM_OUTPUTS];
    let layers = net.forward_profiled(&grids, &mut out).expect("profile");
    let per_sample: Vec<Value> = layers
        .named()
        .into_iter()
        .map(|(layer, s)| json!({"layer": layer, "us_per_sample": 1e6 * s / first.len() as f64}))
        .collect();
    println!(
        "{}",
        json!({"bench": "cnn_layers_one_thread", "mesh": name, "precision": precision, "layers": per_sample})
    );
    println!(
        "{}",
        json!({
            "bench": "one_pass",
            "mesh": name,
            "precision": precision,
            "faces": n,
            "threads": rayon::current_num_threads(),
            "instruction_set": net.instruction_set(),
            "pipeline_face_passes_per_s": n as f64 / pipeline,
            "voxelizer_alone_faces_per_s": n as f64 / vox_s,
            "cnn_alone_faces_per_s": n as f64 / cnn_s,
        })
    );
}

/// The default denoising, exact and with the shortcuts, end to end.
fn end_to_end(name: &str, mesh: &Mesh, gt: &Mesh) {
    let variants: [(&str, Value); 6] = [
        (
            "defaults (int8 blocks and stem, freeze_deg=0.5, flat_skip_deg=15, reuse_move=0.1)",
            json!({}),
        ),
        ("reuse_move=0", json!({"reuse_move": 0.0})),
        ("int8_stem=false", json!({"int8_stem": false})),
        (
            "int8 blocks, f32 stem, no reuse (the defaults before issue 12's third round)",
            json!({"int8_stem": false, "reuse_move": 0.0}),
        ),
        (
            "int8 blocks, f32 stem, freeze_deg=0, flat_skip_deg=0, reuse_move=0",
            json!({"int8_stem": false, "freeze_deg": 0.0, "flat_skip_deg": 0.0, "reuse_move": 0.0}),
        ),
        (
            "f32, freeze_deg=0, flat_skip_deg=0, reuse_move=0 (the exact pipeline)",
            json!({"int8": false, "freeze_deg": 0.0, "flat_skip_deg": 0.0, "reuse_move": 0.0}),
        ),
    ];
    for (label, params) in variants {
        let params: Params = params.as_object().cloned().unwrap_or_default();
        let method = Denoiser::new("normalnet", &params).expect("normalnet");
        let t = Instant::now();
        let outcome = method.run(mesh, None, &NoProgress).expect("denoise");
        let seconds = t.elapsed().as_secs_f64();
        let stages = outcome.stages.unwrap_or_default();
        println!(
            "{}",
            json!({
                "bench": "denoise",
                "mesh": name,
                "variant": label,
                "seconds": seconds,
                "face_passes": stages.faces_processed,
                "iterations": stages.iterations.len(),
                "e_a_deg": compare(gt, &outcome.mesh).expect("metrics").e_a_deg,
            })
        );
    }
}

/// PyTorch CPU f32, the same lite network, forward at batch 64, 2 threads.
fn torch_anchor() {
    let Some(python) = std::env::var_os("NORMALNET_TORCH_PYTHON") else {
        eprintln!("NORMALNET_TORCH_PYTHON not set: no PyTorch anchor");
        return;
    };
    let out = std::process::Command::new(python)
        .args([
            TORCH_BENCH,
            "--preset",
            "lite",
            "--mode",
            "forward",
            "--threads",
            "2",
        ])
        .env_remove("OPENBLAS_CORETYPE")
        .env_remove("OPENBLAS_L2_SIZE")
        .output();
    match out {
        Ok(o) if o.status.success() => {
            for line in String::from_utf8_lossy(&o.stdout).lines() {
                println!("{{\"bench\": \"torch_anchor\", \"torch\": {line}}}");
            }
        }
        Ok(o) => eprintln!("torch bench failed: {}", String::from_utf8_lossy(&o.stderr)),
        Err(e) => eprintln!("torch bench did not start: {e}"),
    }
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else is taken
    let f32_bundle = normalnet_net::embedded::lite().expect("built-in bundle");
    let mut int8_bundle = normalnet_net::embedded::lite().expect("built-in bundle");
    let int8 = int8_bundle.set_arithmetic(Arithmetic::INT8_BLOCKS).int8;
    let meshes = meshes();
    torch_anchor();
    for (name, mesh, _) in &meshes {
        one_pass(name, mesh, &f32_bundle, "f32");
        if int8 {
            one_pass(name, mesh, &int8_bundle, "int8");
        }
    }
    if std::env::var_os("NORMALNET_SPEED_QUICK").is_none() {
        for (name, mesh, gt) in &meshes {
            if let (Some(gt), true) = (gt, name == "Fandisk0.3") {
                end_to_end(name, mesh, gt);
            }
        }
    }
    torch_anchor();
}
