//! Format-1 bundles (burn records, `net1.bpk` …) to format 2 (safetensors;
//! feature `burn`). The weights are copied exactly; the manifest keeps every
//! field, with the new format number and file names; the bundle's other
//! files (logs, plots, evaluation) are copied alongside.

use std::path::Path;

use burn::module::Module;
use burn::tensor::Device;

use crate::NetError;
use crate::bundle::{FORMAT_VERSION, MANIFEST, Manifest, network_file};

/// Converts the format-1 bundle `from` into a format-2 bundle `to` (created;
/// must not be `from`). Returns the new manifest.
pub fn convert_format1(from: &Path, to: &Path) -> Result<Manifest, NetError> {
    let manifest_path = from.join(MANIFEST);
    let text =
        std::fs::read_to_string(&manifest_path).map_err(|e| NetError::io(&manifest_path, e))?;
    let mut manifest: Manifest = toml::from_str(&text).map_err(|e| NetError::BadManifest {
        path: manifest_path.clone(),
        message: e.to_string(),
    })?;
    if manifest.format != 1 {
        return Err(NetError::BadManifest {
            path: manifest_path,
            message: format!(
                "format {} is not format 1: nothing to convert",
                manifest.format
            ),
        });
    }
    if from.canonicalize().ok() == to.canonicalize().ok() {
        return Err(NetError::InvalidParameter {
            name: "output",
            message: "convert into a new folder, not onto the bundle itself".into(),
        });
    }
    let device = Device::flex();
    let config = manifest.model.clone();
    std::fs::create_dir_all(to).map_err(|e| NetError::io(to, e))?;
    for (i, info) in manifest.networks.iter_mut().enumerate() {
        let file = from.join(&info.file);
        let net =
            config
                .init(&device, 0)
                .try_load_file(&file)
                .map_err(|e| NetError::WeightMismatch {
                    path: file.clone(),
                    preset: manifest.preset.clone(),
                    message: e.to_string(),
                })?;
        let w = crate::export::net_weights(&net, &config).map_err(|e| NetError::Record {
            path: file.clone(),
            message: e.to_string(),
        })?;
        info.file = network_file(i);
        crate::weights_file::save(&w, &to.join(&info.file))?;
    }
    manifest.format = FORMAT_VERSION;
    // the rest of the bundle: everything but the weights and the manifest
    let entries = std::fs::read_dir(from).map_err(|e| NetError::io(from, e))?;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if entry.path().is_file() && !name.ends_with(".bpk") && name != MANIFEST {
            std::fs::copy(entry.path(), to.join(&*name))
                .map_err(|e| NetError::io(entry.path(), e))?;
        }
    }
    manifest.validate(&to.join(MANIFEST))?;
    manifest.write(&to.join(MANIFEST))?;
    Ok(manifest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arch::ModelConfig;
    use crate::bundle::{Bundle, new_manifest};

    /// A format-1 tiny bundle written the way format 1 was: burn records.
    fn format1_bundle(dir: &Path) -> Vec<normalnet_cnn::NetWeights> {
        let config = ModelConfig::tiny();
        let device = Device::flex();
        let mut manifest = new_manifest("tiny").unwrap();
        manifest.format = 1;
        let mut weights = Vec::new();
        for (i, info) in manifest.networks.iter_mut().enumerate() {
            let net = config.init(&device, 20 + i as u64);
            weights.push(crate::export::net_weights(&net, &config).unwrap());
            info.file = format!("net{}.bpk", i + 1);
            net.save_file(dir.join(&info.file)).unwrap();
        }
        let text = toml::to_string(&manifest).unwrap();
        std::fs::write(dir.join(MANIFEST), text).unwrap();
        std::fs::write(dir.join("train_log.csv"), "network,step\n").unwrap();
        weights
    }

    #[test]
    fn a_format_1_bundle_converts_exactly() {
        let old = tempfile::tempdir().unwrap();
        let new = tempfile::tempdir().unwrap();
        let weights = format1_bundle(old.path());
        // format 1 is refused with the way out
        let err = Bundle::load(old.path()).unwrap_err().to_string();
        assert!(err.contains("models convert"), "{err}");
        let to = new.path().join("b");
        let manifest = convert_format1(old.path(), &to).unwrap();
        assert_eq!(manifest.format, FORMAT_VERSION);
        let bundle = Bundle::load(&to).unwrap();
        assert_eq!(bundle.networks, weights);
        assert!(to.join("train_log.csv").is_file());
        assert!(!to.join("net1.bpk").exists());
        // converting twice, or onto itself, is refused
        assert!(convert_format1(&to, &new.path().join("c")).is_err());
        assert!(convert_format1(old.path(), old.path()).is_err());
    }
}
