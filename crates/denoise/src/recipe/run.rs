//! Running a recipe: its stages in order, each in its folder, skipped when
//! done; then the bundle, assembled in the output folder.

use std::path::Path;

use normalnet_mesh::Progress;
use normalnet_net::bundle::{Evaluation, MANIFEST, Manifest, RecipeInfo, network_file};
use serde::{Deserialize, Serialize};

use super::evaluate::{evaluate, read_evaluation};
use super::stages::{self, write_file};
use super::{Recipe, Stage, recipe_error};
use crate::DenoiseError;

/// The file that ties an output folder to one recipe (`OUT/recipe-run.toml`).
const RUN_FILE: &str = "recipe-run.toml";
/// A stage is done when its folder holds this file ([`StageMark`]).
const DONE: &str = "DONE";
/// Written when a stage starts ([`StageMark`]): whose work the folder holds.
const STARTED: &str = "STARTED";

/// What ties an output folder to a recipe.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
struct RunFile {
    recipe: String,
    /// the recipe's `name` (absent in folders of older builds: the file's stem)
    #[serde(default, skip_serializing_if = "String::is_empty")]
    name: String,
    hash: String,
}

/// A stage folder's `DONE` and `STARTED`: the stage and the hash of its
/// definition ([`Recipe::stage_hashes`]).
#[derive(Debug, Serialize, Deserialize, PartialEq)]
struct StageMark {
    stage: String,
    hash: String,
}

/// Where a stage's folder stands against the recipe.
#[derive(Debug, PartialEq)]
enum StageState {
    /// done under the same definition
    Done,
    /// started under the same definition (or nothing there yet)
    Continue,
    /// holds the work of another definition: cleared and run again
    Changed,
}

/// What a finished recipe run gives.
#[derive(Debug)]
pub struct RecipeOutcome {
    /// the bundle's manifest (as written to `OUT/manifest.toml`); `None`
    /// for a CNR recipe, whose model is `OUT/cnr.json`
    pub manifest: Option<Manifest>,
    /// per stage: its kind and name, and whether this call ran it (false:
    /// it was done by an earlier call)
    pub stages: Vec<(String, bool)>,
}

/// Runs the recipe in `file` into `out`: every stage not yet done, then the
/// bundle (`OUT/net1..6.safetensors`, `OUT/manifest.toml`, written last),
/// or for a CNR recipe the model (`OUT/cnr.json`).
/// Run again on the same folder it continues where it stopped; after an
/// edit of the recipe (or of a file it names) the stages the edit changes
/// and every later one run again from scratch ([`Recipe::stage_hashes`]),
/// the earlier ones are kept. A folder of another recipe is refused.
///
/// # Errors
/// [`DenoiseError::Recipe`] naming the recipe or the stage's folder; the
/// errors of the stages (training, meshes, suites).
pub fn run(
    file: &Path,
    out: &Path,
    progress: &dyn Progress,
) -> Result<RecipeOutcome, DenoiseError> {
    let recipe = Recipe::load(file)?;
    let hash = recipe.hash()?;
    let marks = stage_marks(&recipe)?;
    let unchanged = claim(&recipe, &hash, out)?;
    let cache = out.join("validation-cache");
    let mut ran = Vec::new();
    for (i, (stage, mark)) in recipe.stages.iter().zip(&marks).enumerate() {
        let dir = recipe.stage_dir(out, i);
        let label = mark.stage.clone();
        match stage_state(&dir, mark, unchanged)? {
            StageState::Done => {
                // folders of older builds: their DONE gains the hash
                write_mark(&dir.join(DONE), mark)?;
                ran.push((label, false));
                continue;
            }
            StageState::Changed => {
                progress.message(&format!(
                    "stage {}/{}: {label} changed since its folder was made: run again",
                    i + 1,
                    recipe.stages.len()
                ));
                std::fs::remove_dir_all(&dir).map_err(|e| recipe_error(&dir, e.to_string()))?;
            }
            StageState::Continue => {}
        }
        progress.message(&format!("stage {}/{}: {label}", i + 1, recipe.stages.len()));
        std::fs::create_dir_all(&dir).map_err(|e| recipe_error(&dir, e.to_string()))?;
        write_mark(&dir.join(STARTED), mark)?;
        match stage {
            Stage::Networks(s) => stages::networks(&recipe, s, out, &dir, progress)?,
            Stage::SwitchRows(s) => stages::switch_rows(&recipe, s, out, &dir, progress)?,
            Stage::SwitchFit(s) => stages::switch_fit(&recipe, s, out, &dir, progress)?,
            Stage::Cnr(s) => stages::cnr(&recipe, s, &dir, progress)?,
            Stage::Evaluate(s) => {
                let bundle = dir.join("bundle");
                assemble(&recipe, &hash, out, i, &bundle)?;
                evaluate(&recipe, s, &bundle, &cache, &dir, progress)?;
            }
        }
        write_mark(&dir.join(DONE), mark)?;
        ran.push((label, true));
    }
    let manifest = if recipe.makes_cnr() {
        assemble_cnr(&recipe, &hash, out)?;
        None
    } else {
        Some(assemble(&recipe, &hash, out, recipe.stages.len(), out)?)
    };
    Ok(RecipeOutcome {
        manifest,
        stages: ran,
    })
}

/// Ties `out` to the recipe: refuses a folder of another recipe (another
/// `name`) and records this one. Returns whether the folder was made by
/// this recipe as it is now (same hash): then stage marks of older builds,
/// which carry no hash, are trusted.
fn claim(recipe: &Recipe, hash: &str, out: &Path) -> Result<bool, DenoiseError> {
    let unchanged = check_claim(recipe, hash, out)?;
    std::fs::create_dir_all(out).map_err(|e| recipe_error(out, e.to_string()))?;
    let path = out.join(RUN_FILE);
    let mine = run_file(recipe, hash);
    let text = toml::to_string(&mine).map_err(|e| recipe_error(&path, e.to_string()))?;
    write_file(&path, text.as_bytes())?;
    Ok(unchanged)
}

fn run_file(recipe: &Recipe, hash: &str) -> RunFile {
    RunFile {
        recipe: recipe.file.display().to_string(),
        name: recipe.name.clone(),
        hash: hash.to_string(),
    }
}

/// [`claim`] without writing anything.
fn check_claim(recipe: &Recipe, hash: &str, out: &Path) -> Result<bool, DenoiseError> {
    let path = out.join(RUN_FILE);
    let mine = run_file(recipe, hash);
    match std::fs::read_to_string(&path) {
        Ok(text) => {
            let theirs: RunFile =
                toml::from_str(&text).map_err(|e| recipe_error(&path, e.to_string()))?;
            let name = if theirs.name.is_empty() {
                Path::new(&theirs.recipe)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            } else {
                theirs.name.clone()
            };
            if name != mine.name {
                return Err(recipe_error(
                    out,
                    format!(
                        "holds a run of recipe {name:?} ({}), not of {:?} ({}): choose another --out or remove this one",
                        theirs.recipe, mine.name, mine.recipe
                    ),
                ));
            }
            Ok(theirs.hash == mine.hash)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(true),
        Err(e) => Err(recipe_error(&path, e.to_string())),
    }
}

/// What [`run`] would do with each stage of the recipe in `file` on the
/// folder `out`, without doing anything: per stage its kind and name and
/// `done` (kept), `continue` (started under this definition: resumes),
/// `run` (not started) or `changed` (holds the work of another definition:
/// cleared and run again).
///
/// # Errors
/// As [`run`] before its first stage: the recipe, the files it names, a
/// folder of another recipe.
pub fn plan(file: &Path, out: &Path) -> Result<Vec<(String, &'static str)>, DenoiseError> {
    let recipe = Recipe::load(file)?;
    let unchanged = check_claim(&recipe, &recipe.hash()?, out)?;
    let mut plan = Vec::with_capacity(recipe.stages.len());
    for (i, mark) in stage_marks(&recipe)?.into_iter().enumerate() {
        let dir = recipe.stage_dir(out, i);
        let what = match stage_state(&dir, &mark, unchanged)? {
            StageState::Done => "done",
            StageState::Changed => "changed",
            StageState::Continue if dir.exists() => "continue",
            StageState::Continue => "run",
        };
        plan.push((mark.stage, what));
    }
    Ok(plan)
}

/// Per stage its mark: `kind name` and the hash of its definition.
fn stage_marks(recipe: &Recipe) -> Result<Vec<StageMark>, DenoiseError> {
    Ok(recipe
        .stages
        .iter()
        .zip(recipe.stage_hashes()?)
        .map(|(stage, hash)| StageMark {
            stage: format!("{} {}", stage.kind(), stage.name()),
            hash,
        })
        .collect())
}

/// Where the folder `dir` of a stage whose definition is `mark` stands.
/// Marks without a hash (older builds) count as this definition's when the
/// whole recipe is `unchanged`.
fn stage_state(dir: &Path, mark: &StageMark, unchanged: bool) -> Result<StageState, DenoiseError> {
    let read = |name: &str| -> Result<Option<bool>, DenoiseError> {
        let path = dir.join(name);
        match std::fs::read_to_string(&path) {
            Ok(text) => Ok(Some(match toml::from_str::<StageMark>(&text) {
                Ok(theirs) => theirs == *mark,
                Err(_) => unchanged,
            })),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(recipe_error(&path, e.to_string())),
        }
    };
    Ok(match (read(DONE)?, read(STARTED)?) {
        (Some(true), _) => StageState::Done,
        (Some(false), _) | (None, Some(false)) => StageState::Changed,
        (None, Some(true)) => StageState::Continue,
        // work of an older build, or none
        (None, None) if unchanged || !dir.exists() => StageState::Continue,
        (None, None) => StageState::Changed,
    })
}

fn write_mark(path: &Path, mark: &StageMark) -> Result<(), DenoiseError> {
    let text = toml::to_string(mark).map_err(|e| recipe_error(path, e.to_string()))?;
    write_file(path, text.as_bytes())
}

/// `OUT/cnr.json`: the last `cnr` stage's model, its training notes ending
/// with the recipe, its hash and the commit.
fn assemble_cnr(recipe: &Recipe, hash: &str, out: &Path) -> Result<(), DenoiseError> {
    let last = (0..recipe.stages.len())
        .rev()
        .find(|&i| recipe.stages[i].kind() == "cnr")
        .expect("a CNR recipe has a cnr stage");
    let source = recipe.stage_dir(out, last).join(stages::CNR_FILE);
    let text =
        std::fs::read_to_string(&source).map_err(|e| recipe_error(&source, e.to_string()))?;
    let mut model = crate::cnr::model::CnrModel::parse(&text, &source.display().to_string())
        .map_err(|e| recipe_error(&source, e))?;
    model.training.push(format!(
        "recipe {} (hash {hash}, commit {})",
        recipe.file.display(),
        normalnet_net::bundle::commit()
    ));
    model.write(&out.join(stages::CNR_FILE))?;
    Ok(())
}

/// The bundle made by the stages before `upto`, written to `target`: the
/// last `networks` stage's networks and manifest, the switch of the
/// `switch_fit` stages, the figures of the last `evaluate` stage, and the
/// recipe's record. The manifest is written last.
fn assemble(
    recipe: &Recipe,
    hash: &str,
    out: &Path,
    upto: usize,
    target: &Path,
) -> Result<Manifest, DenoiseError> {
    let last = |kind: &str| (0..upto).rev().find(|&i| recipe.stages[i].kind() == kind);
    let networks = last("networks")
        .ok_or_else(|| recipe_error(&recipe.file, "no networks stage before this one".into()))?;
    let source = recipe.stage_dir(out, networks);
    std::fs::create_dir_all(target).map_err(|e| recipe_error(target, e.to_string()))?;
    let mut manifest = Manifest::read(&source.join(MANIFEST))?;
    for i in 0..manifest.networks.len() {
        let name = network_file(i);
        if source != target {
            std::fs::copy(source.join(&name), target.join(&name))
                .map_err(|e| recipe_error(&target.join(&name), e.to_string()))?;
        }
    }
    manifest.switch = match last("switch_fit") {
        Some(i) => stages::switch_upto(recipe, out, i)?,
        None => None,
    };
    manifest.evaluation = match last("evaluate") {
        Some(i) => Some(read_evaluation(&recipe.stage_dir(out, i))?),
        None => None::<Evaluation>,
    };
    // the output folder is this machine's: the manifest names it OUT
    let here = out.display().to_string();
    manifest.training.notes = manifest.training.notes.replace(&here, "OUT");
    manifest.recipe = Some(RecipeInfo {
        recipe: recipe.file.display().to_string(),
        hash: hash.to_string(),
        commit: normalnet_net::bundle::commit(),
        stages: recipe
            .stages
            .iter()
            .map(|s| format!("{} {}", s.kind(), s.name()))
            .collect(),
    });
    manifest.write(&target.join(MANIFEST))?;
    Ok(manifest)
}
