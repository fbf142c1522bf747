use super::*;
use crate::ModelConfig;
use crate::bundle::{new_manifest, save_bundle};
use normalnet_cnn::Cnn;
use normalnet_mesh::NoProgress;
use normalnet_mesh::geometry::face_normals;
use normalnet_voxel::frame::{Mat3, mat_vec};
use normalnet_voxel::{VoxelParams, Voxelizer};

fn shape() -> Mesh {
    normalnet_voxel::shapes::generate_seeded(3, 400).unwrap()
}

fn transform(mesh: &Mesh, r: &Mat3, scale: f64, shift: Vec3) -> Mesh {
    let p = mesh
        .positions
        .iter()
        .map(|&x| vec3::add(vec3::scale(mat_vec(r, x), scale), shift))
        .collect();
    mesh.with_positions(p)
}

/// Rotation by `angle` about the unit `axis` (Rodrigues).
fn rotation(axis: Vec3, angle: f64) -> Mat3 {
    let [x, y, z] = vec3::normalize_or_zero(axis);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

fn engine(seed: u64) -> Cnn {
    Cnn::new(&ModelConfig::tiny().init_weights(seed)).unwrap()
}

fn run(mesh: &Mesh, net: &Cnn, yaws: Option<&[f64]>) -> Vec<Vec3> {
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    filtered_normals(
        mesh,
        &topology,
        net,
        false,
        VoxelParams::tiny(),
        2,
        64,
        yaws,
        &NoProgress,
    )
    .unwrap()
    .0
}

fn angles_deg(a: &[Vec3], b: &[Vec3]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(x, y)| vec3::angle(*x, *y).to_degrees())
        .collect()
}

#[test]
fn outputs_are_unit_and_invariant_to_translation_and_scale() {
    let net = engine(7);
    let mesh = shape();
    let a = run(&mesh, &net, None);
    assert_eq!(a.len(), mesh.num_faces());
    assert!(a.iter().all(|n| (vec3::norm(*n) - 1.0).abs() < 1e-9));
    let moved = transform(&mesh, &IDENTITY, 3.5, [10.0, -4.0, 2.0]);
    let b = run(&moved, &net, None);
    let err = angles_deg(&a, &b);
    let mean = err.iter().sum::<f64>() / err.len() as f64;
    assert!(mean < 0.05, "mean change {mean}°");
}

/// A residual network whose output layer is zero predicts "no change":
/// every filtered normal is the face's current normal; the same network
/// read as a direct predictor gives no direction at all (fallback).
#[test]
fn a_zero_residual_is_the_identity() {
    let config = ModelConfig::tiny();
    let mut w = config.init_weights(4);
    w.output.weight.fill(0.0);
    w.output.bias.as_mut().unwrap().fill(0.0);
    let mesh = shape();
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let pass = |w: &normalnet_cnn::NetWeights| {
        let net = Cnn::new(w).unwrap();
        let (normals, _) = filtered_normals(
            &mesh,
            &topology,
            &net,
            true,
            VoxelParams::tiny(),
            2,
            64,
            None,
            &NoProgress,
        )
        .unwrap();
        normals
    };
    let current = face_normals(&mesh);
    let err = angles_deg(&pass(&w), &current);
    assert!(
        err.iter().all(|&e| e < 1e-4),
        "max {:?}",
        err.iter().cloned().fold(0.0, f64::max)
    );
    // a non-zero residual moves the normals
    w.output.bias.as_mut().unwrap().fill(0.2);
    let moved = pass(&w);
    assert!(angles_deg(&moved, &current).iter().any(|&e| e > 5.0));
}

const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The frame aligns the 2-ring mean normal with y and leaves the yaw
/// free, so rotating the mesh by R is exactly the same as keeping it and
/// turning each face's grid by the yaw φ_f = yaw of `W'_f · R · W_fᵀ`.
/// Outputs must then be the rotated outputs: this checks that the
/// network outputs are rotated back with the right `W_rᵀ`. (An untrained
/// network is not yaw-invariant, so without the yaws they would differ.)
#[test]
fn rotating_the_mesh_rotates_the_outputs_modulo_the_free_yaw() {
    let net = engine(8);
    let mesh = shape();
    let r = rotation([0.3, -0.5, 0.8], 1.1);
    let rotated = transform(&mesh, &r, 1.0, [0.0; 3]);
    let topo = Topology::new(mesh.num_vertices(), &mesh.faces);
    let v = Voxelizer::new(&mesh, &topo, VoxelParams::tiny()).unwrap();
    let vr = Voxelizer::new(&rotated, &topo, VoxelParams::tiny()).unwrap();
    let yaws: Vec<f64> = (0..mesh.num_faces())
        .map(|f| {
            let w = v.frame(f, 0.0).rotation;
            let wr = vr.frame(f, 0.0).rotation;
            // M = W'_f R W_fᵀ, a rotation about y by φ: M[0][2] = sin φ, M[0][0] = cos φ
            let m = |i: usize, j: usize| {
                (0..3)
                    .map(|a| (0..3).map(|b| wr[i][a] * r[a][b] * w[j][b]).sum::<f64>())
                    .sum::<f64>()
            };
            assert!((m(1, 1) - 1.0).abs() < 1e-9, "not a yaw");
            m(0, 2).atan2(m(0, 0))
        })
        .collect();
    let base = run(&mesh, &net, Some(&yaws));
    let expected: Vec<Vec3> = base.iter().map(|n| mat_vec(&r, *n)).collect();
    let got = run(&rotated, &net, None);
    let err = angles_deg(&expected, &got);
    let mean = err.iter().sum::<f64>() / err.len() as f64;
    assert!(mean < 0.05, "mean deviation {mean}°");
    // and the yaw matters for an untrained network: without it the
    // outputs are not simply rotated
    let plain: Vec<Vec3> = run(&mesh, &net, None)
        .iter()
        .map(|n| mat_vec(&r, *n))
        .collect();
    let off = angles_deg(&plain, &got);
    assert!(off.iter().sum::<f64>() / off.len() as f64 > 0.05);
}

/// A bundle of six freshly initialised tiny networks.
fn tiny_bundle() -> Bundle {
    let dir = tempfile::tempdir().unwrap();
    let manifest = new_manifest("tiny").unwrap();
    let nets: Vec<normalnet_cnn::NetWeights> = (0..6)
        .map(|i| ModelConfig::tiny().init_weights(i))
        .collect();
    save_bundle(dir.path(), &manifest, &nets).unwrap();
    Bundle::load(dir.path()).unwrap()
}

#[test]
fn denoise_runs_every_interval_without_nan() {
    let bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let params = DenoiseParams {
        iterations: 11,
        vertex_iterations: 2,
        batch: 50,
        auto_stop_deg: 0.0,
        freeze_deg: 0.0,
        flat_skip_deg: 0.0,
        reuse_move: 0.0,
        ..DenoiseParams::default()
    };
    let (out, times) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
    assert_eq!(out.faces, mesh.faces);
    assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
    assert_ne!(out.positions, mesh.positions);
    assert_eq!(times.faces_processed, 11 * mesh.num_faces());
    assert!(times.cnn_s > 0.0 && times.total_s >= times.cnn_s);
    let bad = DenoiseParams {
        iterations: 0,
        ..DenoiseParams::default()
    };
    assert!(matches!(
        denoise(&mesh, &bundle, &bad, &NoProgress),
        Err(NetError::InvalidParameter {
            name: "iterations",
            ..
        })
    ));
}

#[test]
fn unmoved_neighbourhoods_reuse_the_same_networks_output() {
    let bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let run = |reuse_move: f64| {
        let params = DenoiseParams {
            // network 4 serves iterations 4 and 5, network 5 iteration 6
            iterations: 6,
            vertex_iterations: 2,
            batch: 50,
            auto_stop_deg: 0.0,
            freeze_deg: 0.0,
            flat_skip_deg: 0.0,
            reuse_move,
            ..DenoiseParams::default()
        };
        denoise(&mesh, &bundle, &params, &NoProgress).unwrap()
    };
    let evaluated = |times: &StageTimes| -> Vec<usize> {
        times.iterations.iter().map(|i| i.faces_evaluated).collect()
    };
    let n = mesh.num_faces();
    let (exact, t_exact) = run(0.0);
    assert_eq!(evaluated(&t_exact), vec![n; 6]);
    // every vertex counts as unmoved: the same network's faces reuse
    // their outputs, a new network evaluates every face
    let (all, t_all) = run(180.0);
    assert_eq!(evaluated(&t_all), vec![n, n, n, n, 0, n]);
    assert!(all.positions.iter().flatten().all(|x| x.is_finite()));
    assert_eq!(all.faces, exact.faces);
    for bad in [-0.1, f64::NAN] {
        let params = DenoiseParams {
            reuse_move: bad,
            ..DenoiseParams::default()
        };
        assert!(matches!(
            denoise(&mesh, &bundle, &params, &NoProgress),
            Err(NetError::InvalidParameter {
                name: "reuse_move",
                ..
            })
        ));
    }
}

#[test]
fn the_learned_switch_blends_candidates_and_is_optional() {
    let mut bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let run = |bundle: &Bundle, switch: bool| {
        let params = DenoiseParams {
            iterations: 2,
            vertex_iterations: 3,
            switch,
            ..DenoiseParams::default()
        };
        denoise(&mesh, bundle, &params, &NoProgress)
            .unwrap()
            .0
            .positions
    };
    let paper = run(&bundle, true);
    // a switch that always takes the network's output is the paper's form
    bundle.manifest.switch = Some(crate::switch::tests::constant(0));
    let same = run(&bundle, true);
    let largest = paper
        .iter()
        .zip(&same)
        .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
        .fold(0.0, f64::max);
    assert!(largest < 1e-9, "moved {largest}");
    // switched off: exactly the paper's form
    assert_eq!(run(&bundle, false), paper);
    // always "stay": the vertices lie in their faces' planes and do not move
    bundle.manifest.switch = Some(crate::switch::tests::constant(3));
    let stay = run(&bundle, true);
    let largest = mesh
        .positions
        .iter()
        .zip(&stay)
        .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
        .fold(0.0, f64::max);
    assert!(largest < 1e-9, "moved {largest}");
    // ... and the run stops after the first iteration: every face stayed
    let params = DenoiseParams {
        iterations: 5,
        vertex_iterations: 3,
        ..DenoiseParams::default()
    };
    let (_, times) = denoise(&mesh, &bundle, &params, &NoProgress).unwrap();
    assert_eq!(times.iterations.len(), 1);
    assert_eq!(times.iterations[0].stay_share, 1.0);
    let fixed = DenoiseParams {
        auto_stop_deg: 0.0,
        ..params
    };
    let (_, times) = denoise(&mesh, &bundle, &fixed, &NoProgress).unwrap();
    assert_eq!(times.iterations.len(), 5);
    // always the guided pass: the guided form
    bundle.manifest.switch = Some(crate::switch::tests::constant(1));
    let guided = DenoiseParams {
        iterations: 2,
        vertex_iterations: 3,
        guided_from: 1,
        switch: false,
        ..DenoiseParams::default()
    };
    let guided = denoise(&mesh, &bundle, &guided, &NoProgress).unwrap().0;
    let largest = guided
        .positions
        .iter()
        .zip(&run(&bundle, true))
        .map(|(a, b)| vec3::norm(vec3::sub(*a, *b)))
        .fold(0.0, f64::max);
    assert!(largest < 1e-9, "moved {largest}");
}

#[test]
fn a_run_whose_noise_level_reaches_the_heavy_threshold_uses_the_heavy_table() {
    use crate::switch::HeavyTable;
    use crate::switch::tests::constant;
    let mut bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let level = first_noise_level(&mesh);
    let params = DenoiseParams {
        iterations: 2,
        vertex_iterations: 3,
        auto_stop_deg: 0.0,
        ..DenoiseParams::default()
    };
    let run = |bundle: &Bundle| denoise(&mesh, bundle, &params, &NoProgress).unwrap().0;
    // main table "stay", heavy table the network's output
    let with_heavy = |from_noise_level: f64| {
        let mut main = constant(3);
        main.heavy = Some(Box::new(HeavyTable {
            from_noise_level,
            table: constant(0),
        }));
        Some(main)
    };
    bundle.manifest.switch = Some(constant(3));
    let stay = run(&bundle).positions;
    bundle.manifest.switch = Some(constant(0));
    let network = run(&bundle).positions;
    assert_ne!(stay, network);
    bundle.manifest.switch = with_heavy(level * 1.01);
    assert_eq!(run(&bundle).positions, stay, "below the threshold: main");
    bundle.manifest.switch = with_heavy(level);
    assert_eq!(run(&bundle).positions, network, "from it: heavy");
}

/// `clean` with the first vertex of face 0 pushed through the surface by
/// three mean edge lengths: its fan folds.
fn pushed_through(clean: &Mesh) -> Mesh {
    let topology = Topology::new(clean.num_vertices(), &clean.faces);
    let l = normalnet_mesh::geometry::mean_edge_length(clean, &topology);
    let v = clean.faces[0][0] as usize;
    let n = face_normals(clean)[0];
    let mut mesh = clean.clone();
    mesh.positions[v] = vec3::sub(mesh.positions[v], vec3::scale(n, 3.0 * l));
    mesh
}

#[test]
fn with_the_fold_rule_the_switch_moves_only_around_folded_faces() {
    let mesh = pushed_through(&normalnet_voxel::shapes::generate_seeded(5, 200).unwrap());
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut bundle = tiny_bundle();
    let mut stay = crate::switch::tests::constant(3);
    let params = DenoiseParams {
        iterations: 1,
        vertex_iterations: 1,
        ..DenoiseParams::default()
    };
    let run = |bundle: &Bundle| denoise(&mesh, bundle, &params, &NoProgress).unwrap();
    // "stay" everywhere: nothing moves, though faces are folded
    bundle.manifest.switch = Some(stay.clone());
    let moved = |out: &Mesh| -> Vec<usize> {
        (0..mesh.num_vertices())
            .filter(|&i| vec3::norm(vec3::sub(out.positions[i], mesh.positions[i])) > 1e-9)
            .collect()
    };
    let (out, times) = run(&bundle);
    assert!(moved(&out).is_empty());
    let folded = times.iterations[0].folded_share;
    assert!(folded > 0.0 && folded < 0.1, "{folded}");
    // with the rule the folded faces follow the network: vertices move, but
    // (one vertex update) only those of folded faces
    stay.network_on_folds = true;
    bundle.manifest.switch = Some(stay);
    let (out, times) = run(&bundle);
    assert_eq!(times.iterations[0].folded_share, folded);
    assert!(times.iterations[0].stay_share < 1.0);
    let check = normalnet_filters::FoldCheck::new(&mesh.positions, &mesh.faces, &topology);
    let folded_faces = check.folded(&mesh.positions);
    let of_folded = |i: usize| {
        (0..mesh.num_faces()).any(|f| folded_faces[f] && mesh.faces[f].contains(&(i as u32)))
    };
    let moved = moved(&out);
    assert!(!moved.is_empty());
    assert!(moved.iter().all(|&i| of_folded(i)), "{moved:?}");
}

#[test]
fn the_flat_rule_chooses_between_the_guided_and_the_paper_form() {
    let bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let run = |guided_from: usize, flat_deg: f64| {
        let params = DenoiseParams {
            iterations: 2,
            vertex_iterations: 2,
            guided_from,
            guided_flat_deg: flat_deg,
            ..DenoiseParams::default()
        };
        denoise(&mesh, &bundle, &params, &NoProgress)
            .unwrap()
            .0
            .positions
    };
    let paper = run(0, 0.0);
    let guided = run(1, 0.0);
    assert_ne!(paper, guided);
    // every ring normal within 180°: every face flat, the guided form
    assert_eq!(run(1, 180.0), guided);
    // within 1e-9°: no face flat (random networks), the paper's form
    assert_eq!(run(1, 1e-9), paper);
}

/// A strip of 8 × 4 squares (two triangles each) folded by 90° along
/// x = 0: the half x ≤ 0 lies in the plane y = 0, the half x ≥ 0 in
/// the plane x = 0.
fn folded_strip() -> Mesh {
    let mut positions = Vec::new();
    for i in 0..=8 {
        for j in 0..=4 {
            let x = i as f64 - 4.0;
            let z = j as f64;
            positions.push(if x <= 0.0 { [x, 0.0, z] } else { [0.0, x, z] });
        }
    }
    let v = |i: u32, j: u32| i * 5 + j;
    let mut faces = Vec::new();
    for i in 0..8 {
        for j in 0..4 {
            faces.push([v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
            faces.push([v(i, j), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    Mesh::new(positions, faces).unwrap()
}

#[test]
fn flat_patches_are_the_faces_away_from_the_fold_and_skip_the_network() {
    let mesh = folded_strip();
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let normals = face_normals(&mesh);
    let flat = flat_patches(&mesh, &topology, 10.0);
    // columns 0–1 and 6–7 lie two rings or more from the fold
    for (f, got) in flat.iter().enumerate() {
        let column = f / 8;
        let far = !(2..6).contains(&column);
        assert_eq!(got.is_some(), far, "face {f} (column {column})");
        if let Some(mean) = got {
            assert!(vec3::angle(*mean, normals[f]) < 1e-9, "face {f}");
        }
    }
    // the fold's two normals are 90° apart: the 2-ring mean lies less
    // than 90° from each (at least 1 of 40 faces on the other side: 88.6°
    // at most), so a limit of 89.5° takes in every face
    assert!(
        flat_patches(&mesh, &topology, 89.5)
            .iter()
            .all(|m| m.is_some())
    );

    // with a switch that keeps every face where it is, the mesh does not
    // move, and from the second iteration on the flat faces skip the network
    let mut bundle = tiny_bundle();
    bundle.manifest.switch = Some(crate::switch::tests::constant(3));
    let run = |flat_skip_deg: f64| {
        let params = DenoiseParams {
            iterations: 3,
            vertex_iterations: 2,
            freeze_deg: 0.0,
            auto_stop_deg: 0.0,
            flat_skip_deg,
            ..DenoiseParams::default()
        };
        denoise(&mesh, &bundle, &params, &NoProgress).unwrap().1
    };
    let evaluated =
        |t: StageTimes| -> Vec<usize> { t.iterations.iter().map(|s| s.faces_evaluated).collect() };
    let n = mesh.num_faces();
    let skipped = flat.iter().filter(|m| m.is_some()).count();
    assert_eq!(skipped, 32);
    assert_eq!(evaluated(run(0.0)), [n, n, n]);
    assert_eq!(evaluated(run(10.0)), [n, n - skipped, n - skipped]);
    // every face flat: the network runs once, and the turn from its
    // outputs to the 2-ring means counts in the mean change (which the
    // paper form's auto stop reads); then the means stay
    let t = run(89.5);
    let changes: Vec<f64> = t.iterations.iter().map(|s| s.mean_change_deg).collect();
    assert_eq!(evaluated(t), [n, 0, 0]);
    assert!(changes[1] > 1.0, "{changes:?}");
    assert!(changes[2] < 1e-6, "{changes:?}");
    let bad = DenoiseParams {
        flat_skip_deg: f64::NAN,
        ..DenoiseParams::default()
    };
    assert!(matches!(
        bad.validate(),
        Err(NetError::InvalidParameter {
            name: "flat_skip_deg",
            ..
        })
    ));
}

#[test]
fn frozen_faces_keep_their_output_and_auto_stop_ends_the_run() {
    let bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let n = mesh.num_faces();
    let run = |iterations: usize, freeze_deg: f64, auto_stop_deg: f64| {
        let params = DenoiseParams {
            iterations,
            vertex_iterations: 2,
            freeze_deg,
            auto_stop_deg,
            flat_skip_deg: 0.0,
            ..DenoiseParams::default()
        };
        denoise(&mesh, &bundle, &params, &NoProgress).unwrap()
    };
    // off: every face every iteration, the mean change is reported
    let (exact, t) = run(4, 0.0, 0.0);
    assert_eq!(t.iterations.len(), 4);
    assert!(t.iterations.iter().all(|s| s.faces_evaluated == n));
    assert_eq!(t.iterations[0].mean_change_deg, 0.0);
    assert!(t.iterations[1..].iter().all(|s| s.mean_change_deg > 0.0));
    assert_eq!(
        t.iterations.iter().map(|s| s.network).collect::<Vec<_>>(),
        [1, 2, 3, 4]
    );
    // a threshold no face meets changes nothing
    assert_eq!(run(4, 1e-12, 0.0).0.positions, exact.positions);
    // every face turns less than 180°: all freeze after iteration 2, and
    // iterations 3 and 4 move the vertices towards iteration 2's normals
    let (frozen, t) = run(4, 180.0, 0.0);
    assert_eq!(
        t.iterations
            .iter()
            .map(|s| s.faces_evaluated)
            .collect::<Vec<_>>(),
        [n, n, 0, 0]
    );
    assert_eq!(t.faces_processed, 2 * n);
    assert_eq!(t.iterations[2].mean_change_deg, 0.0);
    assert_ne!(frozen.positions, exact.positions);
    // and the frozen run is deterministic
    assert_eq!(run(4, 180.0, 0.0).0.positions, frozen.positions);
    // auto stop: any change is below 180°, so the run ends after 2
    let (stopped, t) = run(10, 0.0, 180.0);
    assert_eq!(t.iterations.len(), 2);
    assert_eq!(stopped.positions, run(2, 0.0, 0.0).0.positions);
    // bad thresholds are refused, naming the field
    for (f, a, name) in [(-1.0, 0.0, "freeze_deg"), (0.0, f64::NAN, "auto_stop_deg")] {
        let params = DenoiseParams {
            freeze_deg: f,
            auto_stop_deg: a,
            ..DenoiseParams::default()
        };
        assert!(matches!(
            params.validate(),
            Err(NetError::InvalidParameter { name: n, .. }) if n == name
        ));
    }
}

#[test]
fn traced_rows_can_leave_out_the_folded_faces() {
    use crate::switch_fit::ROW_LEN;
    use crate::switch_rows::{TracePath, TraceSettings, trace};
    let clean = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let topology = Topology::new(clean.num_vertices(), &clean.faces);
    let noisy = pushed_through(&clean);
    let folded = normalnet_filters::FoldCheck::new(&noisy.positions, &noisy.faces, &topology)
        .folded(&noisy.positions)
        .iter()
        .filter(|&&f| f)
        .count();
    assert!(folded > 0);
    let bundle = tiny_bundle();
    let settings = TraceSettings {
        iterations: 1,
        vertex_iterations: 1,
        ..TraceSettings::default()
    };
    let path = TracePath::Candidate(0);
    let all = trace(&bundle, &noisy, &clean, &path, &settings).unwrap();
    assert_eq!(all.rows.len(), noisy.num_faces() * ROW_LEN);
    assert_eq!(all.skipped_folded, 0);
    let skip = TraceSettings {
        skip_folded: true,
        ..settings
    };
    let kept = trace(&bundle, &noisy, &clean, &path, &skip).unwrap();
    assert_eq!(kept.skipped_folded, folded);
    assert_eq!(kept.rows.len(), (noisy.num_faces() - folded) * ROW_LEN);
    // the vertices follow the same path: the rows kept are the same rows
    assert_eq!(kept.e_a_deg, all.e_a_deg);
    assert!(
        kept.rows
            .chunks_exact(ROW_LEN)
            .all(|r| all.rows.chunks_exact(ROW_LEN).any(|a| same_bits(a, r)))
    );
}

/// Equal rows, bit for bit (a row traced without CNR holds a NaN angle).
fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// `yaw_views`: each face's output is the normalised sum of the outputs at
/// yaws 0, 360°/V, …; one view leaves the outputs as they are.
#[test]
fn yaw_views_average_the_outputs_of_turned_frames() {
    let net = engine(9);
    let mesh = shape();
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let pass = NetworkPass {
        cnn: &net,
        residual: false,
        voxel: VoxelParams::tiny(),
        slot: 2,
        batch: 64,
    };
    let faces: Vec<u32> = (0..mesh.num_faces() as u32).step_by(3).collect();
    let at_yaw = |yaw: f64| run(&mesh, &net, Some(&vec![yaw; mesh.num_faces()]));
    let zero = at_yaw(0.0);
    let half = at_yaw(std::f64::consts::PI);
    let mut normals = zero.clone();
    evaluate::mean_over_yaws(&pass, &mesh, &topology, &faces, 2, &mut normals).unwrap();
    for f in 0..mesh.num_faces() {
        match f % 3 {
            0 => {
                let mean = vec3::normalize_or_zero(vec3::add(zero[f], half[f]));
                assert!(vec3::angle(normals[f], mean) < 1e-6, "face {f}");
            }
            _ => assert_eq!(normals[f], zero[f], "face {f}: not listed, untouched"),
        }
    }
    // an untrained network is not yaw-invariant: the mean moved the outputs
    let moved = angles_deg(&normals, &zero);
    assert!(
        moved.iter().any(|&e| e > 1.0),
        "largest {:?}",
        moved.iter().cloned().fold(0.0, f64::max)
    );
    // one view: nothing to average
    let mut one = zero.clone();
    evaluate::mean_over_yaws(&pass, &mesh, &topology, &faces, 1, &mut one).unwrap();
    assert_eq!(one, zero);
}

#[test]
fn yaw_views_out_of_range_are_refused() {
    for views in [0, 9] {
        let params = DenoiseParams {
            yaw_views: views,
            ..DenoiseParams::default()
        };
        let e = params.validate().unwrap_err().to_string();
        assert!(e.contains("yaw_views"), "{e}");
    }
    for from in [-0.1, f64::NAN] {
        let params = DenoiseParams {
            yaw_views_from_noise: from,
            ..DenoiseParams::default()
        };
        let e = params.validate().unwrap_err().to_string();
        assert!(e.contains("yaw_views_from_noise"), "{e}");
    }
}

/// `yaw_views_from_noise`: the views run only where the input's noise
/// level (the heavy table's router) reaches the threshold; below it the
/// run is the one-view run, bit for bit.
#[test]
fn yaw_views_from_noise_gate_the_views_on_the_input_noise_level() {
    let bundle = tiny_bundle();
    let mesh = normalnet_voxel::shapes::generate_seeded(5, 200).unwrap();
    let level = first_noise_level(&mesh);
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    assert!((crate::switch::noise_level(&topology, &face_normals(&mesh)) - level).abs() < 1e-12);
    let run = |views: usize, from: f64| {
        let params = DenoiseParams {
            iterations: 2,
            vertex_iterations: 3,
            auto_stop_deg: 0.0,
            yaw_views: views,
            yaw_views_from_noise: from,
            ..DenoiseParams::default()
        };
        denoise(&mesh, &bundle, &params, &NoProgress)
            .unwrap()
            .0
            .positions
    };
    let one = run(1, 0.0);
    let two = run(2, 0.0);
    assert_ne!(one, two, "two views move the result");
    assert_eq!(run(2, level * 1.01), one, "below the threshold: one view");
    assert_eq!(run(2, level), two, "from it: the views");
}

/// The defaults: two views in iterations 1–3 of runs whose input's noise
/// level reaches 1.0 rad; below it the one-view run, bit for bit. The run
/// reports the views of each iteration.
#[test]
fn by_default_heavy_noise_takes_two_views_in_the_first_three_iterations() {
    let bundle = tiny_bundle();
    let (_, mild) = normalnet_voxel::shapes::noisy_pair(5, 200, 0.1, 3).unwrap();
    let (_, heavy) = normalnet_voxel::shapes::noisy_pair(5, 200, 1.0, 3).unwrap();
    assert!(first_noise_level(&mild) < YAW_VIEWS_FROM_NOISE);
    assert!(first_noise_level(&heavy) >= YAW_VIEWS_FROM_NOISE);
    let run = |mesh: &Mesh, views: usize, until: usize, from: f64| {
        let params = DenoiseParams {
            iterations: 4,
            vertex_iterations: 3,
            auto_stop_deg: 0.0,
            yaw_views: views,
            yaw_views_until: until,
            yaw_views_from_noise: from,
            ..DenoiseParams::default()
        };
        let (out, times) = denoise(mesh, &bundle, &params, &NoProgress).unwrap();
        let taken: Vec<usize> = times.iterations.iter().map(|i| i.yaw_views).collect();
        (out.positions, taken)
    };
    let defaults = |mesh: &Mesh| {
        let d = DenoiseParams::default();
        run(mesh, d.yaw_views, d.yaw_views_until, d.yaw_views_from_noise)
    };
    let (mild_default, taken) = defaults(&mild);
    assert_eq!(taken, [1, 1, 1, 1]);
    assert_eq!(
        mild_default,
        run(&mild, 1, 0, 0.0).0,
        "mild noise: one view"
    );
    let (heavy_default, taken) = defaults(&heavy);
    assert_eq!(taken, [2, 2, 2, 1]);
    assert_eq!(
        heavy_default,
        run(&heavy, 2, 3, 0.0).0,
        "heavy noise: 2 views to it. 3"
    );
    assert_ne!(heavy_default, run(&heavy, 1, 0, 0.0).0, "the views move it");
    let (every, taken) = run(&heavy, 2, 0, 0.0);
    assert_eq!(taken, [2, 2, 2, 2]);
    assert_ne!(heavy_default, every, "iteration 4 takes one view");
}

/// The mesh's noise level as the switch's features see it in a run's first
/// iteration ([`crate::switch::NOISE_LEVEL_FEATURE`]); positive.
fn first_noise_level(mesh: &Mesh) -> f64 {
    use crate::switch::{NOISE_LEVEL_FEATURE, SwitchState, features};
    let topology = Topology::new(mesh.num_vertices(), &mesh.faces);
    let mut state = SwitchState::new(mesh, &topology, 0.3, false);
    let c = state.candidates(mesh, &topology, face_normals(mesh));
    let level = features(&topology, &c, 1)[0][NOISE_LEVEL_FEATURE];
    assert!(level > 0.0);
    level
}
