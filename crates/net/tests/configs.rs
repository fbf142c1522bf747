//! Every training config the repository ships (`configs/train-*.toml`)
//! reads and validates (ranges, no test model among its sources), and every
//! mesh it names exists under `../shared/data` (checked where the data is
//! present): a config that cannot run is found here, not hours into a
//! training run.

use normalnet_net::training::{TrainConfig, default_data_dir};
use std::path::PathBuf;

fn training_configs() -> Vec<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../configs"));
    let mut configs: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with("train-") && name.ends_with(".toml")
        })
        .collect();
    configs.sort();
    configs
}

#[test]
fn every_training_config_reads_and_names_meshes_that_exist() {
    let configs = training_configs();
    assert!(
        configs.iter().any(|p| p.ends_with("train-lite.toml")),
        "the shipped model's config is among {configs:?}"
    );
    let data = default_data_dir();
    let have_data = data.is_dir();
    if !have_data {
        eprintln!(
            "{} absent: the configs are read, their meshes not looked up",
            data.display()
        );
    }
    for path in &configs {
        let config = TrainConfig::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(!config.sources.is_empty(), "{}", path.display());
        if !have_data || !config.data_dir.is_empty() {
            continue;
        }
        for source in config.sources.iter().chain(&config.validation) {
            if source.mesh.starts_with("shape:") {
                continue;
            }
            assert!(
                data.join(&source.mesh).is_file(),
                "{}: source {} not found under {}",
                path.display(),
                source.mesh,
                data.display()
            );
        }
    }
}
