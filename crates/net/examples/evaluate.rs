//! Evaluates a bundle on noisy/clean pairs next to GNF with the same
//! settings: E_a (degrees), E_v/l_e, and NormalNet's time per stage.
//!
//! `cargo run -p normalnet-net --example evaluate -- BUNDLE NOISY CLEAN N_f N_v MU_G`
//! Prints one JSON line. Use only for evaluation: the test models must
//! never guide training or tuning.

use normalnet_filters::{GnfParams, gnf};
use normalnet_mesh::{NoProgress, compare, read_mesh};
use normalnet_net::{Bundle, DenoiseParams, denoise};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 7 {
        return Err("usage: evaluate BUNDLE NOISY CLEAN N_f N_v MU_G [skip-gnf]".into());
    }
    let bundle = Bundle::load(&a[1])?;
    let noisy = read_mesh(&a[2])?;
    let clean = read_mesh(&a[3])?;
    let (n_f, n_v, mu_g): (usize, usize, f64) = (a[4].parse()?, a[5].parse()?, a[6].parse()?);
    let params = DenoiseParams {
        iterations: n_f,
        vertex_iterations: n_v,
        mu_g,
        ..DenoiseParams::default()
    };
    let noisy_m = compare(&clean, &noisy)?;
    let (out, times) = denoise(&noisy, &bundle, &params, &NoProgress)?;
    let nn = compare(&clean, &out)?;
    let gnf_result = if a.get(7).map(String::as_str) == Some("skip-gnf") {
        None
    } else {
        let t = Instant::now();
        let g = gnf(
            &noisy,
            &GnfParams {
                mu_g,
                normal_iterations: n_f,
                vertex_iterations: n_v,
                ..GnfParams::default()
            },
            &NoProgress,
        )?;
        Some((compare(&clean, &g)?, t.elapsed().as_secs_f64()))
    };
    let faces = noisy.num_faces() as f64 * n_f as f64;
    println!(
        "{{\"noisy\": {:?}, \"faces\": {}, \"n_f\": {n_f}, \"n_v\": {n_v}, \"mu_g\": {mu_g}, \
         \"e_a_noisy\": {:.3}, \"e_a_normalnet\": {:.3}, \"ev_le_normalnet\": {:.4}, \
         \"e_a_gnf\": {}, \"ev_le_gnf\": {}, \"gnf_s\": {}, \
         \"normalnet_s\": {:.1}, \"voxelize_s\": {:.1}, \"cnn_s\": {:.1}, \"vertex_update_s\": {:.2}, \
         \"faces_per_s_voxelize\": {:.0}, \"faces_per_s_cnn\": {:.0}, \"faces_per_s_total\": {:.0}}}",
        a[2],
        noisy.num_faces(),
        noisy_m.e_a_deg,
        nn.e_a_deg,
        nn.e_v_over_le,
        gnf_result
            .as_ref()
            .map_or("null".into(), |g| format!("{:.3}", g.0.e_a_deg)),
        gnf_result
            .as_ref()
            .map_or("null".into(), |g| format!("{:.4}", g.0.e_v_over_le)),
        gnf_result
            .as_ref()
            .map_or("null".into(), |g| format!("{:.2}", g.1)),
        times.total_s,
        times.voxelize_s,
        times.cnn_s,
        times.vertex_update_s,
        faces / times.voxelize_s.max(1e-9),
        faces / times.cnn_s.max(1e-9),
        faces / times.total_s.max(1e-9),
    );
    Ok(())
}
