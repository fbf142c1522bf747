//! The fast forward pass equals a literal f64 evaluation of the network.

mod common;

use normalnet_cnn::{Arithmetic, Cnn, CnnError, Int8Range, Isa, NetWeights};

/// The fast forward pass on every kernel path this CPU runs (scalar, AVX2,
/// AVX-512) equals the f64 reference.
fn check(grid: usize, channels: [usize; 3], batch: usize, seed: u64) {
    let w = common::random_net(seed, grid, channels);
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(seed * 100 + i as u64, grid))
        .collect();
    for isa in Isa::all_here() {
        let mut cnn = Cnn::new(&w).unwrap();
        cnn.set_isa(isa).unwrap();
        assert_eq!(cnn.isa(), isa);
        check_on(&w, &cnn, &grids, batch);
    }
}

fn check_on(w: &NetWeights, cnn: &Cnn, grids: &[f32], batch: usize) {
    let mut out = vec![0.0f32; batch * 18];
    cnn.forward(grids, &mut out).unwrap();
    for b in 0..batch {
        let expected =
            common::reference_forward(w, &grids[b * cnn.grid_len()..(b + 1) * cnn.grid_len()]);
        for (k, (&got, &want)) in out[b * 18..(b + 1) * 18].iter().zip(&expected).enumerate() {
            assert!(
                (got as f64 - want).abs() < 2e-4,
                "sample {b} output {k}: fast {got} vs reference {want} ({})",
                cnn.instruction_set()
            );
        }
    }
}

#[test]
fn tiny_preset_matches_reference() {
    check(15, [8, 16, 32], 3, 1);
}

#[test]
fn lite_preset_matches_reference() {
    check(21, [16, 32, 64], 2, 2);
}

/// Buffers over `KEPT_SCRATCH` (35 MB per thread here, like the paper
/// preset's) are taken per piece of rayon work instead of kept.
#[test]
fn a_network_too_large_to_keep_its_buffers_matches_reference() {
    check(41, [32, 32, 32], 2, 3);
}

#[test]
fn int8_blocks_stay_within_quantization_error_of_the_reference() {
    let (grid, batch) = (21, 6);
    let w = common::random_net(5, grid, [16, 32, 64]);
    let mut cnn = Cnn::new(&w).unwrap();
    assert_eq!(cnn.arithmetic(), Arithmetic::F32, "f32 unless asked");
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(500 + i as u64, grid))
        .collect();
    let mut exact = vec![0.0f32; batch * 18];
    cnn.forward(&grids, &mut exact).unwrap();
    // the full ranges (on a path without VNNI the default is narrow)
    let int8 = Arithmetic {
        int8_range: Some(Int8Range::Full),
        ..Arithmetic::INT8_BLOCKS
    };
    if !cnn.set_arithmetic(int8).int8 {
        eprintln!("no int8 kernels on this CPU: int8 falls back to f32 (checked), rest skipped");
        assert!(!cnn.arithmetic().int8 && cnn.int8_range_in_use().is_none());
        return;
    }
    let mut out = vec![0.0f32; batch * 18];
    cnn.forward(&grids, &mut out).unwrap();
    let worst = largest_difference_to_reference(&w, &cnn, &grids, &out);
    // outputs are tanh values in [-1, 1]; 8-bit blocks move them by a few
    // thousandths, far more than f32 rounding (2e-4 above) but small
    assert!(worst < INT8_TOLERANCE, "int8 off by {worst}");
    assert!(
        worst > 2e-4,
        "int8 gave f32 results ({worst}): not running?"
    );
    // back to f32: the exact outputs again, bit for bit
    assert_eq!(cnn.set_arithmetic(Arithmetic::F32), Arithmetic::F32);
    cnn.forward(&grids, &mut out).unwrap();
    assert_eq!(out, exact);
}

const INT8_TOLERANCE: f64 = 0.03;

/// The largest difference between `out` (18 outputs per grid) and the f64
/// reference network on `grids`.
fn largest_difference_to_reference(w: &NetWeights, cnn: &Cnn, grids: &[f32], out: &[f32]) -> f64 {
    let mut worst = 0.0f64;
    for (grid, out) in grids.chunks_exact(cnn.grid_len()).zip(out.chunks_exact(18)) {
        let expected = common::reference_forward(w, grid);
        for (&got, &want) in out.iter().zip(&expected) {
            worst = worst.max((got as f64 - want).abs());
        }
    }
    worst
}

#[test]
fn empty_grid_is_finite() {
    let w = common::random_net(3, 15, [8, 16, 32]);
    let cnn = Cnn::new(&w).unwrap();
    let mut out = vec![0.0f32; 18];
    cnn.forward(&vec![0.0; cnn.grid_len()], &mut out).unwrap();
    assert!(out.iter().all(|v| v.is_finite() && v.abs() <= 1.0));
}

#[test]
fn bad_shapes_are_named() {
    let mut w = common::random_net(4, 15, [8, 16, 32]);
    w.blocks[1].conv_b.weight.pop();
    let err = Cnn::new(&w).unwrap_err();
    assert!(
        matches!(&err, CnnError::WeightShape { layer, .. } if layer == "block 2 conv_b"),
        "{err}"
    );
    let mut w = common::random_net(4, 15, [8, 16, 32]);
    w.hidden[0].0.in_features = 7;
    w.hidden[0].0.weight.truncate(7 * 512);
    assert!(Cnn::new(&w).unwrap_err().to_string().contains("hidden 1"));
    let w = common::random_net(4, 15, [8, 16, 32]);
    let cnn = Cnn::new(&w).unwrap();
    let mut out = vec![0.0f32; 17];
    assert!(matches!(
        cnn.forward(&vec![0.0; cnn.grid_len()], &mut out),
        Err(CnnError::BufferSize { .. })
    ));
}

#[test]
fn isolated_voxels_at_the_borders_match_reference() {
    // Only the cubes near these voxels are computed; the rest is copied from
    // the empty-grid activations: both must agree with the literal network.
    let n = 15;
    let w = common::random_net(5, n, [8, 16, 32]);
    let cnn = Cnn::new(&w).unwrap();
    let cubes = n * n * n;
    let mut grid = vec![0.0f32; 3 * cubes];
    for (d, h, wi) in [(0, 0, 0), (n - 1, 7, 3), (6, n - 1, n - 1)] {
        let i = (d * n + h) * n + wi;
        grid[i] = 0.3;
        grid[cubes + i] = 0.9;
        grid[2 * cubes + i] = -0.2;
    }
    let mut out = vec![0.0f32; 18];
    cnn.forward(&grid, &mut out).unwrap();
    let worst = largest_difference_to_reference(&w, &cnn, &grid, &out);
    assert!(worst < 2e-4, "{worst}");
}

#[test]
fn the_profiled_forward_gives_the_same_outputs_and_times_every_layer() {
    let w = common::random_net(4, 21, [16, 32, 64]);
    let cnn = Cnn::new(&w).unwrap();
    let grids: Vec<f32> = (0..3).flat_map(|i| common::sheet_grid(i, 21)).collect();
    let (mut a, mut b) = (vec![0.0f32; 3 * 18], vec![0.0f32; 3 * 18]);
    cnn.forward(&grids, &mut a).unwrap();
    let times = cnn.forward_profiled(&grids, &mut b).unwrap();
    assert_eq!(a, b);
    let named = times.named();
    // gather, stem, three per block, head
    assert_eq!(named.len() % 3, 0);
    assert!(named.len() >= 6);
    assert!(named.iter().all(|(_, s)| *s >= 0.0));
    assert!(named.iter().map(|(_, s)| s).sum::<f64>() > 0.0);
    assert!(matches!(
        cnn.forward_profiled(&grids[1..], &mut b),
        Err(CnnError::BufferSize { .. })
    ));
}

/// On every path this CPU runs: the row stem (AVX-512 and AVX2) equals
/// the scatter up to f32 rounding; the scalar path has only the scatter.
#[test]
fn the_row_stem_equals_the_scatter() {
    let w = common::random_net(3, 21, [16, 32, 64]);
    let mut cnn = Cnn::new(&w).unwrap();
    let batch = 8;
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(300 + i as u64, 21))
        .collect();
    for isa in Isa::all_here() {
        cnn.set_isa(isa).unwrap();
        let mut rows = vec![0.0f32; batch * 18];
        let mut scatter = rows.clone();
        let available = cnn.set_row_stem(true);
        assert_eq!(available, isa >= Isa::Avx2, "{isa}: row stem");
        cnn.forward(&grids, &mut rows).unwrap();
        assert!(!cnn.set_row_stem(false));
        cnn.forward(&grids, &mut scatter).unwrap();
        if !available {
            assert_eq!(rows, scatter);
            continue;
        }
        let worst = rows
            .iter()
            .zip(&scatter)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        println!("{isa}: row stem vs scatter: largest output difference {worst:e}");
        assert!(worst < 1e-5, "{isa}: row stem off by {worst}");
    }
}

/// The int8 stem, on every path with int8 kernels (VNNI, and AVX2's exact
/// `vpmaddwd` sums on the others): the same outputs on each, near the
/// reference, off with the row stem off.
#[test]
fn the_int8_stem_is_opt_in_and_near_the_reference() {
    let mut outputs: Vec<(Isa, Vec<f32>)> = Vec::new();
    for isa in Isa::all_here().filter(|isa| isa.has_avx2()) {
        let Some((mut cnn, out)) =
            int8_option_near_the_reference(5, "stem", isa, |a| &mut a.int8_stem)
        else {
            return;
        };
        // the row stem off: the scatter stem in f32
        assert!(!cnn.set_row_stem(false) && !cnn.arithmetic().int8_stem);
        outputs.push((isa, out));
    }
    // the int8 stem and blocks give the same i32 sums on every path, but
    // the f32 shortcuts (each path's summation order) can move a value
    // across a byte's rounding boundary in the next block: the paths agree
    // to the quantization tolerance
    for pair in outputs.windows(2) {
        let worst = pair[0]
            .1
            .iter()
            .zip(&pair[1].1)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        println!("int8 stem, {} vs {}: {worst:e}", pair[0].0, pair[1].0);
        assert!(
            f64::from(worst) < INT8_TOLERANCE,
            "{} vs {}: {worst}",
            pair[0].0,
            pair[1].0
        );
    }
}

/// Every part in int8 with narrow ranges: the same outputs, bit for bit, on
/// every path with int8 kernels (plain AVX2 with `vpmaddubsw`, AVX-VNNI,
/// AVX-512 VNNI), near the reference (twice the full ranges' tolerance: half
/// the steps), not those of the full ranges; back to full ranges, the full
/// ranges' outputs again.
#[test]
fn narrow_int8_gives_the_same_outputs_on_every_path_near_the_reference() {
    let (grid, batch) = (21, 6);
    let w = common::random_net(7, grid, [16, 32, 64]);
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(700 + i as u64, grid))
        .collect();
    let mut outputs: Vec<(Isa, Vec<f32>)> = Vec::new();
    for isa in Isa::all_here().filter(|isa| isa.has_avx2()) {
        let mut cnn = Cnn::new(&w).unwrap();
        cnn.set_isa(isa).unwrap();
        assert_eq!(cnn.int8_range(), Int8Range::Full);
        let full_ranges = Arithmetic {
            int8_range: Some(Int8Range::Full),
            ..Arithmetic::INT8
        };
        if cnn.set_arithmetic(full_ranges) != full_ranges {
            eprintln!("no int8 kernels on {isa}: skipped");
            return;
        }
        assert_eq!(cnn.int8_range_in_use(), Some(Int8Range::Full));
        let mut full = vec![0.0f32; batch * 18];
        cnn.forward(&grids, &mut full).unwrap();
        // trained for narrow ranges: narrow on every path unless asked
        // otherwise
        cnn.set_arithmetic(Arithmetic::INT8);
        assert_eq!(cnn.set_int8_range(Int8Range::Narrow), Arithmetic::INT8);
        assert_eq!(cnn.int8_range_in_use(), Some(Int8Range::Narrow));
        let mut out = vec![0.0f32; batch * 18];
        cnn.forward(&grids, &mut out).unwrap();
        assert_ne!(out, full, "{isa}: the narrow ranges did not run");
        let worst = largest_difference_to_reference(&w, &cnn, &grids, &out);
        println!("{isa}: narrow int8 vs f64: largest output difference {worst:e}");
        assert!(
            worst < 2.0 * INT8_TOLERANCE,
            "{isa}: narrow int8 off by {worst}"
        );
        assert_eq!(cnn.set_int8_range(Int8Range::Full), Arithmetic::INT8);
        assert_eq!(cnn.set_arithmetic(full_ranges), full_ranges);
        let mut again = vec![0.0f32; batch * 18];
        cnn.forward(&grids, &mut again).unwrap();
        assert_eq!(again, full, "{isa}: full ranges again");
        outputs.push((isa, out));
    }
    for pair in outputs.windows(2) {
        assert!(
            pair[0]
                .1
                .iter()
                .zip(&pair[1].1)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "narrow int8: {} and {} differ",
            pair[0].0,
            pair[1].0
        );
    }
}

/// The ranges int8 runs with by default: the network's own (full) where
/// the path has VNNI, narrow where plain AVX2 sums the bytes; asked ranges
/// on every path; none with f32 blocks.
#[test]
fn the_default_int8_ranges_follow_the_path() {
    let w = common::random_net(8, 21, [16, 32, 64]);
    for isa in Isa::all_here().filter(|isa| isa.has_avx2()) {
        let mut cnn = Cnn::new(&w).unwrap();
        cnn.set_isa(isa).unwrap();
        assert_eq!(cnn.int8_range_in_use(), None, "f32 at first");
        if !cnn.set_arithmetic(Arithmetic::INT8).int8 {
            eprintln!("no int8 kernels on {isa}: skipped");
            continue;
        }
        let vnni = isa.has_vnni() || isa.uses_avx_vnni();
        let auto = if vnni {
            Int8Range::Full
        } else {
            Int8Range::Narrow
        };
        assert_eq!(cnn.int8_range_in_use(), Some(auto), "{isa}");
        for range in [Int8Range::Full, Int8Range::Narrow] {
            let asked = Arithmetic {
                int8_range: Some(range),
                ..Arithmetic::INT8
            };
            assert_eq!(cnn.set_arithmetic(asked), asked);
            assert_eq!(cnn.int8_range_in_use(), Some(range), "{isa}");
        }
        cnn.set_arithmetic(Arithmetic::F32);
        assert_eq!(cnn.int8_range_in_use(), None);
    }
}

#[test]
fn the_int8_shortcuts_run_only_with_int8_and_stay_near_the_reference() {
    for isa in Isa::all_here().filter(|isa| isa.has_avx2()) {
        let Some((mut cnn, _)) =
            int8_option_near_the_reference(6, "shortcuts", isa, |a| &mut a.int8_shortcut)
        else {
            return;
        };
        let f32_blocks = Arithmetic {
            int8: false,
            ..Arithmetic::INT8
        };
        assert!(
            !cnn.set_arithmetic(f32_blocks).int8_shortcut,
            "f32 blocks again"
        );
    }
}

/// An int8 option (the field `option` of [`Arithmetic`]) does nothing with
/// f32 blocks; with int8 blocks on path `isa` it changes the outputs and
/// keeps them within [`INT8_TOLERANCE`] of the f64 reference.
/// Returns the network with int8 and the option on and its outputs, or
/// `None` on a CPU without int8 kernels.
fn int8_option_near_the_reference(
    seed: u64,
    what: &str,
    isa: Isa,
    option: fn(&mut Arithmetic) -> &mut bool,
) -> Option<(Cnn, Vec<f32>)> {
    // the full ranges on every path (the narrow ones: their own test)
    let with = |blocks: Arithmetic, on: bool| {
        let mut a = Arithmetic {
            int8_range: Some(Int8Range::Full),
            ..blocks
        };
        *option(&mut a) = on;
        a
    };
    let runs = |mut a: Arithmetic| *option(&mut a);
    let (grid, batch) = (21, 6);
    let w = common::random_net(seed, grid, [16, 32, 64]);
    let mut cnn = Cnn::new(&w).unwrap();
    cnn.set_isa(isa).unwrap();
    let asked = with(Arithmetic::F32, true);
    assert!(
        !runs(cnn.set_arithmetic(asked)),
        "int8 {what} not with f32 blocks"
    );
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(100 * seed + i as u64, grid))
        .collect();
    let int8 = with(Arithmetic::INT8_BLOCKS, true);
    if !runs(cnn.set_arithmetic(int8)) {
        eprintln!("no int8 kernels on {isa}: no int8 {what} (checked), rest skipped");
        return None;
    }
    let mut without = vec![0.0f32; batch * 18];
    assert!(!runs(
        cnn.set_arithmetic(with(Arithmetic::INT8_BLOCKS, false))
    ));
    cnn.forward(&grids, &mut without).unwrap();
    let mut out = vec![0.0f32; batch * 18];
    assert!(runs(cnn.set_arithmetic(int8)));
    cnn.forward(&grids, &mut out).unwrap();
    assert_ne!(out, without, "the int8 {what} did not run");
    let worst = largest_difference_to_reference(&w, &cnn, &grids, &out);
    println!("{isa}: int8 with the int8 {what} vs f64: largest output difference {worst:e}");
    assert!(worst < INT8_TOLERANCE, "{isa}: int8 {what} off by {worst}");
    Some((cnn, out))
}

#[test]
fn sparse_inputs_give_the_dense_outputs_and_bad_ones_are_named() {
    let (grid, batch) = (21, 10);
    let w = common::random_net(8, grid, [16, 32, 64]);
    let mut cnn = Cnn::new(&w).unwrap();
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(900 + i as u64, grid))
        .collect();
    let sparse = common::sparse_grids(&grids, cnn.grid_len());
    let samples: Vec<(&[u32], &[f32])> = sparse.iter().map(|(i, v)| (&i[..], &v[..])).collect();
    // every arithmetic this CPU has: the same bits either way
    for arithmetic in [Arithmetic::F32, Arithmetic::INT8_BLOCKS, Arithmetic::INT8] {
        cnn.set_arithmetic(arithmetic);
        let mut dense = vec![0.0f32; batch * 18];
        cnn.forward(&grids, &mut dense).unwrap();
        let mut out = vec![0.0f32; batch * 18];
        cnn.forward_sparse(&samples, &mut out).unwrap();
        assert_eq!(out, dense, "{arithmetic:?}");
    }
    let mut out = vec![0.0f32; 18];
    let named = |samples: &[(&[u32], &[f32])], out: &mut [f32]| {
        cnn.forward_sparse(samples, out).unwrap_err().to_string()
    };
    let cubes = (grid * grid * grid) as u32;
    assert!(named(&[(&[3, 3], &[0.5; 6])], &mut out).contains("not ascending at position 1"));
    assert!(named(&[(&[2, cubes], &[0.5; 6])], &mut out).contains(&format!("cube index {cubes}")));
    assert!(named(&[(&[2], &[0.5; 2])], &mut out).contains("2 values for 1 cubes"));
    assert!(named(&[(&[2], &[0.5; 3])], &mut [0.0; 17]).contains("output batch"));
    // no occupied cube at all is a valid sample
    cnn.forward_sparse(&[(&[], &[])], &mut out).unwrap();
    assert!(out.iter().all(|v| v.is_finite()));
}

#[test]
fn a_sample_gives_the_same_outputs_in_any_batch() {
    // more samples than one register block of the head (8) and not a
    // multiple of it, so blocked and plain head paths both run
    let (grid, batch) = (21, 19);
    let w = common::random_net(9, grid, [16, 32, 64]);
    let mut cnn = Cnn::new(&w).unwrap();
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(950 + i as u64, grid))
        .collect();
    for (isa, arithmetic) in
        Isa::all_here().flat_map(|isa| [(isa, Arithmetic::F32), (isa, Arithmetic::INT8_BLOCKS)])
    {
        cnn.set_isa(isa).unwrap();
        cnn.set_arithmetic(arithmetic);
        let mut all = vec![0.0f32; batch * 18];
        cnn.forward(&grids, &mut all).unwrap();
        for (b, grid) in grids.chunks_exact(cnn.grid_len()).enumerate() {
            let mut one = vec![0.0f32; 18];
            cnn.forward(grid, &mut one).unwrap();
            // == : the same values (an exact zero may differ in sign)
            assert_eq!(
                one,
                all[b * 18..(b + 1) * 18],
                "{isa} {arithmetic:?} sample {b}"
            );
        }
    }
}

/// Review: a stem that grows the grid past the sparse pass's 64-cube masks
/// (63 cubes, padding 3: 65 a side) panicked in the mask; such a network
/// runs every cube, and equals the reference.
#[test]
fn a_stem_growing_the_grid_past_the_masks_runs_every_cube() {
    let n = 63;
    let mut w = common::random_net(9, n, [8, 8, 8]);
    w.stem.padding = 3;
    let cnn = Cnn::new(&w).unwrap();
    let grid = common::sheet_grid(9, n);
    let mut out = vec![0.0f32; 18];
    cnn.forward(&grid, &mut out).unwrap();
    let worst = largest_difference_to_reference(&w, &cnn, &grid, &out);
    assert!(worst < 2e-4, "{worst}");
}

/// A path this CPU does not run is refused with both names; int8 falls
/// back to f32 on a path without int8 kernels.
#[test]
fn set_isa_refuses_what_the_cpu_lacks_and_drops_int8_where_the_path_has_none() {
    let w = common::random_net(9, 15, [8, 16, 32]);
    let mut cnn = Cnn::new(&w).unwrap();
    assert_eq!(cnn.isa(), normalnet_cnn::Isa::detected());
    for isa in Isa::ALL {
        match cnn.set_isa(isa) {
            Ok(()) => assert!(isa.runs_here()),
            Err(e) => {
                assert!(!isa.runs_here());
                let text = e.to_string();
                assert!(
                    text.contains(isa.name()) && text.contains("does not run"),
                    "{text}"
                );
            }
        }
    }
    cnn.set_isa(Isa::Scalar).unwrap();
    assert_eq!(cnn.set_arithmetic(Arithmetic::INT8), Arithmetic::F32);
    assert_eq!(cnn.instruction_set(), "scalar");
}
