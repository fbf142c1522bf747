//! Stage `evaluate`: the bundle made so far, run as the `normalnet`
//! denoiser on every pair of a validation suite; E_a per pair, per group
//! and over all pairs (the figures `normalnet bench --suite` reproduces).

use std::collections::BTreeMap;
use std::path::Path;

use normalnet_mesh::{NoProgress, Progress, compare, read_mesh};
use normalnet_net::bundle::Evaluation;

use super::{EvaluateStage, Recipe, recipe_error};
use crate::suite::Suite;
use crate::{DenoiseError, Denoiser, Params};

/// The file an `evaluate` stage writes its figures to.
pub(super) const EVALUATION_FILE: &str = "evaluation.toml";

/// The NormalNet parameters an `evaluate` stage runs with: those of
/// `normalnet bench --suite` (`configs/bench.toml`'s `[defaults.normalnet]`:
/// the denoiser's defaults with the auto stop off, a test in
/// `normalnet-bench` holds the two together), then the stage's own
/// `params` over them, so a stage's figures are the bench's on the same
/// suite and bundle.
pub fn evaluate_params(stage_params: &Params) -> Params {
    let mut params = Params::new();
    params.insert("auto_stop_deg".into(), 0.0.into());
    for (key, value) in stage_params {
        params.insert(key.clone(), value.clone());
    }
    params
}

/// Runs the bundle in `bundle` on the stage's suite (pairs generated into
/// `cache`) and writes `DIR/evaluation.toml`.
pub(super) fn evaluate(
    recipe: &Recipe,
    stage: &EvaluateStage,
    bundle: &Path,
    cache: &Path,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<Evaluation, DenoiseError> {
    let fail =
        |e: &dyn std::fmt::Display| recipe_error(dir, format!("stage {:?}: {e}", stage.name));
    let suite_file = recipe.path(&stage.suite);
    let suite = Suite::load(&suite_file)?;
    let prepared = suite.prepare(cache, progress)?;
    let settings = evaluate_params(&stage.params);
    let mut params = settings.clone();
    params.insert("model".into(), bundle.display().to_string().into());
    let denoiser = Denoiser::new("normalnet", &params)?;
    let mut pairs = BTreeMap::new();
    progress.start(&format!("evaluate {}", stage.name), prepared.len() as u64);
    for p in &prepared {
        progress.message(&format!("evaluating {}", p.name));
        let noisy = read_mesh(&p.noisy)?;
        let clean = read_mesh(&p.clean)?;
        let out = denoiser.denoise(&noisy, None, &NoProgress)?;
        pairs.insert(p.name.clone(), compare(&clean, &out)?.e_a_deg);
        progress.advance(1);
    }
    progress.finish();
    let mean = |names: &mut dyn Iterator<Item = &str>| {
        let v: Vec<f64> = names.filter_map(|n| pairs.get(n).copied()).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let groups = suite
        .groups
        .iter()
        .map(|g| (g.clone(), mean(&mut suite.members(g).into_iter())))
        .collect();
    let suite_bytes =
        std::fs::read(&suite_file).map_err(|e| recipe_error(&suite_file, e.to_string()))?;
    let evaluation = Evaluation {
        suite: stage.suite.clone(),
        suite_hash: format!("{:016x}", normalnet_net::bundle::fnv1a(&suite_bytes)),
        settings: format!(
            "normalnet with {} (normalnet bench's settings)",
            serde_json::Value::Object(settings)
        ),
        all_deg: mean(&mut suite.pairs.iter().map(|p| p.name.as_str())),
        groups,
        pairs,
    };
    let text = toml::to_string(&evaluation).map_err(|e| fail(&e))?;
    super::stages::write_file(&dir.join(EVALUATION_FILE), text.as_bytes())?;
    Ok(evaluation)
}

/// The figures an `evaluate` stage wrote.
pub(super) fn read_evaluation(dir: &Path) -> Result<Evaluation, DenoiseError> {
    let file = dir.join(EVALUATION_FILE);
    let text =
        std::fs::read_to_string(&file).map_err(|e| recipe_error(&file, format!("reading: {e}")))?;
    toml::from_str(&text).map_err(|e| recipe_error(&file, e.to_string()))
}
