//! Training recipes (issue 35): one TOML file per shipped model
//! (`configs/recipes/<model>.toml`) lists every stage that makes its
//! bundle, in order; `normalnet train --recipe FILE --out DIR` runs them
//! ([`run`]) and resumes at the stage and checkpoint where a run stopped.
//!
//! ```toml
//! name = "lite"
//! description = "..."
//!
//! [[stage]]                      # train the six networks (paper §4)
//! kind = "networks"
//! name = "first"
//! config = "../train-lite.toml"  # a training config, relative to this file
//!
//! [[stage]]                      # continue every network of `first`
//! kind = "networks"
//! name = "more"
//! config = "../train-lite-more.toml"
//! continue_from = "first"        # replaces the config's init_from
//!
//! [[stage]]                      # rows for the learned switch
//! kind = "switch_rows"
//! name = "rows"
//! networks = "more"              # whose networks run
//! follow = ""                    # a switch_fit stage: rows along its path
//! iterations = 10
//! pairs = [{ mesh = "shape:60", gaussian = [0.3] }]
//!
//! [[stage]]
//! kind = "switch_fit"
//! name = "switch"
//! rows = ["rows"]                # switch_rows stages (a name twice counts twice)
//!
//! [[stage]]
//! kind = "evaluate"
//! name = "validation"
//! suite = "../validation.toml"
//! ```
//!
//! A stage may take what it makes from a bundle folder instead (a recipe
//! that refits only the switch of a shipped bundle,
//! `configs/recipes/lite-heavy-switch.toml`):
//!
//! ```toml
//! [[stage]]
//! kind = "networks"
//! name = "shipped"
//! bundle = "../../models/lite"   # its networks as they are, no training
//!
//! [[stage]]
//! kind = "switch_fit"
//! name = "shipped-switch"
//! bundle = "../../models/lite"   # its main table (late = true: its late one)
//! ```
//!
//! and a `networks` stage may pick, per network slot, the network of an
//! earlier `networks` stage:
//!
//! ```toml
//! [[stage]]
//! kind = "networks"
//! name = "mixed"
//! slots = ["broad", "broad", "broad", "shipped", "shipped", "shipped"]
//! ```
//!
//! A CNR recipe has one stage instead, which trains the model on a
//! training config's sources (`configs/recipes/cnr.toml`):
//!
//! ```toml
//! [[stage]]
//! kind = "cnr"
//! name = "cnr"
//! config = "../train-lite.toml"  # sources, validation meshes and seed
//! [stage.settings]               # cnr::train::CnrTrainSettings, over its defaults
//! clusters = 4
//! ```
//!
//! and writes `DIR/cnr.json`, its training notes ending with the recipe,
//! its hash and the commit.
//!
//! The bundle in `DIR` takes the networks of the last `networks` stage,
//! the `[switch]` table of the last main `switch_fit` stage (with
//! `[switch.late]` of the last one after it with `late = true`, and
//! `[switch.heavy]` of the last one after it with `heavy_from`) and the
//! figures of the last
//! `evaluate` stage; its manifest's `[recipe]` records the recipe, its hash
//! (the recipe and every file it names) and the commit. Each stage works in
//! `DIR/stages/NN-name/` and is done when its `DONE` file holds the
//! stage's hash ([`Recipe::stage_hashes`]): an edited recipe reruns the
//! stages its edit changes and every later one, and keeps the earlier ones.

mod evaluate;
mod run;
mod stages;

pub use evaluate::evaluate_params;
pub use run::{RecipeOutcome, plan, run};

use std::path::{Path, PathBuf};

use normalnet_net::training::{SourceSpec, TrainConfig};
use serde::{Deserialize, Serialize};

use crate::DenoiseError;

/// A recipe as read from its file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// the model it makes (`lite`, `smoke`, ...)
    pub name: String,
    /// what the model is, in words
    #[serde(default)]
    pub description: String,
    /// the stages, run in order
    #[serde(rename = "stage")]
    pub stages: Vec<Stage>,
    /// the recipe file's folder (paths in stages are relative to it)
    #[serde(skip)]
    pub folder: PathBuf,
    /// the recipe file
    #[serde(skip)]
    pub file: PathBuf,
}

/// One stage of a recipe.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Stage {
    /// Train the six networks (`normalnet_net::training::train`).
    Networks(NetworksStage),
    /// Collect learned-switch rows on training pairs
    /// (`normalnet_net::switch_rows::trace`).
    SwitchRows(RowsStage),
    /// Fit a switch table to rows (`normalnet_net::switch_fit::fit`).
    SwitchFit(FitStage),
    /// Run the bundle made so far on a validation suite.
    Evaluate(EvaluateStage),
    /// Train a CNR model (`crate::cnr::train::train_from_config`): the
    /// model of a CNR recipe, which has no other kind of stage.
    Cnr(CnrStage),
}

/// Stage `cnr`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CnrStage {
    /// the stage's name
    pub name: String,
    /// the training config (relative to the recipe's folder): its sources,
    /// validation meshes and seed
    pub config: String,
    /// the training settings over their defaults; the seed is the
    /// config's (a `seed` here is refused)
    #[serde(default)]
    pub settings: crate::cnr::train::CnrTrainSettings,
}

/// Stage `networks`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NetworksStage {
    /// the stage's name (its folder `NN-name`)
    pub name: String,
    /// the training config (TOML, relative to the recipe's folder); empty
    /// with `bundle`
    #[serde(default)]
    pub config: String,
    /// an earlier `networks` stage whose bundle this one continues (the
    /// config's `init_from` is replaced by it); empty = the config's own
    #[serde(default)]
    pub continue_from: String,
    /// a bundle folder (relative to the recipe's folder) whose networks the
    /// stage takes as they are instead of training any (no `config`): a
    /// recipe that refits only the switch of a shipped bundle
    #[serde(default)]
    pub bundle: String,
    /// per network slot (six), the earlier `networks` stage whose network
    /// serves it, instead of `config` or `bundle`: a bundle that keeps
    /// some networks of one stage and takes others from another
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub slots: Vec<String>,
}

/// Stage `switch_rows`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RowsStage {
    /// the stage's name
    pub name: String,
    /// the `networks` stage whose bundle runs
    pub networks: String,
    /// a `switch_fit` stage: the vertices follow the switch made up to it
    /// (its main table and the late table fitted before it); empty = the
    /// network's output (the paper's form)
    #[serde(default)]
    pub follow: String,
    /// the pairs: clean sources and their noise, as training sources are
    /// written (paths under the data folder or `shape:SEED`)
    pub pairs: Vec<SourceSpec>,
    /// seed of the pairs' noise (seed + 1000·pair + copy, as training)
    #[serde(default = "default_rows_seed")]
    pub seed: u64,
    /// face count of procedural shapes
    #[serde(default = "default_shape_faces")]
    pub shape_faces: usize,
    /// normal-filtering iterations per run
    #[serde(default = "default_iterations")]
    pub iterations: usize,
    /// μ_g of the runs
    #[serde(default = "default_mu_g")]
    pub mu_g: f64,
    /// vertex updates per iteration
    #[serde(default = "default_vertex_iterations")]
    pub vertex_iterations: usize,
    /// the flat skip of the denoiser (degrees; 0 = off)
    #[serde(default)]
    pub flat_skip_deg: f64,
    /// rows of earlier iterations are not kept
    #[serde(default = "one")]
    pub min_iteration: usize,
    /// residual blocks in 8-bit integers, as the denoiser runs by default
    /// (where the CPU has AVX2)
    #[serde(default = "yes")]
    pub int8: bool,
    /// rows of faces folded in the mesh an iteration starts from are left
    /// out: rows for a table fitted with `network_on_folds = true`, which
    /// never decides those faces (`normalnet_net::switch_rows::TraceSettings::skip_folded`)
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub skip_folded: bool,
    /// the rows carry the CNR candidate (CNR's normals of each noisy input,
    /// `normalnet_net::switch::cnr_normals`), for a `switch_fit` with
    /// `cnr = true`
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cnr: bool,
}

/// Stage `switch_fit`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FitStage {
    /// the stage's name
    pub name: String,
    /// `switch_rows` stages whose rows it reads (a name given twice counts
    /// its rows twice); empty with `bundle`
    #[serde(default)]
    pub rows: Vec<String>,
    /// a bundle folder (relative to the recipe's folder) whose table (with
    /// `late`, its late table) the stage takes instead of fitting one (no
    /// `rows`): the path a refit's rows follow, or a table it keeps; a
    /// main table comes without the bundle's late and heavy tables
    #[serde(default)]
    pub bundle: String,
    /// hidden units
    #[serde(default = "default_hidden")]
    pub hidden: usize,
    /// passes over the rows
    #[serde(default = "default_epochs")]
    pub epochs: usize,
    /// shuffling and initialisation
    #[serde(default = "one_u64")]
    pub seed: u64,
    /// the iteration feature's clamp
    #[serde(default = "default_max_iteration")]
    pub max_iteration: usize,
    /// rows of earlier iterations are left out
    #[serde(default = "one")]
    pub min_iteration: usize,
    /// rows of later iterations are left out (0 = none): the first
    /// iterations of long runs
    #[serde(default)]
    pub last_iteration: usize,
    /// a late table (`[switch.late]`, the iterations after the main
    /// table's clamp) instead of the main one
    #[serde(default)]
    pub late: bool,
    /// a table for noisy runs (`[switch.heavy]`) instead of the main one:
    /// runs whose noise level in iteration 1 (the switch's feature 9,
    /// radians) is at least this use it in place of the main table
    /// (`normalnet_net::switch::HeavyTable`); it takes the main table's
    /// late table and fold rule
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heavy_from: Option<f64>,
    /// the table takes the network's output on folded faces
    /// (`normalnet_net::switch::SwitchWeights::network_on_folds`): `true`
    /// turns the rule on, `false` off; unset, a fitted table has it off and
    /// a table taken from a bundle keeps the bundle's. Main tables only
    /// (the main table's rule covers the late table's iterations).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network_on_folds: Option<bool>,
    /// a table with the CNR candidate (its rows stages need `cnr = true`)
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cnr: bool,
    /// written into the table's `notes`
    #[serde(default)]
    pub notes: String,
}

impl FitStage {
    /// Whether the stage makes a main table (not a late or a heavy one).
    pub fn is_main(&self) -> bool {
        !self.late && self.heavy_from.is_none()
    }
}

/// Stage `evaluate`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluateStage {
    /// the stage's name
    pub name: String,
    /// the validation suite (relative to the recipe's folder)
    pub suite: String,
    /// NormalNet parameters laid over `normalnet bench`'s
    /// ([`evaluate_params`])
    #[serde(default)]
    pub params: serde_json::Map<String, serde_json::Value>,
}

/// Appends the length and the bytes of `file` to `bytes`.
fn append_file(bytes: &mut Vec<u8>, file: &Path) -> Result<(), DenoiseError> {
    let content = std::fs::read(file).map_err(|e| recipe_error(file, format!("reading: {e}")))?;
    bytes.extend_from_slice(&(content.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&content);
    Ok(())
}

fn default_rows_seed() -> u64 {
    5000
}
fn default_shape_faces() -> usize {
    2000
}
fn default_iterations() -> usize {
    10
}
fn default_mu_g() -> f64 {
    0.35
}
fn default_vertex_iterations() -> usize {
    20
}
fn default_hidden() -> usize {
    32
}
fn default_epochs() -> usize {
    40
}
fn default_max_iteration() -> usize {
    normalnet_net::switch::DEFAULT_MAX_ITERATION
}
fn one() -> usize {
    1
}
fn one_u64() -> u64 {
    1
}
fn yes() -> bool {
    true
}

impl Stage {
    /// The stage's name.
    pub fn name(&self) -> &str {
        match self {
            Stage::Networks(s) => &s.name,
            Stage::SwitchRows(s) => &s.name,
            Stage::SwitchFit(s) => &s.name,
            Stage::Evaluate(s) => &s.name,
            Stage::Cnr(s) => &s.name,
        }
    }

    /// The stage's kind as written in the recipe.
    pub fn kind(&self) -> &'static str {
        match self {
            Stage::Networks(_) => "networks",
            Stage::SwitchRows(_) => "switch_rows",
            Stage::SwitchFit(_) => "switch_fit",
            Stage::Evaluate(_) => "evaluate",
            Stage::Cnr(_) => "cnr",
        }
    }
}

impl Recipe {
    /// Reads and checks a recipe ([`Recipe::parse`]).
    ///
    /// # Errors
    /// [`DenoiseError::Recipe`] naming the file and the stage.
    pub fn load(file: &Path) -> Result<Recipe, DenoiseError> {
        let text = std::fs::read_to_string(file).map_err(|e| recipe_error(file, e.to_string()))?;
        Recipe::parse(&text, file)
    }

    /// Parses and checks a recipe's text; `file` places its relative paths.
    ///
    /// # Errors
    /// [`DenoiseError::Recipe`]: invalid TOML, no `networks` stage, stage
    /// names empty, unsafe or used twice, references to a stage that is
    /// not an earlier one of the right kind, unreadable or invalid training
    /// configs and suites, test data among the pairs, values out of range.
    pub fn parse(text: &str, file: &Path) -> Result<Recipe, DenoiseError> {
        let mut recipe: Recipe =
            toml::from_str(text).map_err(|e| recipe_error(file, e.to_string()))?;
        recipe.file = file.to_path_buf();
        recipe.folder = file
            .parent()
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        recipe.check()?;
        Ok(recipe)
    }

    /// A path of a stage, relative to the recipe's folder.
    pub fn path(&self, relative: &str) -> PathBuf {
        self.folder.join(relative)
    }

    /// The stage folder of stage `i` inside `out`.
    pub fn stage_dir(&self, out: &Path, i: usize) -> PathBuf {
        out.join("stages")
            .join(format!("{:02}-{}", i + 1, self.stages[i].name()))
    }

    /// Index of the stage called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.stages.iter().position(|s| s.name() == name)
    }

    /// The training config of a `networks` stage (its `init_from` not yet
    /// replaced).
    ///
    /// # Errors
    /// An unreadable or invalid config, naming the stage.
    pub fn train_config(&self, stage: &NetworksStage) -> Result<TrainConfig, DenoiseError> {
        self.read_config(&stage.name, &stage.config)
    }

    /// The training config `config` (relative) of stage `name`.
    fn read_config(&self, name: &str, config: &str) -> Result<TrainConfig, DenoiseError> {
        TrainConfig::read(&self.path(config)).map_err(|e| self.stage_error(name, e.to_string()))
    }

    /// The training config of a `cnr` stage.
    ///
    /// # Errors
    /// An unreadable or invalid config, naming the stage.
    pub fn cnr_config(&self, stage: &CnrStage) -> Result<TrainConfig, DenoiseError> {
        self.read_config(&stage.name, &stage.config)
    }

    /// Whether the recipe makes a CNR model (a `cnr` stage) rather than a
    /// NormalNet bundle.
    pub fn makes_cnr(&self) -> bool {
        self.stages.iter().any(|s| matches!(s, Stage::Cnr(_)))
    }

    /// FNV-1a 64 (hex) of the recipe's text and of every file it names
    /// (training configs, suites, bundles): the recipe's record in the
    /// bundle it makes.
    ///
    /// # Errors
    /// A named file that cannot be read.
    pub fn hash(&self) -> Result<String, DenoiseError> {
        let mut files = vec![self.file.clone()];
        for stage in &self.stages {
            files.extend(self.stage_files(stage));
        }
        let mut bytes = Vec::new();
        for f in &files {
            append_file(&mut bytes, f)?;
        }
        Ok(format!("{:016x}", normalnet_net::bundle::fnv1a(&bytes)))
    }

    /// Per stage, FNV-1a 64 (hex) of the previous stage's hash, the
    /// stage's definition (as parsed: comments and layout do not count)
    /// and every file it names. A stage's work in an output folder is kept
    /// only under the same hash, so an edit reruns the stage it touches
    /// and every later one, never an earlier one.
    ///
    /// # Errors
    /// A named file that cannot be read.
    pub fn stage_hashes(&self) -> Result<Vec<String>, DenoiseError> {
        let mut previous = String::new();
        let mut hashes = Vec::with_capacity(self.stages.len());
        for stage in &self.stages {
            let mut bytes = previous.into_bytes();
            let definition = serde_json::to_vec(stage)
                .map_err(|e| self.stage_error(stage.name(), e.to_string()))?;
            bytes.extend_from_slice(&(definition.len() as u64).to_le_bytes());
            bytes.extend_from_slice(&definition);
            if let Stage::Evaluate(s) = stage {
                // what it runs with, so a change of the settings reruns it
                let params = serde_json::to_vec(&evaluate_params(&s.params))
                    .map_err(|e| self.stage_error(stage.name(), e.to_string()))?;
                bytes.extend_from_slice(&params);
            }
            for f in self.stage_files(stage) {
                append_file(&mut bytes, &f)?;
            }
            previous = format!("{:016x}", normalnet_net::bundle::fnv1a(&bytes));
            hashes.push(previous.clone());
        }
        Ok(hashes)
    }

    /// The files a stage names: its training config, suite, or the bundle
    /// it takes networks or a table from.
    fn stage_files(&self, stage: &Stage) -> Vec<PathBuf> {
        match stage {
            Stage::Networks(s) if !s.bundle.is_empty() => {
                let bundle = self.path(&s.bundle);
                std::iter::once(bundle.join(normalnet_net::bundle::MANIFEST))
                    .chain((0..6).map(|i| bundle.join(normalnet_net::bundle::network_file(i))))
                    .collect()
            }
            Stage::SwitchFit(s) if !s.bundle.is_empty() => {
                vec![self.path(&s.bundle).join(normalnet_net::bundle::MANIFEST)]
            }
            Stage::Networks(s) if !s.slots.is_empty() => Vec::new(),
            Stage::Networks(s) => vec![self.path(&s.config)],
            Stage::Cnr(s) => vec![self.path(&s.config)],
            Stage::Evaluate(s) => vec![self.path(&s.suite)],
            Stage::SwitchRows(_) | Stage::SwitchFit(_) => Vec::new(),
        }
    }

    fn stage_error(&self, stage: &str, message: String) -> DenoiseError {
        recipe_error(&self.file, format!("stage {stage:?}: {message}"))
    }

    /// The index of the earlier stage `name` refers to, checked to be of
    /// `kind`.
    fn earlier(
        &self,
        at: usize,
        name: &str,
        kind: &str,
        what: &str,
    ) -> Result<usize, DenoiseError> {
        let me = self.stages[at].name();
        match self.index_of(name) {
            Some(i) if i < at && self.stages[i].kind() == kind => Ok(i),
            Some(i) if i < at => Err(self.stage_error(
                me,
                format!(
                    "{what} {name:?} is a {} stage, expected {kind}",
                    self.stages[i].kind()
                ),
            )),
            _ => Err(self.stage_error(me, format!("{what} {name:?} is no earlier {kind} stage"))),
        }
    }

    fn check(&self) -> Result<(), DenoiseError> {
        if self.stages.is_empty() {
            return Err(recipe_error(&self.file, "no [[stage]] entries".into()));
        }
        for (i, stage) in self.stages.iter().enumerate() {
            let n = stage.name();
            if n.is_empty()
                || n.starts_with('.')
                || !n
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
            {
                return Err(
                    self.stage_error(n, "a name is letters, digits, '.', '_' and '-' only".into())
                );
            }
            if self.stages[..i].iter().any(|s| s.name() == n) {
                return Err(self.stage_error(n, "the name is used twice".into()));
            }
            self.check_stage(i)?;
        }
        self.check_held_out()?;
        let networks = self.stages.iter().any(|s| matches!(s, Stage::Networks(_)));
        if self.makes_cnr() {
            if let Some(other) = self.stages.iter().find(|s| !matches!(s, Stage::Cnr(_))) {
                return Err(self.stage_error(
                    other.name(),
                    format!(
                        "a CNR recipe (it has a cnr stage) has only cnr stages, not {}",
                        other.kind()
                    ),
                ));
            }
        } else if !networks {
            return Err(recipe_error(
                &self.file,
                "no networks stage (a bundle needs one) and no cnr stage".into(),
            ));
        }
        Ok(())
    }

    /// No training source (networks' sources, switch pairs) is a source of
    /// a suite the recipe evaluates on: selection data stays out of
    /// training.
    fn check_held_out(&self) -> Result<(), DenoiseError> {
        let mut held_out = Vec::new();
        for stage in &self.stages {
            if let Stage::Evaluate(e) = stage {
                let suite = crate::suite::Suite::load(&self.path(&e.suite))?;
                held_out.extend(suite.pairs.into_iter().map(|p| (p.source, e.suite.clone())));
            }
        }
        for stage in &self.stages {
            let sources = match stage {
                Stage::Networks(s) if !s.bundle.is_empty() || !s.slots.is_empty() => continue,
                Stage::Networks(s) => self.train_config(s)?.sources,
                Stage::Cnr(s) => self.cnr_config(s)?.sources,
                Stage::SwitchRows(s) => s.pairs.clone(),
                _ => continue,
            };
            for src in sources {
                if let Some((_, suite)) = held_out.iter().find(|(h, _)| *h == src.mesh) {
                    return Err(self.stage_error(
                        stage.name(),
                        format!(
                            "{} is a pair of the validation suite {suite}: a recipe never trains on what selects it",
                            src.mesh
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The manifest of the bundle folder `bundle` (relative) that stage `i`
    /// takes its networks or table from.
    ///
    /// # Errors
    /// A folder without a readable manifest, naming the stage.
    pub(super) fn bundle_manifest(
        &self,
        i: usize,
        bundle: &str,
    ) -> Result<normalnet_net::bundle::Manifest, DenoiseError> {
        let file = self.path(bundle).join(normalnet_net::bundle::MANIFEST);
        normalnet_net::bundle::Manifest::read(&file)
            .map_err(|e| self.stage_error(self.stages[i].name(), format!("bundle: {e}")))
    }

    /// Whether a `switch_fit` stage before stage `i` makes a main table.
    fn main_table_before(&self, i: usize) -> bool {
        self.stages[..i]
            .iter()
            .any(|t| matches!(t, Stage::SwitchFit(f) if f.is_main()))
    }

    /// Checks stage `i` alone (its values, its references to earlier
    /// stages, the files it names).
    fn check_stage(&self, i: usize) -> Result<(), DenoiseError> {
        match &self.stages[i] {
            Stage::Networks(s) if !s.slots.is_empty() => self.check_slots(i, s),
            Stage::Networks(s) if !s.bundle.is_empty() => self.check_taken_networks(i, s),
            Stage::Networks(s) => self.check_networks(i, s),
            Stage::SwitchRows(s) => self.check_rows(i, s),
            Stage::SwitchFit(s) if !s.bundle.is_empty() => self.check_taken_table(i, s),
            Stage::SwitchFit(s) => self.check_fit(i, s),
            Stage::Cnr(s) => self.check_cnr(s),
            Stage::Evaluate(s) => self.check_evaluate(s),
        }
    }

    fn check_taken_networks(&self, i: usize, s: &NetworksStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        if !s.config.is_empty() || !s.continue_from.is_empty() {
            return Err(bad(
                "a stage takes its networks from `bundle` or trains them by `config`, not both"
                    .into(),
            ));
        }
        self.bundle_manifest(i, &s.bundle)?;
        Ok(())
    }

    fn check_slots(&self, i: usize, s: &NetworksStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        if !s.config.is_empty() || !s.continue_from.is_empty() || !s.bundle.is_empty() {
            return Err(bad(
                "a stage takes its networks from `slots`, `bundle` or `config`, one of them".into(),
            ));
        }
        if s.slots.len() != normalnet_net::bundle::INTERVALS.len() {
            return Err(bad(format!(
                "slots names {} stages, one per network: {}",
                s.slots.len(),
                normalnet_net::bundle::INTERVALS.len()
            )));
        }
        for from in &s.slots {
            self.earlier(i, from, "networks", "slots")?;
        }
        Ok(())
    }

    fn check_networks(&self, i: usize, s: &NetworksStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        let config = self.train_config(s)?;
        if config.stop_after < 6 {
            return Err(bad(format!(
                "the config trains {} of 6 networks (stop_after): no bundle",
                config.stop_after
            )));
        }
        if !s.continue_from.is_empty() {
            self.earlier(i, &s.continue_from, "networks", "continue_from")?;
        }
        Ok(())
    }

    fn check_rows(&self, i: usize, s: &RowsStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        self.earlier(i, &s.networks, "networks", "networks")?;
        if !s.follow.is_empty() {
            self.earlier(i, &s.follow, "switch_fit", "follow")?;
        }
        if s.pairs.is_empty() {
            return Err(bad("no pairs".into()));
        }
        if s.iterations == 0 || s.vertex_iterations == 0 || s.min_iteration == 0 {
            return Err(bad(
                "iterations, vertex_iterations and min_iteration must be positive".into(),
            ));
        }
        if s.min_iteration > s.iterations {
            return Err(bad(format!(
                "min_iteration {} > iterations {}: no rows",
                s.min_iteration, s.iterations
            )));
        }
        if !(s.mu_g > 0.0 && s.mu_g < 10.0 && (0.0..=90.0).contains(&s.flat_skip_deg)) {
            return Err(bad(
                "mu_g must lie in (0, 10), flat_skip_deg in [0, 90]".into()
            ));
        }
        // the pairs are training data: TrainConfig's checks refuse test models
        stages::rows_config(s)
            .validate(&self.file)
            .map_err(|e| bad(e.to_string()))?;
        Ok(())
    }

    /// The fold rule belongs to main tables; a late or heavy table needs
    /// an earlier main one; a table is one of the three.
    fn check_table_kind(&self, i: usize, s: &FitStage) -> Result<(), DenoiseError> {
        let bad = |message: &str| Err(self.stage_error(&s.name, message.into()));
        if s.late && s.heavy_from.is_some() {
            return bad("a table is late or heavy, not both");
        }
        if !s.is_main() && s.network_on_folds.is_some() {
            return bad(
                "network_on_folds is set on the main table, whose rule covers the late and heavy tables' runs",
            );
        }
        if s.heavy_from.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
            return bad("heavy_from must be a positive angle (radians)");
        }
        if !s.is_main() && !self.main_table_before(i) {
            let kind = if s.late { "late" } else { "heavy" };
            return bad(&format!(
                "a {kind} table needs an earlier main switch_fit stage"
            ));
        }
        Ok(())
    }

    fn check_taken_table(&self, i: usize, s: &FitStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        self.check_table_kind(i, s)?;
        if s.heavy_from.is_some() {
            return Err(bad(
                "a heavy table is fitted on `rows`; a bundle's is not taken".into(),
            ));
        }
        if s.cnr {
            return Err(bad(
                "cnr = true fits a table with the CNR candidate on `rows`; a bundle's table is taken as it is".into(),
            ));
        }
        if !s.rows.is_empty() {
            return Err(bad(
                "a stage takes its table from `bundle` or fits it on `rows`, not both".into(),
            ));
        }
        let switch = self.bundle_manifest(i, &s.bundle)?.switch;
        let table = match (switch, s.late) {
            (Some(main), false) => Some(main),
            (Some(main), true) => main.late.map(|late| *late),
            (None, _) => None,
        };
        if table.is_none() {
            return Err(bad(format!(
                "bundle {:?} has no {} switch table",
                s.bundle,
                if s.late { "late" } else { "main" }
            )));
        }
        Ok(())
    }

    fn check_fit(&self, i: usize, s: &FitStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        self.check_table_kind(i, s)?;
        if s.rows.is_empty() {
            return Err(bad("no rows stages".into()));
        }
        for r in &s.rows {
            self.earlier(i, r, "switch_rows", "rows")?;
            let traced_with_cnr = matches!(
                self.index_of(r).map(|j| &self.stages[j]),
                Some(Stage::SwitchRows(rows)) if rows.cnr
            );
            if s.cnr && !traced_with_cnr {
                return Err(bad(format!(
                    "a table with the CNR candidate (cnr = true) needs rows traced with it: give stage {r:?} cnr = true"
                )));
            }
        }
        if s.hidden == 0 || s.epochs == 0 || s.max_iteration == 0 || s.min_iteration == 0 {
            return Err(bad(
                "hidden, epochs, max_iteration and min_iteration must be positive".into(),
            ));
        }
        if s.last_iteration > 0 && s.last_iteration < s.min_iteration {
            return Err(bad(format!(
                "last_iteration {} < min_iteration {}: no rows",
                s.last_iteration, s.min_iteration
            )));
        }
        if s.late && s.min_iteration <= 1 {
            return Err(bad(
                "a late table is fitted on the iterations after the main table's clamp: set min_iteration".into(),
            ));
        }
        Ok(())
    }

    fn check_cnr(&self, s: &CnrStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        self.cnr_config(s)?;
        s.settings
            .validate()
            .map_err(|e| bad(format!("settings: {e}")))?;
        if s.settings.seed != crate::cnr::train::CnrTrainSettings::default().seed {
            return Err(bad(
                "settings: no seed here, the training config's seed is used".into(),
            ));
        }
        Ok(())
    }

    fn check_evaluate(&self, s: &EvaluateStage) -> Result<(), DenoiseError> {
        let bad = |message: String| self.stage_error(&s.name, message);
        crate::suite::Suite::load(&self.path(&s.suite)).map_err(|e| bad(e.to_string()))?;
        let params: crate::Params = s.params.clone();
        if params.contains_key("model") {
            return Err(bad("params: the model is the recipe's bundle".into()));
        }
        Ok(())
    }
}

fn recipe_error(path: &Path, message: String) -> DenoiseError {
    DenoiseError::Recipe {
        path: path.to_path_buf(),
        message,
    }
}

#[cfg(test)]
mod tests;
