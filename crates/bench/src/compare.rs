//! Two bench runs of one suite side by side (`normalnet compare`): per
//! group of the base run's suite and over all its pairs, the mean E_a of a
//! method in each run, and whether the candidate is lower — the check a
//! model candidate must pass on the validation suite (every group and the
//! mean, docs/validation.md).

use anyhow::{Context, bail};
use normalnet_render::report::BenchReport;
use std::collections::HashMap;
use std::path::Path;

/// One group's means in the two runs.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupDelta {
    /// the group (`all` for every pair of the base run)
    pub group: String,
    /// its pairs
    pub pairs: usize,
    /// mean E_a (degrees) of the base run's method
    pub base: f64,
    /// mean E_a (degrees) of the candidate run's method
    pub candidate: f64,
    /// how many of its pairs the candidate is lower on: a group's mean can
    /// hide losses on some of its pairs behind gains on others
    pub pairs_lower: usize,
}

impl GroupDelta {
    /// Whether the candidate's mean is lower.
    pub fn wins(&self) -> bool {
        self.candidate < self.base
    }
}

/// The `results.json` of a bench output folder (or the file itself).
///
/// # Errors
/// A missing or unreadable file, or one that is not bench results.
pub fn read_results(path: &Path) -> anyhow::Result<BenchReport> {
    let file = if path.is_dir() {
        path.join("results.json")
    } else {
        path.to_path_buf()
    };
    let text =
        std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a bench results file", file.display()))
}

/// One pair's E_a in the two runs.
#[derive(Clone, Debug, PartialEq)]
pub struct PairDelta {
    /// the pair (model)
    pub model: String,
    /// E_a (degrees) of the base run's method
    pub base: f64,
    /// E_a (degrees) of the candidate run's method
    pub candidate: f64,
}

impl PairDelta {
    /// How much higher the candidate is (degrees; negative: lower).
    pub fn loss(&self) -> f64 {
        self.candidate - self.base
    }
}

/// Every model of `base`, its E_a of `base_method` in `base` and of
/// `method` in `candidate`, in the base run's order.
///
/// # Errors
/// A model of `base` without an E_a of the method in either run.
pub fn pair_deltas(
    base: &BenchReport,
    base_method: &str,
    candidate: &BenchReport,
    method: &str,
) -> anyhow::Result<Vec<PairDelta>> {
    let of = |report: &BenchReport, method: &str| -> HashMap<String, f64> {
        report
            .records
            .iter()
            .filter(|r| r.method == method)
            .filter_map(|r| Some((r.model.clone(), r.e_a_deg?)))
            .collect()
    };
    let (b, c) = (of(base, base_method), of(candidate, method));
    base.models
        .iter()
        .map(|model| {
            let get = |e: &HashMap<String, f64>, run: &str, m: &str| match e.get(model) {
                Some(v) => Ok(*v),
                None => bail!("the {run} run has no E_a of {m} on {model}"),
            };
            Ok(PairDelta {
                model: model.clone(),
                base: get(&b, "base", base_method)?,
                candidate: get(&c, "candidate", method)?,
            })
        })
        .collect()
}

/// Per group of `base` (then `all`: every model of `base`), the mean E_a
/// of `base_method` in `base` and of `method` in `candidate`.
///
/// # Errors
/// A model of `base` without an E_a of the method in either run (a failed
/// or missing cell): the means would not be over the same pairs.
pub fn compare(
    base: &BenchReport,
    base_method: &str,
    candidate: &BenchReport,
    method: &str,
) -> anyhow::Result<Vec<GroupDelta>> {
    let pairs: HashMap<String, PairDelta> = pair_deltas(base, base_method, candidate, method)?
        .into_iter()
        .map(|d| (d.model.clone(), d))
        .collect();
    let all = ("all".to_string(), base.models.clone());
    let groups = base
        .groups
        .iter()
        .map(|g| (g.name.clone(), g.models.clone()));
    groups
        .chain(std::iter::once(all))
        .map(|(group, models)| {
            let mut delta = GroupDelta {
                pairs: models.len(),
                base: 0.0,
                candidate: 0.0,
                pairs_lower: 0,
                group,
            };
            for model in &models {
                let Some(d) = pairs.get(model) else {
                    bail!("group {}: {model} is no pair of the base run", delta.group);
                };
                delta.base += d.base;
                delta.candidate += d.candidate;
                delta.pairs_lower += usize::from(d.candidate < d.base);
            }
            let n = models.len().max(1) as f64;
            delta.base /= n;
            delta.candidate /= n;
            Ok(delta)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use normalnet_render::report::{ReportGroup, RunRecord};

    fn report(method: &str, e: &[(&str, f64)], groups: &[(&str, &[&str])]) -> BenchReport {
        BenchReport {
            models: e.iter().map(|(m, _)| m.to_string()).collect(),
            records: e
                .iter()
                .map(|(m, v)| RunRecord {
                    model: m.to_string(),
                    method: method.to_string(),
                    e_a_deg: Some(*v),
                    ..RunRecord::default()
                })
                .collect(),
            groups: groups
                .iter()
                .map(|(n, ms)| ReportGroup {
                    name: n.to_string(),
                    models: ms.iter().map(|m| m.to_string()).collect(),
                })
                .collect(),
            ..BenchReport::default()
        }
    }

    #[test]
    fn group_means_of_both_runs_and_who_wins() {
        let groups: &[(&str, &[&str])] = &[("mild", &["a", "b"]), ("heavy", &["b", "c"])];
        let base = report("normalnet", &[("a", 1.0), ("b", 3.0), ("c", 5.0)], groups);
        let cand = report("x", &[("a", 2.0), ("b", 1.0), ("c", 6.0)], &[]);
        let d = compare(&base, "normalnet", &cand, "x").unwrap();
        let got: Vec<(&str, usize, f64, f64, bool, usize)> = d
            .iter()
            .map(|g| {
                let row = (g.group.as_str(), g.pairs, g.base, g.candidate);
                (row.0, row.1, row.2, row.3, g.wins(), g.pairs_lower)
            })
            .collect();
        assert_eq!(
            got,
            [
                ("mild", 2, 2.0, 1.5, true, 1),
                ("heavy", 2, 4.0, 3.5, true, 1),
                ("all", 3, 3.0, 3.0, false, 1),
            ]
        );
        // per pair: the mild group's mean wins while pair a loses 1°
        let pairs = pair_deltas(&base, "normalnet", &cand, "x").unwrap();
        let losses: Vec<(&str, f64)> = pairs.iter().map(|p| (p.model.as_str(), p.loss())).collect();
        assert_eq!(losses, [("a", 1.0), ("b", -2.0), ("c", 1.0)]);
        // a pair the candidate lacks (or the wrong method) is an error
        let short = report("x", &[("a", 2.0), ("b", 1.0)], &[]);
        let err = compare(&base, "normalnet", &short, "x")
            .unwrap_err()
            .to_string();
        assert!(err.contains("candidate run has no E_a of x on c"), "{err}");
        let err = compare(&base, "gnf", &cand, "x").unwrap_err().to_string();
        assert!(err.contains("base run has no E_a of gnf on a"), "{err}");
    }
}
