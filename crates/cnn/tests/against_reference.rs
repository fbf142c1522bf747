//! The fast forward pass equals a literal f64 evaluation of the network.

mod common;

use normalnet_cnn::{Cnn, CnnError};

fn check(grid: usize, channels: [usize; 3], batch: usize, seed: u64) {
    let w = common::random_net(seed, grid, channels);
    let cnn = Cnn::new(&w).unwrap();
    let grids: Vec<f32> = (0..batch)
        .flat_map(|i| common::sheet_grid(seed * 100 + i as u64, grid))
        .collect();
    let mut out = vec![0.0f32; batch * 18];
    cnn.forward(&grids, &mut out).unwrap();
    for b in 0..batch {
        let expected =
            common::reference_forward(&w, &grids[b * cnn.grid_len()..(b + 1) * cnn.grid_len()]);
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
