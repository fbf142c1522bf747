//! Regression: sums over edges must give the same bits for any thread
//! count (a rayon `sum` once made `l_e`, hence noise σ, vary in the last bit
//! from run to run, so one seed did not always give the same bytes).

use normalnet_mesh::geometry::{FaceGeometry, mean_centre_distance, mean_edge_length};
use normalnet_mesh::noise::{NoiseParams, add_noise};
use normalnet_mesh::{Mesh, Topology};

fn wavy_grid(n: usize) -> Mesh {
    Mesh::grid(n, |i, j| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        [
            x + 0.01 * (7.0 * y).sin(),
            y,
            0.1 * (5.0 * x).sin() * (3.0 * y).cos(),
        ]
    })
}

#[test]
fn edge_sums_and_noise_do_not_depend_on_threads() {
    let m = wavy_grid(150);
    let t = Topology::new(m.num_vertices(), &m.faces);
    let c = FaceGeometry::new(&m).centres;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            (
                mean_edge_length(&m, &t).to_bits(),
                mean_centre_distance(&t, &c).to_bits(),
                add_noise(
                    &m,
                    &NoiseParams {
                        seed: 9,
                        ..NoiseParams::default()
                    },
                )
                .unwrap(),
            )
        })
    };
    let one = run(1);
    for threads in [2, 3, 8] {
        for _ in 0..3 {
            assert!(run(threads) == one, "{threads} threads differ from 1");
        }
    }
}
