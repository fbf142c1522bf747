//! The burn-free CPU engine reproduces the burn network it was exported from.

use burn::tensor::{Tensor, TensorData};
use normalnet_net::ModelConfig;
use normalnet_net::export::{compile, net_weights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn sparse_grids(len: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..len)
        .map(|_| {
            if rng.random::<f32>() < 0.08 {
                rng.random::<f32>() * 2.0 - 1.0
            } else {
                0.0
            }
        })
        .collect()
}

fn agree(config: ModelConfig, seed: u64) {
    let device = burn::tensor::Device::flex();
    let net = config.init(&device, seed);
    let cnn = compile(&net, &config).unwrap();
    let batch = 3;
    let grids = sparse_grids(batch * cnn.grid_len(), seed);
    let s = config.grid;
    let t = Tensor::<5>::from_data(TensorData::new(grids.clone(), [batch, 3, s, s, s]), &device);
    let expected = net.forward(t).into_data().try_to_vec::<f32>().unwrap();
    let mut got = vec![0.0f32; batch * 18];
    cnn.forward(&grids, &mut got).unwrap();
    for (i, (a, b)) in expected.iter().zip(&got).enumerate() {
        assert!((a - b).abs() < 1e-5, "output {i}: burn {a} vs cnn {b}");
    }
}

#[test]
fn tiny_network_matches_burn() {
    agree(ModelConfig::tiny(), 1);
}

#[test]
fn lite_network_matches_burn() {
    agree(ModelConfig::lite(), 2);
}

#[test]
fn export_names_a_misshapen_config() {
    let device = burn::tensor::Device::flex();
    let net = ModelConfig::tiny().init(&device, 3);
    let err = net_weights(&net, &ModelConfig::lite()).unwrap_err();
    assert!(err.to_string().contains("conv_in.weight"), "{err}");
}
