//! Validation suites (issue 35): a TOML list of clean sources, each with its
//! noise (one or more [`NoiseParams`] components, seeded) and the groups it
//! belongs to, generated deterministically into a cache folder and compared
//! against the clean source by `normalnet bench --suite FILE`.
//!
//! ```toml
//! data = "../../shared/data"          # sources' folder, relative to this file
//! shape_faces = 6000                  # faces of the procedural `shape:SEED` sources
//! groups = ["moderate", "cad"]        # every group a pair may name, in table order
//!
//! [[pair]]
//! name = "rocker-arm-g0.3"            # letters, digits, `.`, `_`, `-`, `+`
//! source = "c3d/rocker-arm.obj"       # under `data`, or `shape:SEED`
//! groups = ["moderate", "cad"]
//! noise = [{ level = 0.3, seed = 1 }] # components add up (a mixture)
//! ```
//!
//! A suite never reads test data: [`Suite::load`] refuses any source under
//! `cnr/` or in one of [`TEST_FOLDERS`] of `gd/` (`../shared/data/SOURCES.md`,
//! "Split"). Everything is checked before anything is generated.
//!
//! Cache: `CACHE/NAME/Noisy.obj` (and `Original.obj` for procedural
//! sources; a file source is its own ground truth) beside `key.json`, the
//! pair's source, noise components, shape face count and the FNV-1a hash of
//! the source file's bytes. A pair whose key differs (changed spec, seed or
//! source file) is generated again; the key is written last, so an
//! interrupted generation is redone.

use crate::DenoiseError;
use normalnet_mesh::noise::add_noise_mixture;
use normalnet_mesh::{NoiseDirection, NoiseParams, Progress, read_mesh, write_mesh};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `gd/` folders that are test data (the paper's Table 3 models); with
/// all of `cnr/` no suite may use them.
pub const TEST_FOLDERS: [&str; 5] = [
    "Fandisk0.3",
    "Fandisk0.7",
    "Block0.4",
    "Twelve0.5Impulsive",
    "Bunny0.2",
];

/// Version of the generation recorded in every cache key: raise it when the
/// noise or shape generators change their output for the same parameters.
const GENERATOR_VERSION: u32 = 1;

/// A validation suite as read from its TOML file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Suite {
    /// folder of the file sources, relative to the suite file's folder
    #[serde(default = "default_data")]
    pub data: String,
    /// face count of the procedural sources (`shape:SEED`)
    #[serde(default = "default_shape_faces")]
    pub shape_faces: usize,
    /// the groups pairs may belong to, in the order the report lists them
    pub groups: Vec<String>,
    /// the pairs, in the order the report lists them
    #[serde(rename = "pair")]
    pub pairs: Vec<SuitePair>,
    /// the suite file's folder (set by [`Suite::load`] / [`Suite::parse`])
    #[serde(skip)]
    pub folder: PathBuf,
}

fn default_data() -> String {
    "../../shared/data".into()
}

fn default_shape_faces() -> usize {
    6000
}

/// One clean source and its noise.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuitePair {
    /// unique name (a folder name in the cache and the report's row)
    pub name: String,
    /// a path under the suite's `data` folder, or `shape:SEED`
    pub source: String,
    /// the groups of the pair (each one of [`Suite::groups`])
    pub groups: Vec<String>,
    /// noise components, added in order (one for plain noise)
    pub noise: Vec<NoiseParams>,
}

/// A pair ready to bench: its noisy input and ground truth on disk.
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedPair {
    /// the pair's name
    pub name: String,
    /// the generated noisy mesh (in the cache)
    pub noisy: PathBuf,
    /// the clean mesh: the source file, or the generated shape in the cache
    pub clean: PathBuf,
    /// the pair's groups
    pub groups: Vec<String>,
    /// whether this call generated it (false: the cache was current)
    pub generated: bool,
}

/// What a cache entry was generated from (`key.json`).
#[derive(Serialize, PartialEq)]
struct CacheKey<'a> {
    generator: u32,
    source: &'a str,
    source_fnv1a: Option<String>,
    shape_faces: Option<usize>,
    noise: &'a [NoiseParams],
}

impl Suite {
    /// Reads and checks a suite file ([`Suite::parse`]).
    ///
    /// # Errors
    /// [`DenoiseError::Suite`] naming the file (and the pair) for unreadable
    /// or invalid TOML, duplicate or unsafe names, undeclared groups, empty
    /// groups or noise lists, bad noise parameters, missing source files and
    /// test data.
    pub fn load(path: &Path) -> Result<Suite, DenoiseError> {
        let text = std::fs::read_to_string(path).map_err(|e| suite_error(path, e.to_string()))?;
        let folder = path.parent().unwrap_or(Path::new("")).to_path_buf();
        Suite::parse(&text, path, folder)
    }

    /// Parses suite text (`path` names it in errors; `folder` anchors its
    /// `data`) and checks every pair before anything is generated.
    ///
    /// # Errors
    /// As [`Suite::load`].
    pub fn parse(text: &str, path: &Path, folder: PathBuf) -> Result<Suite, DenoiseError> {
        let mut suite: Suite =
            toml::from_str(text).map_err(|e| suite_error(path, format!("invalid suite: {e}")))?;
        suite.folder = folder;
        suite.check(path)?;
        Ok(suite)
    }

    /// The folder of the file sources.
    pub fn data_folder(&self) -> PathBuf {
        self.folder.join(&self.data)
    }

    /// The file of a pair's source, `None` for a procedural shape.
    pub fn source_file(&self, pair: &SuitePair) -> Option<PathBuf> {
        shape_seed(&pair.source)
            .is_none()
            .then(|| self.data_folder().join(&pair.source))
    }

    /// The pairs of `group`, in suite order.
    pub fn members(&self, group: &str) -> Vec<&str> {
        self.pairs
            .iter()
            .filter(|p| p.groups.iter().any(|g| g == group))
            .map(|p| p.name.as_str())
            .collect()
    }

    fn check(&self, path: &Path) -> Result<(), DenoiseError> {
        let err =
            |pair: &str, message: String| suite_error(path, format!("pair {pair:?}: {message}"));
        if self.pairs.is_empty() {
            return Err(suite_error(path, "no [[pair]] entries".into()));
        }
        if !(100..=2_000_000).contains(&self.shape_faces) {
            return Err(suite_error(
                path,
                format!("shape_faces {} must be in 100..=2000000", self.shape_faces),
            ));
        }
        for (i, p) in self.pairs.iter().enumerate() {
            let n = &p.name;
            if n.is_empty()
                || n.starts_with('.')
                || !n
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "._-+".contains(c))
            {
                return Err(err(
                    n,
                    "a name is letters, digits, '.', '_', '-' and '+' only".into(),
                ));
            }
            if self.pairs[..i].iter().any(|q| &q.name == n) {
                return Err(err(n, "the name is used twice".into()));
            }
            if p.groups.is_empty() {
                return Err(err(n, "belongs to no group".into()));
            }
            if let Some(g) = p.groups.iter().find(|g| !self.groups.contains(g)) {
                return Err(err(
                    n,
                    format!(
                        "group {g:?} is not declared in `groups` ({})",
                        self.groups.join(", ")
                    ),
                ));
            }
            if p.noise.is_empty() {
                return Err(err(n, "`noise` needs at least one component".into()));
            }
            for (k, c) in p.noise.iter().enumerate() {
                c.validate()
                    .map_err(|e| err(n, format!("noise component {}: {e}", k + 1)))?;
            }
            if let Some(t) = test_data_in(&p.source) {
                return Err(err(
                    n,
                    format!(
                        "source {:?} is test data ({t}): a suite never uses it",
                        p.source
                    ),
                ));
            }
            if p.source.starts_with("shape:") {
                if shape_seed(&p.source).is_none() {
                    return Err(err(n, format!("{:?}: expected shape:SEED", p.source)));
                }
            } else if let Some(file) = self.source_file(p)
                && !file.is_file()
            {
                return Err(err(
                    n,
                    format!("source file {} does not exist", file.display()),
                ));
            }
        }
        if let Some(g) = self.groups.iter().find(|g| self.members(g).is_empty()) {
            return Err(suite_error(path, format!("group {g:?} has no pairs")));
        }
        Ok(())
    }

    /// Generates the pairs whose cache entry is missing or out of date into
    /// `cache` and returns every pair's files, in suite order.
    ///
    /// # Errors
    /// [`DenoiseError::Suite`] naming the pair for a source that cannot be
    /// read or made, noise that cannot be added, or a cache that cannot be
    /// written.
    pub fn prepare(
        &self,
        cache: &Path,
        progress: &dyn Progress,
    ) -> Result<Vec<PreparedPair>, DenoiseError> {
        let mut out = Vec::with_capacity(self.pairs.len());
        for pair in &self.pairs {
            out.push(self.prepare_pair(pair, cache, progress)?);
        }
        Ok(out)
    }

    fn prepare_pair(
        &self,
        pair: &SuitePair,
        cache: &Path,
        progress: &dyn Progress,
    ) -> Result<PreparedPair, DenoiseError> {
        let fail = |what: &str, e: &dyn std::fmt::Display| {
            suite_error(cache, format!("pair {:?}: {what}: {e}", pair.name))
        };
        let dir = cache.join(&pair.name);
        let noisy_path = dir.join("Noisy.obj");
        let source_file = self.source_file(pair);
        let clean_path = source_file
            .clone()
            .unwrap_or_else(|| dir.join("Original.obj"));
        let source_fnv1a = match &source_file {
            Some(f) => {
                let bytes =
                    std::fs::read(f).map_err(|e| fail(&format!("reading {}", f.display()), &e))?;
                Some(format!("{:016x}", normalnet_net::bundle::fnv1a(&bytes)))
            }
            None => None,
        };
        let key = CacheKey {
            generator: GENERATOR_VERSION,
            source: &pair.source,
            source_fnv1a,
            shape_faces: source_file.is_none().then_some(self.shape_faces),
            noise: &pair.noise,
        };
        let key_text = serde_json::to_string_pretty(&key).map_err(|e| fail("cache key", &e))?;
        let key_path = dir.join("key.json");
        let current = std::fs::read_to_string(&key_path).is_ok_and(|t| t == key_text)
            && noisy_path.is_file()
            && clean_path.is_file();
        if !current {
            progress.message(&format!("generating {}", pair.name));
            let clean = match (&source_file, shape_seed(&pair.source)) {
                (Some(f), _) => read_mesh(f).map_err(|e| fail("reading the source", &e))?,
                (None, Some(seed)) => {
                    normalnet_voxel::shapes::generate_seeded(seed, self.shape_faces)
                        .map_err(|e| fail("making the shape", &e))?
                }
                (None, None) => unreachable!("checked by Suite::check"),
            };
            let (noisy, _) =
                add_noise_mixture(&clean, &pair.noise).map_err(|e| fail("adding noise", &e))?;
            std::fs::create_dir_all(&dir)
                .map_err(|e| fail(&format!("creating {}", dir.display()), &e))?;
            // a stale key must not outlive a partial rewrite
            let _ = std::fs::remove_file(&key_path);
            if source_file.is_none() {
                write_mesh(&clean_path, &clean).map_err(|e| fail("writing the shape", &e))?;
            }
            write_mesh(&noisy_path, &noisy).map_err(|e| fail("writing the noisy mesh", &e))?;
            normalnet_mesh::io::write_atomically(&key_path, |w| w.write_all(key_text.as_bytes()))
                .map_err(|e| fail("writing the cache key", &e))?;
        }
        Ok(PreparedPair {
            name: pair.name.clone(),
            noisy: noisy_path,
            clean: clean_path,
            groups: pair.groups.clone(),
            generated: !current,
        })
    }
}

/// A short description of a pair's noise for the report, e.g. `gaussian
/// L=0.3`, `impulsive L=0.5 p=0.5`, `view L=0.2 k=2 + impulsive L=1 p=0.05`.
pub fn describe_noise(components: &[NoiseParams]) -> String {
    components
        .iter()
        .map(describe_component)
        .collect::<Vec<_>>()
        .join(" + ")
}

fn describe_component(p: &NoiseParams) -> String {
    let mut words = Vec::new();
    if p.correlation_length.is_some() {
        words.push("correlated".to_string());
    }
    words.push(
        match (p.impulsive_fraction.is_some(), p.direction) {
            (true, _) => "impulsive",
            (false, NoiseDirection::View) => "view",
            (false, _) => "gaussian",
        }
        .to_string(),
    );
    if p.impulsive_fraction.is_some() && p.direction == NoiseDirection::View {
        words.push("view".into());
    }
    if p.direction == NoiseDirection::Random {
        words.push("random-dir".into());
    }
    words.push(format!("L={}", p.level));
    if let Some(f) = p.impulsive_fraction {
        words.push(format!("p={f}"));
    }
    if p.depth_gain != 0.0 {
        words.push(format!("k={}", p.depth_gain));
    }
    if let Some(l) = p.correlation_length {
        words.push(format!("λ={l}"));
    }
    words.join(" ")
}

/// Which test data a source path is in, if any (`cnr/...` or a
/// [`TEST_FOLDERS`] folder of `gd/`).
pub fn test_data_in(source: &str) -> Option<String> {
    let parts: Vec<&str> = Path::new(source)
        .components()
        .filter_map(|c| c.as_os_str().to_str())
        .filter(|c| *c != ".")
        .collect();
    if parts.contains(&"cnr") {
        return Some("cnr/".into());
    }
    parts
        .iter()
        .find(|c| TEST_FOLDERS.contains(c))
        .map(|c| format!("gd/{c}"))
}

fn shape_seed(source: &str) -> Option<u64> {
    source.strip_prefix("shape:")?.parse().ok()
}

fn suite_error(path: &Path, message: String) -> DenoiseError {
    DenoiseError::Suite {
        path: path.to_path_buf(),
        message,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TINY: &str = r#"
shape_faces = 400
groups = ["cad", "heavy"]

[[pair]]
name = "box-g0.3"
source = "shape:900"
groups = ["cad"]
noise = [{ level = 0.3, seed = 1 }]

[[pair]]
name = "cyl-mix"
source = "shape:901"
groups = ["cad", "heavy"]
noise = [{ level = 0.6, seed = 2 }, { level = 1.0, impulsive_fraction = 0.1, seed = 3 }]
"#;

    fn parse(text: &str) -> Result<Suite, DenoiseError> {
        Suite::parse(text, Path::new("s.toml"), PathBuf::from("."))
    }

    /// The fold study (configs/switch-fold-study.toml) chooses a rule of
    /// the shipped switch, so it may not use what checks the choice: no
    /// source of the validation suite, no procedural shape it reserves
    /// (900–999), no test data.
    #[test]
    fn the_fold_study_keeps_out_of_the_validation_suite() {
        let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
        let study = Suite::load(&configs.join("switch-fold-study.toml")).unwrap();
        let validation = Suite::load(&configs.join("validation.toml")).unwrap();
        assert!(study.pairs.len() >= 10);
        for pair in &study.pairs {
            let source = pair.source.as_str();
            assert!(
                validation.pairs.iter().all(|v| v.source != source),
                "{}: {source} is a validation source",
                pair.name
            );
            let seed = source
                .strip_prefix("shape:")
                .and_then(|s| s.parse::<u64>().ok());
            assert!(
                seed.is_none_or(|s| !(900..1000).contains(&s)),
                "{}: {source} is reserved for validation",
                pair.name
            );
            assert_eq!(test_data_in(source), None, "{}", pair.name);
        }
    }

    #[test]
    fn a_suite_is_generated_once_and_regenerated_when_its_spec_changes() {
        let suite = parse(TINY).unwrap();
        assert_eq!(suite.members("heavy"), ["cyl-mix"]);
        let dir = tempfile::tempdir().unwrap();
        let first = suite
            .prepare(dir.path(), &normalnet_mesh::NoProgress)
            .unwrap();
        assert!(first.iter().all(|p| p.generated));
        assert_eq!(first[1].clean, dir.path().join("cyl-mix/Original.obj"));
        let bytes = std::fs::read(&first[1].noisy).unwrap();
        let again = suite
            .prepare(dir.path(), &normalnet_mesh::NoProgress)
            .unwrap();
        assert!(again.iter().all(|p| !p.generated), "the cache is current");
        let changed = parse(&TINY.replace("seed = 3", "seed = 4")).unwrap();
        let redone = changed
            .prepare(dir.path(), &normalnet_mesh::NoProgress)
            .unwrap();
        assert_eq!((redone[0].generated, redone[1].generated), (false, true));
        assert_ne!(std::fs::read(&redone[1].noisy).unwrap(), bytes);
        assert_eq!(
            describe_noise(&suite.pairs[1].noise),
            "gaussian L=0.6 + impulsive L=1 p=0.1"
        );
    }

    #[test]
    fn bad_suites_name_the_pair_and_the_problem() {
        for (edit, needle) in [
            (
                ("\"cad\"]\nnoise", "\"organic\"]\nnoise"),
                "group \"organic\" is not declared",
            ),
            (("shape:901", "cnr/block_n1/Noisy.obj"), "test data (cnr/)"),
            (
                ("shape:901", "gd/Bunny0.2/Original.obj"),
                "test data (gd/Bunny0.2)",
            ),
            (("shape:901", "c3d/nosuch.obj"), "does not exist"),
            (("shape:901", "shape:x"), "expected shape:SEED"),
            (("cyl-mix", "box-g0.3"), "used twice"),
            (("cyl-mix", "a/b"), "letters, digits"),
            (("seed = 2 }", "seed = 2, depth_gain = 1 }"), "depth_gain"),
            (("seed = 2 }", "sed = 2 }"), "unknown field `sed`"),
        ] {
            let e = parse(&TINY.replace(edit.0, edit.1))
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle) && e.contains("s.toml"), "{e}");
        }
        let e = parse(&TINY.replace(
            "[\"cad\", \"heavy\"]\n\n",
            "[\"cad\", \"heavy\", \"mild\"]\n\n",
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("group \"mild\" has no pairs"), "{e}");
    }

    /// The shipped suite parses, its files exist (when the data is here) and
    /// it holds no test data.
    #[test]
    fn the_shipped_validation_suite_uses_no_test_data() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/validation.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let folder = path.parent().unwrap().to_path_buf();
        let data_here = folder.join("../../shared/data").is_dir();
        let suite = match Suite::parse(&text, &path, folder.clone()) {
            Ok(s) => s,
            Err(e) if !data_here && e.to_string().contains("does not exist") => {
                eprintln!("skipping the file checks: ../shared/data is absent ({e})");
                let mut s: Suite = toml::from_str(&text).unwrap();
                s.folder = folder;
                s
            }
            Err(e) => panic!("{e}"),
        };
        for p in &suite.pairs {
            assert_eq!(test_data_in(&p.source), None, "{}", p.source);
            assert!(!p.source.contains("cnr"), "{}", p.source);
            for t in TEST_FOLDERS {
                assert!(!p.source.contains(t), "{} is test data", p.source);
            }
        }
        for g in [
            "mild",
            "moderate",
            "heavy",
            "impulsive",
            "cad",
            "organic",
            "scanner",
        ] {
            assert!(
                suite.members(g).len() >= 3,
                "group {g}: {:?}",
                suite.members(g)
            );
        }
    }
}
