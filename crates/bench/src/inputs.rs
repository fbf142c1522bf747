//! The pairs a bench runs on: the model folders of a data folder, or a
//! validation suite's pairs generated into its cache.

use anyhow::{Context, bail};
use normalnet_denoise::suite::{Suite, describe_noise};
use normalnet_render::report::ReportGroup;
use std::path::{Path, PathBuf};

use crate::BenchUi;

/// Folders under `data` holding `Noisy.obj` and `Original.obj`, sorted.
fn discover_models(data: &Path) -> anyhow::Result<Vec<String>> {
    let entries = std::fs::read_dir(data)
        .with_context(|| format!("reading data folder {}", data.display()))?;
    let mut models: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("Noisy.obj").is_file() && e.path().join("Original.obj").is_file())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    models.sort();
    Ok(models)
}

/// One model of the bench: its name and the files of its noisy input and
/// ground truth.
pub(crate) struct BenchInput {
    pub(crate) model: String,
    pub(crate) noisy: PathBuf,
    pub(crate) clean: PathBuf,
}

/// The models of a data folder (`--models`, else every pair folder), checked.
pub(crate) fn inputs_from_data(data: &Path, names: &[String]) -> anyhow::Result<Vec<BenchInput>> {
    let models = if names.is_empty() {
        discover_models(data)?
    } else {
        names.iter().map(|m| m.trim().to_string()).collect()
    };
    if models.is_empty() {
        bail!(
            "no model folders with Noisy.obj and Original.obj under {}",
            data.display()
        );
    }
    let mut inputs = Vec::new();
    for m in models {
        let dir = data.join(&m);
        for f in ["Noisy.obj", "Original.obj"] {
            if !dir.join(f).is_file() {
                bail!("{}: missing {f}", dir.display());
            }
        }
        inputs.push(BenchInput {
            noisy: dir.join("Noisy.obj"),
            clean: dir.join("Original.obj"),
            model: m,
        });
    }
    Ok(inputs)
}

/// What a suite gives the bench: its inputs, the report's groups and the
/// noise description of each pair.
pub(crate) struct SuiteInputs {
    pub(crate) inputs: Vec<BenchInput>,
    pub(crate) groups: Vec<ReportGroup>,
    pub(crate) noise_labels: Vec<(String, String)>,
}

/// The pairs of a suite (`--models`: only those), generated into `cache`
/// where missing, with the report's groups and noise labels.
pub(crate) fn inputs_from_suite(
    path: &Path,
    cache: &Path,
    names: &[String],
    ui: &dyn BenchUi,
) -> anyhow::Result<SuiteInputs> {
    let mut suite = Suite::load(path)?;
    let names: Vec<&str> = names.iter().map(|n| n.trim()).collect();
    if let Some(bad) = names
        .iter()
        .find(|n| !suite.pairs.iter().any(|p| &p.name == *n))
    {
        bail!("{}: no pair named `{bad}`", path.display());
    }
    if !names.is_empty() {
        suite.pairs.retain(|p| names.contains(&p.name.as_str()));
    }
    let prepared = suite.prepare(cache, &*ui.progress())?;
    let made = prepared.iter().filter(|p| p.generated).count();
    ui.line(&format!(
        "suite {}: {} pairs, {made} generated into {}",
        path.display(),
        prepared.len(),
        cache.display()
    ));
    let groups = suite
        .groups
        .iter()
        .map(|g| ReportGroup {
            name: g.clone(),
            models: suite.members(g).iter().map(|m| m.to_string()).collect(),
        })
        .filter(|g| !g.models.is_empty())
        .collect();
    let labels = suite
        .pairs
        .iter()
        .map(|p| (p.name.clone(), describe_noise(&p.noise)))
        .collect();
    let inputs = prepared
        .into_iter()
        .map(|p| BenchInput {
            model: p.name,
            noisy: p.noisy,
            clean: p.clean,
        })
        .collect();
    Ok(SuiteInputs {
        inputs,
        groups,
        noise_labels: labels,
    })
}
