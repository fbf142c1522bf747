//! Model bundles (SPEC §8): a folder with the six networks of one preset
//! (`net1.safetensors` … `net6.safetensors`, see [`crate::weights_file`]) and
//! a `manifest.toml` saying what they are (architecture, voxel grid) and how
//! they were trained. Loading needs no deep-learning framework: the networks
//! are compiled for the CPU engine of `normalnet-cnn` once, when the bundle
//! loads.
//!
//! Format history: 1 (until 2026-11) stored burn records (`net1.bpk`, ...);
//! `normalnet models convert` (a build with `--features burn`) turns such a
//! bundle into format 2.
//!
//! Network k serves the filtering iterations of [`INTERVALS`]`[k]`:
//! [1], [2], [3], [4–5], [6–10], [11–N_f] (paper §4).

use std::path::{Path, PathBuf};

use normalnet_cnn::{Arithmetic, Cnn, Int8Range, NetWeights};
use normalnet_voxel::VoxelParams;
use serde::{Deserialize, Serialize};

use crate::NetError;
use crate::arch::{MU_GS, ModelConfig};
use crate::switch::SwitchWeights;

/// First and last filtering iteration (1-based) of each network; `usize::MAX`
/// stands for N_f (open end).
pub const INTERVALS: [(usize, usize); 6] =
    [(1, 1), (2, 2), (3, 3), (4, 5), (6, 10), (11, usize::MAX)];

/// Index (0-based) of the network serving filtering iteration `k` (1-based).
pub fn network_for_iteration(k: usize) -> usize {
    INTERVALS
        .iter()
        .position(|&(a, b)| k >= a && k <= b)
        .unwrap_or(0)
}

/// File name of network `i` (0-based) inside a bundle.
pub fn network_file(i: usize) -> String {
    format!("net{}.safetensors", i + 1)
}

/// The manifest file name.
pub const MANIFEST: &str = "manifest.toml";

/// Version of the manifest layout written by this code.
pub const FORMAT_VERSION: u32 = 2;

/// What a bundle is and how it was made (`manifest.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// manifest layout version ([`FORMAT_VERSION`])
    pub format: u32,
    /// `paper`, `lite` or `tiny`
    pub preset: String,
    /// μ_g of the six outputs, in output order
    pub mu_gs: Vec<f64>,
    /// filtering iterations served by each network, `[first, last]`; last 0 = N_f
    pub intervals: Vec<[usize; 2]>,
    /// program version and git description at training time
    pub code_version: String,
    /// UTC time the bundle was written (seconds since the Unix epoch)
    pub created_unix: u64,
    /// the integer ranges the networks' int8 parts run with: what they were
    /// trained for (`full`, the default, or `narrow`: 7-bit block inputs
    /// and 6-bit weights, which plain AVX2 sums twice as fast)
    #[serde(default, skip_serializing_if = "is_full_range")]
    pub int8_range: Int8Range,
    /// network architecture
    pub model: ModelConfig,
    /// voxel grid the networks read
    pub voxel: VoxelParams,
    /// how the networks were trained
    pub training: TrainingInfo,
    /// one entry per network, in interval order
    pub networks: Vec<NetworkInfo>,
    /// the learned switch between candidate normals (see
    /// [`crate::switch`]); bundles without one run the paper's form
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub switch: Option<SwitchWeights>,
    /// the recipe that built the bundle (`normalnet train --recipe`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recipe: Option<RecipeInfo>,
    /// the bundle's figures on a validation suite (a recipe's `evaluate`
    /// stage; `normalnet bench --suite` reproduces them)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evaluation: Option<Evaluation>,
}

/// The manifest leaves out the default ranges.
fn is_full_range(range: &Int8Range) -> bool {
    *range == Int8Range::Full
}

/// Which recipe built a bundle, and from what code.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RecipeInfo {
    /// the recipe file as given to `normalnet train --recipe`
    pub recipe: String,
    /// FNV-1a 64 (hex) of the recipe and of every file it names
    pub hash: String,
    /// `git rev-parse HEAD` of the code that ran it (`-dirty` when the tree
    /// had changes; empty outside a git checkout)
    pub commit: String,
    /// the stages, in order (`kind name`)
    pub stages: Vec<String>,
}

/// Mean E_a of a bundle on a validation suite (NormalNet at its defaults).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// the suite file
    pub suite: String,
    /// FNV-1a 64 (hex) of the suite file
    pub suite_hash: String,
    /// the settings the pairs ran at, in words
    pub settings: String,
    /// mean E_a (degrees) over all pairs
    pub all_deg: f64,
    /// mean E_a (degrees) per group
    pub groups: std::collections::BTreeMap<String, f64>,
    /// E_a (degrees) per pair
    pub pairs: std::collections::BTreeMap<String, f64>,
}

/// Training data and settings shared by the six networks.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainingInfo {
    /// clean training meshes (paths relative to the data folder, or `shape:NAME:SEED`)
    pub sources: Vec<String>,
    /// validation meshes (held-back training sources)
    pub validation: Vec<String>,
    /// noise settings of the noisy copies, in words
    pub noise: String,
    /// base seed of noise, sampling and initialisation
    pub seed: u64,
    /// batch size
    pub batch: usize,
    /// base learning rate and schedule, in words
    pub learning_rate: String,
    /// which meshes M_k were regenerated with the trained networks, in words
    pub regeneration: String,
    /// anything else a reader should know (deviations from the paper)
    pub notes: String,
}

/// One trained network.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NetworkInfo {
    /// weight file inside the bundle
    pub file: String,
    /// `[first, last]` filtering iteration; last 0 = N_f
    pub interval: [usize; 2],
    /// optimisation steps taken
    pub steps: usize,
    /// training samples seen (steps × batch)
    pub samples_seen: usize,
    /// distinct faces in the sample pool
    pub pool_faces: usize,
    /// epochs over the pool (samples_seen / pool_faces)
    pub epochs: f64,
    /// wall-clock training time in seconds
    pub train_seconds: f64,
    /// mean training loss (MSE) over the last steps
    pub train_loss: f64,
    /// mean angular error (degrees) of the μ_g-0.35 output on the validation faces, kept checkpoint
    pub validation_error_deg: f64,
    /// the same error of the input (noisy) normal vs the μ_g-0.35 target, for scale
    pub validation_baseline_deg: f64,
    /// the network predicts `target − input normal` (local frame) and
    /// inference adds the face's current normal back; false (bundles
    /// before this field): it predicts the normal itself
    #[serde(default)]
    pub residual: bool,
}

impl Manifest {
    /// Interval list in manifest form (`usize::MAX` written as 0).
    pub fn default_intervals() -> Vec<[usize; 2]> {
        INTERVALS
            .iter()
            .map(|&(a, b)| [a, if b == usize::MAX { 0 } else { b }])
            .collect()
    }

    /// Checks the manifest against what this code can run.
    pub fn validate(&self, path: &Path) -> Result<(), NetError> {
        let bad = |message: String| NetError::BadManifest {
            path: path.to_path_buf(),
            message,
        };
        if self.format == 1 {
            return Err(bad(format!(
                "format 1 (burn records, net1.bpk ...); this program reads format \
                 {FORMAT_VERSION} (safetensors). Convert it once with `normalnet models convert \
                 {} NEW_DIR` from a build with `--features burn`",
                path.parent().unwrap_or(Path::new(".")).display()
            )));
        }
        if self.format != FORMAT_VERSION {
            return Err(bad(format!(
                "format {} (this program reads {FORMAT_VERSION})",
                self.format
            )));
        }
        let preset = ModelConfig::preset(&self.preset).map_err(|e| bad(e.to_string()))?;
        if preset != self.model {
            return Err(bad(format!(
                "model {:?} is not the {} preset {:?}",
                self.model, self.preset, preset
            )));
        }
        self.model.validate().map_err(|e| bad(e.to_string()))?;
        self.voxel.validate().map_err(|e| bad(e.to_string()))?;
        if self.voxel.side() != self.model.grid {
            return Err(bad(format!(
                "voxel grid side {} does not match the network's {}",
                self.voxel.side(),
                self.model.grid
            )));
        }
        if self.mu_gs.len() * 3 != self.model.outputs {
            return Err(bad(format!(
                "{} μ_g values for {} outputs",
                self.mu_gs.len(),
                self.model.outputs
            )));
        }
        if self.mu_gs.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
            return Err(bad("mu_gs must be positive".into()));
        }
        if self.intervals != Manifest::default_intervals() {
            return Err(bad(format!(
                "intervals {:?} (expected {:?})",
                self.intervals,
                Manifest::default_intervals()
            )));
        }
        if let Some(switch) = &self.switch {
            switch.validate().map_err(bad)?;
        }
        if self.networks.len() != INTERVALS.len() {
            return Err(bad(format!(
                "{} networks listed (expected {})",
                self.networks.len(),
                INTERVALS.len()
            )));
        }
        Ok(())
    }

    /// Reads and validates `manifest.toml`.
    pub fn read(path: &Path) -> Result<Manifest, NetError> {
        let text = std::fs::read_to_string(path).map_err(|e| NetError::io(path, e))?;
        Manifest::parse(&text, path)
    }

    /// Parses and validates manifest text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Manifest, NetError> {
        let manifest: Manifest = toml::from_str(text).map_err(|e| NetError::BadManifest {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        manifest.validate(path)?;
        Ok(manifest)
    }

    /// Writes `manifest.toml` atomically.
    pub fn write(&self, path: &Path) -> Result<(), NetError> {
        let text = toml::to_string(self).map_err(|e| NetError::BadManifest {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        write_atomically(path, text.as_bytes())
    }
}

/// Six loaded networks and their manifest, ready for inference.
#[derive(Debug, Clone)]
pub struct Bundle {
    /// where it was loaded from (`<built-in ...>` for the embedded model)
    pub path: PathBuf,
    /// what it is
    pub manifest: Manifest,
    /// the six networks' weights, in interval order
    pub networks: Vec<NetWeights>,
    /// the same networks compiled for the CPU engine (inference mode)
    pub engines: Vec<Cnn>,
}

impl Bundle {
    /// Sets the arithmetic of every network ([`Cnn::set_arithmetic`]) and
    /// returns what all of them run: a part is in int8 when it is in every
    /// network.
    pub fn set_arithmetic(&mut self, arithmetic: Arithmetic) -> Arithmetic {
        self.engines.iter_mut().fold(arithmetic, |every, engine| {
            every.and(engine.set_arithmetic(arithmetic))
        })
    }

    /// Loads the bundle in folder `path`.
    ///
    /// # Errors
    /// [`NetError::MissingFile`] for a missing manifest or weight file,
    /// [`NetError::BadManifest`] for an unreadable or inconsistent manifest
    /// (format 1 included, with the command that converts it),
    /// [`NetError::WeightMismatch`] when a weight file does not fit the preset.
    pub fn load(path: impl AsRef<Path>) -> Result<Bundle, NetError> {
        let path = path.as_ref();
        if !path.is_dir() {
            return Err(NetError::MissingFile {
                bundle: path.to_path_buf(),
                file: "(the bundle folder itself)".into(),
            });
        }
        let manifest_path = path.join(MANIFEST);
        if !manifest_path.is_file() {
            return Err(NetError::MissingFile {
                bundle: path.to_path_buf(),
                file: MANIFEST.into(),
            });
        }
        let manifest = Manifest::read(&manifest_path)?;
        let mut networks = Vec::with_capacity(INTERVALS.len());
        for (i, info) in manifest.networks.iter().enumerate() {
            if info.file.contains('/') || info.file.contains('\\') || info.file.is_empty() {
                return Err(NetError::BadManifest {
                    path: manifest_path.clone(),
                    message: format!(
                        "network {} file name {:?} is not a plain name",
                        i + 1,
                        info.file
                    ),
                });
            }
            let file = path.join(&info.file);
            if !file.is_file() {
                return Err(NetError::MissingFile {
                    bundle: path.to_path_buf(),
                    file: info.file.clone(),
                });
            }
            networks.push(crate::weights_file::load(
                &manifest.model,
                &manifest.preset,
                &file,
            )?);
        }
        Bundle::from_parts(path.to_path_buf(), manifest, networks)
    }

    /// A bundle from a manifest (`manifest.toml` text) and the six weight
    /// files' bytes held in memory; `label` names it in messages.
    pub fn from_bytes(label: &str, manifest: &str, files: &[&[u8]]) -> Result<Bundle, NetError> {
        let path = PathBuf::from(label);
        let manifest = Manifest::parse(manifest, &path.join(MANIFEST))?;
        if files.len() != manifest.networks.len() {
            return Err(NetError::BadManifest {
                path: path.join(MANIFEST),
                message: format!(
                    "{} weight files for {} networks",
                    files.len(),
                    manifest.networks.len()
                ),
            });
        }
        let mut networks = Vec::with_capacity(files.len());
        for (info, bytes) in manifest.networks.iter().zip(files) {
            let w = crate::weights_file::from_bytes(&manifest.model, bytes).map_err(|message| {
                NetError::WeightMismatch {
                    path: path.join(&info.file),
                    preset: manifest.preset.clone(),
                    message,
                }
            })?;
            networks.push(w);
        }
        Bundle::from_parts(path, manifest, networks)
    }

    /// A bundle of weights already in memory (checked against the manifest's
    /// architecture and compiled).
    pub fn from_parts(
        path: PathBuf,
        manifest: Manifest,
        networks: Vec<NetWeights>,
    ) -> Result<Bundle, NetError> {
        let mut engines = Vec::with_capacity(networks.len());
        for (info, w) in manifest.networks.iter().zip(&networks) {
            let mismatch = |message: String| NetError::WeightMismatch {
                path: path.join(&info.file),
                preset: manifest.preset.clone(),
                message,
            };
            if w.grid != manifest.model.grid {
                return Err(mismatch(format!(
                    "grid {} for a {}-grid network",
                    w.grid, manifest.model.grid
                )));
            }
            let mut cnn = Cnn::new(w).map_err(|e| mismatch(e.to_string()))?;
            cnn.set_int8_range(manifest.int8_range);
            if cnn.outputs() != manifest.model.outputs {
                return Err(mismatch(format!(
                    "{} outputs, the manifest says {}",
                    cnn.outputs(),
                    manifest.model.outputs
                )));
            }
            engines.push(cnn);
        }
        Ok(Bundle {
            path,
            manifest,
            networks,
            engines,
        })
    }

    /// The voxel grid parameters the networks expect.
    pub fn voxel_params(&self) -> VoxelParams {
        self.manifest.voxel
    }

    /// Output slot (0..6) of the μ_g nearest to `mu_g`.
    pub fn output_for_mu_g(&self, mu_g: f64) -> usize {
        nearest_mu_g(&self.manifest.mu_gs, mu_g)
    }
}

/// Index of the entry of `mu_gs` nearest to `mu_g` (first on ties).
pub fn nearest_mu_g(mu_gs: &[f64], mu_g: f64) -> usize {
    let mut best = 0;
    for (i, m) in mu_gs.iter().enumerate() {
        if (m - mu_g).abs() < (mu_gs[best] - mu_g).abs() - 1e-12 {
            best = i;
        }
    }
    best
}

/// Writes `bytes` to `path` through a temporary file and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), NetError> {
    let tmp = path.with_extension("tmp~");
    std::fs::write(&tmp, bytes).map_err(|e| NetError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| NetError::io(path, e))
}

/// Writes a whole bundle: the six networks and the manifest (written last,
/// so a folder with a manifest is complete).
pub fn save_bundle(
    dir: &Path,
    manifest: &Manifest,
    networks: &[NetWeights],
) -> Result<(), NetError> {
    std::fs::create_dir_all(dir).map_err(|e| NetError::io(dir, e))?;
    for (i, net) in networks.iter().enumerate() {
        crate::weights_file::save(net, &dir.join(&manifest.networks[i].file))?;
    }
    manifest.write(&dir.join(MANIFEST))
}

/// A manifest for `preset` with default intervals and μ_g list and empty
/// training information.
pub fn new_manifest(preset: &str) -> Result<Manifest, NetError> {
    let model = ModelConfig::preset(preset)?;
    let voxel = match preset {
        "paper" => VoxelParams::paper(),
        "tiny" => VoxelParams::tiny(),
        _ => VoxelParams::lite(),
    };
    Ok(Manifest {
        format: FORMAT_VERSION,
        preset: preset.to_string(),
        mu_gs: MU_GS.to_vec(),
        intervals: Manifest::default_intervals(),
        code_version: code_version(),
        int8_range: Int8Range::Full,
        created_unix: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        model,
        voxel,
        training: TrainingInfo::default(),
        networks: (0..INTERVALS.len())
            .map(|i| NetworkInfo {
                file: network_file(i),
                interval: Manifest::default_intervals()[i],
                ..NetworkInfo::default()
            })
            .collect(),
        switch: None,
        recipe: None,
        evaluation: None,
    })
}

/// `git rev-parse HEAD` of the source tree, `-dirty` appended when it has
/// changes; empty outside a git checkout.
pub fn commit() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "HEAD"]) {
        Some(head) => match git(&["status", "--porcelain", "--untracked-files=no"]) {
            Some(changes) if !changes.is_empty() => format!("{head}-dirty"),
            _ => head,
        },
        None => String::new(),
    }
}

/// `normalnet-net <version>` plus `git describe` of the working tree when
/// available.
pub fn code_version() -> String {
    let git = std::process::Command::new("git")
        .args(["describe", "--always", "--dirty"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    match git {
        Some(g) => format!("normalnet-net {} ({g})", env!("CARGO_PKG_VERSION")),
        None => format!("normalnet-net {}", env!("CARGO_PKG_VERSION")),
    }
}

/// FNV-1a 64 of `bytes`: the content hashes a bundle and its recipe run
/// record (recipes, suites, source files, the network that made a
/// training stage's mesh states).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny_bundle(dir: &Path) -> Manifest {
        let manifest = new_manifest("tiny").unwrap();
        let nets: Vec<NetWeights> = (0..6)
            .map(|i| ModelConfig::tiny().init_weights(i as u64))
            .collect();
        save_bundle(dir, &manifest, &nets).unwrap();
        manifest
    }

    #[test]
    fn intervals_cover_every_iteration() {
        assert_eq!(network_for_iteration(1), 0);
        assert_eq!(network_for_iteration(3), 2);
        assert_eq!(network_for_iteration(5), 3);
        assert_eq!(network_for_iteration(6), 4);
        assert_eq!(network_for_iteration(10), 4);
        assert_eq!(network_for_iteration(11), 5);
        assert_eq!(network_for_iteration(40), 5);
    }

    #[test]
    fn nearest_mu_g_picks_the_closest_output() {
        assert_eq!(nearest_mu_g(&MU_GS, 0.35), 2);
        assert_eq!(nearest_mu_g(&MU_GS, 0.0), 0);
        assert_eq!(nearest_mu_g(&MU_GS, 0.9), 5);
        assert_eq!(nearest_mu_g(&MU_GS, 0.31), 1);
    }

    #[test]
    fn save_and_load_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let manifest = tiny_bundle(dir.path());
        let bundle = Bundle::load(dir.path()).unwrap();
        assert_eq!(bundle.manifest, manifest);
        assert_eq!(bundle.networks.len(), 6);
        assert_eq!(bundle.networks[3], ModelConfig::tiny().init_weights(3));
        // the same from bytes in memory
        let read = |f: &str| std::fs::read(dir.path().join(f)).unwrap();
        let files: Vec<Vec<u8>> = (0..6).map(|i| read(&network_file(i))).collect();
        let refs: Vec<&[u8]> = files.iter().map(|f| f.as_slice()).collect();
        let text = std::fs::read_to_string(dir.path().join(MANIFEST)).unwrap();
        let from_bytes = Bundle::from_bytes("<memory>", &text, &refs).unwrap();
        assert_eq!(from_bytes.networks, bundle.networks);
    }

    /// `int8_range` is left out for full ranges, read back as written, set on
    /// every engine, and an unknown range is refused naming the manifest.
    #[test]
    fn the_int8_range_is_written_read_and_set_on_every_network() {
        let dir = tempfile::tempdir().unwrap();
        let mut manifest = tiny_bundle(dir.path());
        let path = dir.path().join(MANIFEST);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(!text.contains("int8_range"), "full ranges are the default");
        let bundle = Bundle::load(dir.path()).unwrap();
        assert!(
            bundle
                .engines
                .iter()
                .all(|e| e.int8_range() == Int8Range::Full)
        );
        manifest.int8_range = Int8Range::Narrow;
        manifest.write(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("int8_range = \"narrow\""), "{text}");
        let bundle = Bundle::load(dir.path()).unwrap();
        assert_eq!(bundle.manifest, manifest);
        assert!(
            bundle
                .engines
                .iter()
                .all(|e| e.int8_range() == Int8Range::Narrow)
        );
        std::fs::write(&path, text.replace("\"narrow\"", "\"wide\"")).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("manifest.toml") && err.contains("wide"),
            "{err}"
        );
    }

    #[test]
    fn format_1_bundles_get_the_conversion_command() {
        let dir = tempfile::tempdir().unwrap();
        let mut manifest = tiny_bundle(dir.path());
        manifest.format = 1;
        manifest.write(&dir.path().join(MANIFEST)).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("format 1") && err.contains("normalnet models convert"),
            "{err}"
        );
    }

    #[test]
    fn missing_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        tiny_bundle(dir.path());
        std::fs::remove_file(dir.path().join("net4.safetensors")).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err();
        assert!(
            matches!(err, NetError::MissingFile { ref file, .. } if file == "net4.safetensors"),
            "{err}"
        );
        let err = Bundle::load(dir.path().join("nope")).unwrap_err();
        assert!(matches!(err, NetError::MissingFile { .. }), "{err}");
        std::fs::remove_file(dir.path().join(MANIFEST)).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err();
        assert!(err.to_string().contains("manifest.toml"), "{err}");
    }

    #[test]
    fn wrong_preset_weights_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let mut manifest = tiny_bundle(dir.path());
        // claim the weights are `lite`
        manifest.preset = "lite".into();
        manifest.model = ModelConfig::lite();
        manifest.voxel = VoxelParams::lite();
        manifest.write(&dir.path().join(MANIFEST)).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err();
        assert!(matches!(err, NetError::WeightMismatch { .. }), "{err}");
        assert!(err.to_string().contains("net1.safetensors"), "{err}");
    }

    #[test]
    fn bad_manifests_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let manifest = tiny_bundle(dir.path());
        let path = dir.path().join(MANIFEST);
        std::fs::write(&path, "preset = [").unwrap();
        assert!(matches!(
            Bundle::load(dir.path()),
            Err(NetError::BadManifest { .. })
        ));
        let mut m = manifest.clone();
        m.voxel = VoxelParams::lite();
        m.write(&path).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err();
        assert!(err.to_string().contains("grid side"), "{err}");
        let mut m = manifest.clone();
        m.networks.pop();
        m.write(&path).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err();
        assert!(err.to_string().contains("5 networks"), "{err}");
        // a switch of the wrong shape is named, with the manifest's path
        let mut m = manifest.clone();
        let mut switch = crate::switch::tests::constant(0);
        switch.b1.push(0.0);
        m.switch = Some(switch);
        m.write(&path).unwrap();
        let err = Bundle::load(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("switch: b1") && err.contains("manifest.toml"),
            "{err}"
        );
        // a good one survives the round trip
        let mut m = manifest;
        m.switch = Some(crate::switch::tests::constant(2));
        m.write(&path).unwrap();
        assert_eq!(Bundle::load(dir.path()).unwrap().manifest, m);
    }
}
