//! What each kind of recipe stage does in its folder. A stage that stops
//! part way is run again from its start, except where it says otherwise
//! (`networks` resumes from the training checkpoint, `switch_rows` keeps
//! the pairs it finished).

use std::path::{Path, PathBuf};

use normalnet_mesh::Progress;
use normalnet_net::Bundle;
use normalnet_net::bundle::{MANIFEST, Manifest, network_file};
use normalnet_net::switch::{HeavyTable, SwitchWeights};
use normalnet_net::switch_fit::{FitParams, ROW_LEN, fit};
use normalnet_net::switch_rows::{TracePath, TraceSettings, read_rows, trace, write_rows};
use normalnet_net::training::{TrainConfig, noisy_pairs, train};
use serde::{Deserialize, Serialize};

use super::{CnrStage, FitStage, NetworksStage, Recipe, RowsStage, recipe_error};
use crate::DenoiseError;

/// The file a `switch_fit` stage writes its table to.
pub(super) const SWITCH_FILE: &str = "switch.toml";

/// A training config carrying a rows stage's pairs, so that they are made
/// (and checked against the test data) exactly as training sources are.
pub(super) fn rows_config(stage: &RowsStage) -> TrainConfig {
    TrainConfig {
        sources: stage.pairs.clone(),
        shape_faces: stage.shape_faces,
        ..TrainConfig::default()
    }
}

/// `networks`: the six networks, trained (or continued) into `dir`.
pub(super) fn networks(
    recipe: &Recipe,
    stage: &NetworksStage,
    out: &Path,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<(), DenoiseError> {
    if !stage.slots.is_empty() {
        return mix_networks(recipe, stage, out, dir);
    }
    if !stage.bundle.is_empty() {
        return copy_networks(recipe, stage, dir);
    }
    let mut config = recipe.train_config(stage)?;
    if !stage.continue_from.is_empty() {
        let from = recipe
            .index_of(&stage.continue_from)
            .expect("checked by Recipe::check");
        config.init_from = recipe.stage_dir(out, from).display().to_string();
    }
    let resume = dir.join("state.toml").is_file();
    train(&config, dir, resume, progress)
        .map_err(|e| recipe_error(dir, format!("stage {:?}: {e}", stage.name)))?;
    Ok(())
}

/// `networks` with `bundle`: that bundle's manifest and networks, copied
/// into `dir` as they are.
fn copy_networks(recipe: &Recipe, stage: &NetworksStage, dir: &Path) -> Result<(), DenoiseError> {
    let i = recipe.index_of(&stage.name).expect("a stage of the recipe");
    let manifest = recipe.bundle_manifest(i, &stage.bundle)?;
    let from = recipe.path(&stage.bundle);
    for k in 0..manifest.networks.len() {
        copy_network(&from, k, dir)?;
    }
    manifest.write(&dir.join(MANIFEST))?;
    Ok(())
}

/// Network `k`'s weight file of the bundle folder `from`, copied into `dir`.
fn copy_network(from: &Path, k: usize, dir: &Path) -> Result<(), DenoiseError> {
    let name = network_file(k);
    let bytes = std::fs::read(from.join(&name))
        .map_err(|e| recipe_error(&from.join(&name), format!("reading: {e}")))?;
    write_file(&dir.join(&name), &bytes)
}

/// `networks` with `slots`: per slot the network of the named earlier
/// stage, with its manifest entry; the rest of the manifest is the first
/// slot's stage's, its notes saying where each network came from. The
/// stages must agree on everything the networks are read with (preset,
/// architecture, voxel grid, outputs, intervals, int8 ranges).
fn mix_networks(
    recipe: &Recipe,
    stage: &NetworksStage,
    out: &Path,
    dir: &Path,
) -> Result<(), DenoiseError> {
    let fail = |m: String| recipe_error(dir, format!("stage {:?}: {m}", stage.name));
    let source = |name: &str| recipe.stage_dir(out, recipe.index_of(name).expect("checked"));
    let manifests = stage
        .slots
        .iter()
        .map(|name| Manifest::read(&source(name).join(MANIFEST)))
        .collect::<Result<Vec<_>, _>>()?;
    let mut manifest = manifests[0].clone();
    let reads = |m: &Manifest| {
        (
            m.preset.clone(),
            m.model.clone(),
            m.voxel,
            m.mu_gs.clone(),
            m.intervals.clone(),
            m.int8_range,
        )
    };
    for (k, (name, m)) in stage.slots.iter().zip(&manifests).enumerate() {
        if reads(m) != reads(&manifest) {
            return Err(fail(format!(
                "slot {}: stage {name:?}'s networks are not read as stage {:?}'s (preset, architecture, voxel grid, outputs, intervals or int8 ranges differ)",
                k + 1,
                stage.slots[0]
            )));
        }
        copy_network(&source(name), k, dir)?;
        manifest.networks[k] = m.networks[k].clone();
    }
    let by_slot: Vec<String> = stage
        .slots
        .iter()
        .enumerate()
        .map(|(k, name)| format!("{} from stage {name}", k + 1))
        .collect();
    manifest.training.notes = format!(
        "networks by slot: {}; the training below is stage {}'s. {}",
        by_slot.join(", "),
        stage.slots[0],
        manifest.training.notes
    );
    manifest.switch = None;
    manifest.write(&dir.join(MANIFEST))?;
    Ok(())
}

/// The file a `cnr` stage writes its model to (and the recipe's output).
pub(super) const CNR_FILE: &str = "cnr.json";

/// `cnr`: a CNR model trained on the config's sources into `DIR/cnr.json`
/// (run again from the start if it stopped: it takes seconds to minutes).
pub(super) fn cnr(
    recipe: &Recipe,
    stage: &CnrStage,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<(), DenoiseError> {
    let config = recipe.cnr_config(stage)?;
    let settings = crate::cnr::train::CnrTrainSettings {
        seed: config.seed,
        ..stage.settings.clone()
    };
    let start = std::time::Instant::now();
    let mut model = crate::cnr::train::train_from_config(&config, &settings, progress)
        .map_err(|e| recipe_error(dir, format!("stage {:?}: {e}", stage.name)))?;
    model.training.push(format!(
        "trained by stage {:?} with {} in {:.0} s",
        stage.name,
        stage.config,
        start.elapsed().as_secs_f64()
    ));
    model.write(&dir.join(CNR_FILE))?;
    Ok(())
}

/// What a `switch_rows` stage saw, per pair (`DIR/trace.toml`).
#[derive(Debug, Default, Serialize, Deserialize)]
struct RowsReport {
    /// the precision the residual blocks ran in
    precision: String,
    pairs: Vec<PairReport>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
struct PairReport {
    name: String,
    rows: usize,
    e_a_deg: Vec<f64>,
    chosen: Vec<usize>,
    /// rows left out as folded (`skip_folded`)
    skipped_folded: usize,
}

/// `switch_rows`: one rows file per noisy pair (`pair-N.bin`), written
/// whole; a pair whose file exists is not run again.
pub(super) fn switch_rows(
    recipe: &Recipe,
    stage: &RowsStage,
    out: &Path,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<(), DenoiseError> {
    let fail =
        |e: &dyn std::fmt::Display| recipe_error(dir, format!("stage {:?}: {e}", stage.name));
    let networks = recipe.index_of(&stage.networks).expect("checked");
    let mut bundle = Bundle::load(recipe.stage_dir(out, networks)).map_err(|e| fail(&e))?;
    let arithmetic = bundle.set_arithmetic(if stage.int8 {
        normalnet_net::Arithmetic::INT8_BLOCKS
    } else {
        normalnet_net::Arithmetic::F32
    });
    let path = if stage.follow.is_empty() {
        TracePath::Candidate(0)
    } else {
        let upto = recipe.index_of(&stage.follow).expect("checked");
        TracePath::Learned(switch_upto(recipe, out, upto)?.expect("a switch_fit stage"))
    };
    let settings = TraceSettings {
        iterations: stage.iterations,
        mu_g: stage.mu_g,
        vertex_iterations: stage.vertex_iterations,
        flat_skip_deg: stage.flat_skip_deg,
        min_iteration: stage.min_iteration,
        skip_folded: stage.skip_folded,
        cnr: stage.cnr,
        ..TraceSettings::default()
    };
    let config = rows_config(stage);
    let pairs =
        noisy_pairs(&config, &config.sources, stage.seed, progress).map_err(|e| fail(&e))?;
    let mut report = RowsReport {
        precision: if arithmetic.int8 { "Int8" } else { "F32" }.to_string(),
        pairs: Vec::new(),
    };
    progress.start(&format!("rows {}", stage.name), pairs.len() as u64);
    for (i, (name, clean, noisy)) in pairs.iter().enumerate() {
        let file = rows_file(dir, i);
        if file.is_file() {
            let rows = read_rows(&file, 1).map_err(|e| fail(&e))?;
            report.pairs.push(PairReport {
                name: name.clone(),
                rows: rows.len() / ROW_LEN,
                ..PairReport::default()
            });
        } else {
            progress.message(&format!("tracing {name}"));
            let t = trace(&bundle, noisy, clean, &path, &settings).map_err(|e| fail(&e))?;
            write_rows(&file, &t.rows).map_err(|e| fail(&e))?;
            report.pairs.push(PairReport {
                name: name.clone(),
                rows: t.rows.len() / ROW_LEN,
                e_a_deg: t.e_a_deg,
                chosen: t.chosen.to_vec(),
                skipped_folded: t.skipped_folded,
            });
        }
        progress.advance(1);
    }
    progress.finish();
    let text = toml::to_string(&report).map_err(|e| fail(&e))?;
    write_file(&dir.join("trace.toml"), text.as_bytes())
}

fn rows_file(dir: &Path, pair: usize) -> PathBuf {
    dir.join(format!("pair-{pair}.bin"))
}

/// The rows files of a `switch_rows` stage, in pair order.
fn rows_files(dir: &Path) -> Result<Vec<PathBuf>, DenoiseError> {
    let mut files = Vec::new();
    while rows_file(dir, files.len()).is_file() {
        files.push(rows_file(dir, files.len()));
    }
    if files.is_empty() {
        return Err(recipe_error(dir, "no rows files (pair-0.bin ...)".into()));
    }
    Ok(files)
}

/// The rows of iterations up to `last`.
fn rows_up_to(rows: Vec<f32>, last: usize) -> Vec<f32> {
    rows.chunks_exact(ROW_LEN)
        .filter(|r| r[normalnet_net::switch::ITERATION_FEATURE] <= last as f32)
        .flatten()
        .copied()
        .collect()
}

#[derive(Serialize, Deserialize)]
struct SwitchFile {
    switch: SwitchWeights,
}

/// `switch_fit`: the table fitted on the rows (or taken from `bundle`),
/// written to `DIR/switch.toml` (`[switch]`).
pub(super) fn switch_fit(
    recipe: &Recipe,
    stage: &FitStage,
    out: &Path,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<(), DenoiseError> {
    let fail =
        |e: &dyn std::fmt::Display| recipe_error(dir, format!("stage {:?}: {e}", stage.name));
    if !stage.bundle.is_empty() {
        let i = recipe.index_of(&stage.name).expect("a stage of the recipe");
        let main = recipe
            .bundle_manifest(i, &stage.bundle)?
            .switch
            .ok_or_else(|| fail(&"the bundle has no switch"))?;
        let mut table = match stage.late {
            false => main,
            true => *main
                .late
                .ok_or_else(|| fail(&"the bundle has no late table"))?,
        };
        table.late = None;
        table.heavy = None;
        if let Some(on) = stage.network_on_folds {
            table.network_on_folds = on;
        }
        let text = toml::to_string(&SwitchFile { switch: table }).map_err(|e| fail(&e))?;
        return write_file(&dir.join(SWITCH_FILE), text.as_bytes());
    }
    let mut rows = Vec::new();
    for r in &stage.rows {
        let i = recipe.index_of(r).expect("checked");
        for f in rows_files(&recipe.stage_dir(out, i))? {
            let mut r = read_rows(&f, stage.min_iteration).map_err(|e| fail(&e))?;
            if stage.last_iteration > 0 {
                r = rows_up_to(r, stage.last_iteration);
            }
            rows.extend(r);
        }
    }
    progress.message(&format!(
        "fitting {} on {} rows",
        stage.name,
        rows.len() / ROW_LEN
    ));
    let params = FitParams {
        hidden: stage.hidden,
        epochs: stage.epochs,
        seed: stage.seed,
        max_iteration: stage.max_iteration,
        cnr: stage.cnr,
        ..FitParams::default()
    };
    let allowed: Vec<usize> = (0..params.dims().1).collect();
    let (mut weights, report) = fit(&rows, &allowed, &params).map_err(|e| fail(&e))?;
    weights.network_on_folds = stage.network_on_folds.unwrap_or(false);
    weights.notes = format!(
        "{}{}fitted by recipe {} stage {:?} ({} hidden, {} epochs, seed {}, iteration clamp {}, iterations {}..{}) on {} rows of {}; expected angle {:.3} deg in the last epoch (per candidate {:.3?}, per-row best {:.3})",
        stage.notes,
        if stage.notes.is_empty() { "" } else { "; " },
        recipe.name,
        stage.name,
        stage.hidden,
        stage.epochs,
        stage.seed,
        stage.max_iteration,
        stage.min_iteration,
        if stage.last_iteration > 0 {
            stage.last_iteration.to_string()
        } else {
            "".into()
        },
        rows.len() / ROW_LEN,
        stage.rows.join(", "),
        report.epoch_loss.last().copied().unwrap_or(f64::NAN),
        report.candidate_mean_deg,
        report.best_mean_deg,
    );
    let text = toml::to_string(&SwitchFile { switch: weights }).map_err(|e| fail(&e))?;
    write_file(&dir.join(SWITCH_FILE), text.as_bytes())
}

/// The switch made by the `switch_fit` stages up to and including `upto`:
/// the last main table, with the last late and heavy tables fitted after
/// it; none without a main table.
pub(super) fn switch_upto(
    recipe: &Recipe,
    out: &Path,
    upto: usize,
) -> Result<Option<SwitchWeights>, DenoiseError> {
    let mut main: Option<SwitchWeights> = None;
    for (i, stage) in recipe.stages[..=upto].iter().enumerate() {
        let super::Stage::SwitchFit(fit) = stage else {
            continue;
        };
        let file = recipe.stage_dir(out, i).join(SWITCH_FILE);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| recipe_error(&file, format!("reading: {e}")))?;
        let table = toml::from_str::<SwitchFile>(&text)
            .map_err(|e| recipe_error(&file, e.to_string()))?
            .switch;
        // (a late or heavy table follows a main one: checked at load)
        match (main.as_mut(), fit.heavy_from) {
            _ if fit.is_main() => main = Some(table),
            (Some(m), _) if fit.late => m.late = Some(Box::new(table)),
            (Some(m), Some(from)) => {
                let table = SwitchWeights {
                    network_on_folds: false,
                    ..table
                };
                m.heavy = Some(Box::new(HeavyTable {
                    from_noise_level: from,
                    table,
                }));
            }
            _ => {}
        }
    }
    // (a heavy table of another clamp than the main one's is refused here,
    // before any rows follow it or a bundle carries it)
    if let Some(m) = &main {
        m.validate().map_err(|e| {
            recipe_error(&recipe.file, format!("the switch up to stage {upto}: {e}"))
        })?;
    }
    Ok(main)
}

/// Writes `bytes` to `path` whole (never a partial file).
pub(super) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), DenoiseError> {
    normalnet_mesh::io::write_atomically(path, |w| w.write_all(bytes))
        .map_err(|e| recipe_error(path, e.to_string()))
}
