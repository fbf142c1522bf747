//! The comparison report of `normalnet bench`: the paper's Table 3 layout
//! (Zhao et al., NormalNet, Table 3: one block of metric rows per model and
//! noise level, one column per method, the best value of each row in bold)
//! as `table.md`, plus `results.csv`, `results.json` and a static
//! `index.html` with the table and the pictures (no scripts, no network).
//!
//! The noisy input is a column too (its errors are the starting point); it
//! never takes part in the bolding, which ranks the methods only. A method
//! that failed on a model shows `failed` with its message listed under the
//! table.

use crate::error::RenderError;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// The method name used for the unprocessed noisy input.
pub const NOISY: &str = "noisy";

/// One run: a method on a model, with its metrics or its error.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct RunRecord {
    /// model folder name, e.g. `Fandisk0.3`
    pub model: String,
    /// noise description from the folder name, e.g. `0.3` or `0.5 impulsive`
    pub noise: String,
    /// method name (`noisy` for the input itself)
    pub method: String,
    /// the settings used, human-readable (e.g. `N_f=10 N_v=20 mu_g=0.25`)
    pub params: String,
    /// E_a: mean angle between result and ground-truth face normals, degrees
    pub e_a_deg: Option<f64>,
    /// E_v: area-weighted RMS vertex–surface distance (SPEC §3), model units
    pub e_v: Option<f64>,
    /// E_v divided by the ground truth's mean edge length l_e
    pub e_v_over_le: Option<f64>,
    /// Hausdorff distance between result and ground-truth surfaces (both ways)
    pub hausdorff: Option<f64>,
    /// faces whose normal opposes the ground truth's (folded over)
    pub flipped_faces: Option<usize>,
    /// wall-clock seconds of the denoising call alone
    pub denoise_seconds: Option<f64>,
    /// wall-clock seconds of the whole run (denoise + metrics + rendering)
    pub total_seconds: Option<f64>,
    /// the error message when the run failed
    pub error: Option<String>,
    /// why the run was skipped (by the settings), when it was
    pub skipped: Option<String>,
}

/// Everything the report files show.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct BenchReport {
    /// title line of table.md / index.html
    pub title: String,
    /// model names in row order
    pub models: Vec<String>,
    /// method names in column order (without `noisy`, which comes first)
    pub methods: Vec<String>,
    /// all runs, including the `noisy` rows
    pub records: Vec<RunRecord>,
    /// `(model, picture file name relative to the report folder)`
    pub pictures: Vec<(String, String)>,
    /// free-form lines shown under the table (machine, command, caveats)
    pub notes: Vec<String>,
    /// method columns shown for reference but never ranked (bold), e.g. an
    /// oracle that uses the ground truth; `noisy` is always unranked
    pub unranked: Vec<String>,
    /// groups of models (a validation suite's), in display order: their
    /// means follow the table
    pub groups: Vec<ReportGroup>,
    /// `(model, noise)` for models whose name does not hold their noise
    /// (a suite's pairs); other models' noise comes from [`split_model_name`]
    pub noise_labels: Vec<(String, String)>,
}

/// A named group of models (e.g. `heavy`, `cad`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct ReportGroup {
    /// the group's name
    pub name: String,
    /// its models, in table order
    pub models: Vec<String>,
}

/// The mean of one column over one group's models (`results.json`
/// `group_means`); a value is `None` where the column lacks it on some
/// model of the group.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct GroupMean {
    /// the group's name
    pub group: String,
    /// the column (`noisy` or a method)
    pub method: String,
    /// number of models in the group
    pub pairs: usize,
    /// mean E_a, degrees
    pub e_a_deg: Option<f64>,
    /// mean E_v / l_e
    pub e_v_over_le: Option<f64>,
}

/// Splits a data-set folder name into model and noise level:
/// `Fandisk0.3` → (`Fandisk`, `0.3`), `Twelve0.5Impulsive` → (`Twelve`, `0.5 impulsive`).
/// A name without a number gives the whole name and `-`.
pub fn split_model_name(name: &str) -> (String, String) {
    let Some(start) = name.find(|c: char| c.is_ascii_digit()) else {
        return (name.to_string(), "-".to_string());
    };
    let rest = &name[start..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    let (number, suffix) = rest.split_at(end);
    let noise = if suffix.is_empty() {
        number.to_string()
    } else {
        format!("{number} {}", suffix.to_lowercase())
    };
    (name[..start].to_string(), noise)
}

/// For one table row: which cells are best (the minimum), compared at the
/// precision shown (`decimals`), so displayed ties are all bold. Cells that
/// are `None` or non-finite never win; an all-empty row has no winner.
pub fn best_cells(values: &[Option<f64>], decimals: usize) -> Vec<bool> {
    let shown: Vec<Option<String>> = values
        .iter()
        .map(|v| {
            v.filter(|x| x.is_finite())
                .map(|x| format!("{x:.decimals$}"))
        })
        .collect();
    let min = values
        .iter()
        .filter_map(|v| v.filter(|x| x.is_finite()))
        .fold(f64::INFINITY, f64::min);
    if !min.is_finite() {
        return vec![false; values.len()];
    }
    let min_shown = format!("{min:.decimals$}");
    shown
        .iter()
        .map(|s| s.as_deref() == Some(min_shown.as_str()))
        .collect()
}

/// One metric row of the table.
struct MetricRow {
    label: &'static str,
    decimals: usize,
    get: fn(&RunRecord) -> Option<f64>,
}

const METRIC_ROWS: [MetricRow; 3] = [
    MetricRow {
        label: "E_a (deg)",
        decimals: 2,
        get: |r| r.e_a_deg,
    },
    MetricRow {
        label: "E_v / l_e",
        decimals: 4,
        get: |r| r.e_v_over_le,
    },
    MetricRow {
        label: "time (s)",
        decimals: 2,
        get: |r| r.denoise_seconds,
    },
];

/// A cell of the table.
enum Cell {
    Value(String, bool),
    Failed,
    Skipped,
    Missing,
}

impl BenchReport {
    fn record(&self, model: &str, method: &str) -> Option<&RunRecord> {
        self.records
            .iter()
            .find(|r| r.model == model && r.method == method)
    }

    /// Whether column `m` takes part in the bolding.
    fn ranked(&self, m: &str) -> bool {
        m != NOISY && !self.unranked.iter().any(|u| u == m)
    }

    /// Column names: `noisy` then the methods.
    fn columns(&self) -> Vec<String> {
        let mut cols = vec![NOISY.to_string()];
        cols.extend(self.methods.iter().filter(|m| *m != NOISY).cloned());
        cols
    }

    /// The cells of one metric row for one model (noisy first). Time is not
    /// shown for the noisy input.
    fn row_cells(&self, model: &str, metric: &MetricRow) -> Vec<Cell> {
        let cols = self.columns();
        let values: Vec<Option<f64>> = cols
            .iter()
            .map(|m| {
                if !self.ranked(m) {
                    None
                } else {
                    self.record(model, m)
                        .filter(|r| r.error.is_none())
                        .and_then(metric.get)
                }
            })
            .collect();
        let best = best_cells(&values, metric.decimals);
        cols.iter()
            .enumerate()
            .map(|(i, m)| match self.record(model, m) {
                None => Cell::Missing,
                Some(r) if r.skipped.is_some() => Cell::Skipped,
                Some(r) if r.error.is_some() => Cell::Failed,
                Some(r) => match (metric.get)(r) {
                    Some(v)
                        if v.is_finite() && !(m == NOISY && metric.label.starts_with("time")) =>
                    {
                        Cell::Value(format!("{v:.p$}", p = metric.decimals), best[i])
                    }
                    _ => Cell::Missing,
                },
            })
            .collect()
    }

    /// Mean over models of one metric per method; `None` where a method lacks a
    /// value on some model (a mean over fewer models would not compare).
    fn means(&self, metric: &MetricRow) -> Vec<Option<f64>> {
        self.means_over(&self.models, metric)
    }

    /// [`BenchReport::means`] over `models` only.
    fn means_over(&self, models: &[String], metric: &MetricRow) -> Vec<Option<f64>> {
        self.columns()
            .iter()
            .map(|m| {
                let vals: Option<Vec<f64>> = models
                    .iter()
                    .map(|model| {
                        self.record(model, m)
                            .filter(|r| r.error.is_none())
                            .and_then(metric.get)
                            .filter(|v| v.is_finite())
                    })
                    .collect();
                vals.filter(|v| !v.is_empty())
                    .map(|v| v.iter().sum::<f64>() / v.len() as f64)
            })
            .collect()
    }

    /// The model and noise columns of `model`'s rows.
    fn name_and_noise(&self, model: &str) -> (String, String) {
        match self.noise_labels.iter().find(|(m, _)| m == model) {
            Some((m, noise)) => (m.clone(), noise.clone()),
            None => split_model_name(model),
        }
    }

    /// Every column's E_a and E_v / l_e means over each group.
    pub fn group_means(&self) -> Vec<GroupMean> {
        let cols = self.columns();
        let mut out = Vec::new();
        for g in &self.groups {
            let e_a = self.means_over(&g.models, &METRIC_ROWS[0]);
            let e_v = self.means_over(&g.models, &METRIC_ROWS[1]);
            for (i, c) in cols.iter().enumerate() {
                out.push(GroupMean {
                    group: g.name.clone(),
                    method: c.clone(),
                    pairs: g.models.len(),
                    e_a_deg: e_a[i],
                    e_v_over_le: e_v[i],
                });
            }
        }
        out
    }

    fn failures(&self) -> Vec<&RunRecord> {
        self.records.iter().filter(|r| r.error.is_some()).collect()
    }

    fn skips(&self) -> Vec<&RunRecord> {
        self.records
            .iter()
            .filter(|r| r.skipped.is_some())
            .collect()
    }
}

/// "the noisy input is" / "the noisy input and X are".
fn unranked_phrase(report: &BenchReport) -> String {
    if report.unranked.is_empty() {
        "the noisy input is".to_string()
    } else {
        format!("the noisy input and {} are", report.unranked.join(", "))
    }
}

fn md_escape(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// `<h2>title</h2>` and a list with one `model / method: text` line per
/// record, `text(record)` being HTML already.
fn write_run_list<'r>(
    s: &mut String,
    title: &str,
    records: impl Iterator<Item = &'r RunRecord>,
    text: impl Fn(&RunRecord) -> String,
) {
    let _ = writeln!(s, "<h2>{title}</h2><ul>");
    for r in records {
        let (model, method) = (html_escape(&r.model), html_escape(&r.method));
        let _ = writeln!(s, "<li>{model} / {method}: {}</li>", text(r));
    }
    let _ = writeln!(s, "</ul>");
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `table.md`: the paper's Table 3 layout with a settings list, failures,
/// notes and links to the pictures.
pub fn table_markdown(report: &BenchReport) -> String {
    let cols = report.columns();
    let mut s = String::new();
    let _ = writeln!(s, "# {}\n", report.title);
    let _ = writeln!(
        s,
        "Best method per row in **bold** ({} shown for reference and not ranked). \
         E_a: mean face-normal angle error in degrees; E_v / l_e: area-weighted RMS vertex distance \
         to the ground-truth surface over its mean edge length; time: the denoising call alone.\n",
        unranked_phrase(report)
    );
    let _ = writeln!(s, "| model | noise | metric | {} |", cols.join(" | "));
    let _ = writeln!(s, "|---|---|---|{}", "---:|".repeat(cols.len()));
    for model in &report.models {
        let (name, noise) = report.name_and_noise(model);
        for (k, metric) in METRIC_ROWS.iter().enumerate() {
            let (m, n) = if k == 0 {
                (name.as_str(), noise.as_str())
            } else {
                ("", "")
            };
            let cells: Vec<String> = report
                .row_cells(model, metric)
                .into_iter()
                .map(|c| match c {
                    Cell::Value(v, true) => format!("**{v}**"),
                    Cell::Value(v, false) => v,
                    Cell::Failed => "failed".to_string(),
                    Cell::Skipped => "skipped".to_string(),
                    Cell::Missing => "–".to_string(),
                })
                .collect();
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                md_escape(m),
                md_escape(n),
                metric.label,
                cells.join(" | ")
            );
        }
    }
    if report.models.len() > 1 {
        for (k, metric) in METRIC_ROWS.iter().enumerate() {
            let means = report.means(metric);
            let ranked: Vec<Option<f64>> = cols
                .iter()
                .zip(&means)
                .map(|(c, v)| if report.ranked(c) { *v } else { None })
                .collect();
            let best = best_cells(&ranked, metric.decimals);
            let cells: Vec<String> = means
                .iter()
                .enumerate()
                .map(|(i, v)| match v {
                    Some(v) if !(cols[i] == NOISY && metric.label.starts_with("time")) => {
                        let t = format!("{v:.p$}", p = metric.decimals);
                        if best[i] { format!("**{t}**") } else { t }
                    }
                    _ => "–".to_string(),
                })
                .collect();
            let first = if k == 0 { "mean" } else { "" };
            let _ = writeln!(
                s,
                "| {first} | | {} | {} |",
                metric.label,
                cells.join(" | ")
            );
        }
    }
    let _ = writeln!(s);
    if !report.groups.is_empty() {
        group_means_markdown(report, &mut s);
    }
    let failures = report.failures();
    if !failures.is_empty() {
        let _ = writeln!(s, "## Failed runs\n");
        for r in failures {
            let _ = writeln!(
                s,
                "- {} / {}: {}",
                md_escape(&r.model),
                md_escape(&r.method),
                md_escape(r.error.as_deref().unwrap_or(""))
            );
        }
        let _ = writeln!(s);
    }
    let skips = report.skips();
    if !skips.is_empty() {
        let _ = writeln!(s, "## Skipped runs\n");
        for r in skips {
            let _ = writeln!(
                s,
                "- {} / {}: {}",
                md_escape(&r.model),
                md_escape(&r.method),
                md_escape(r.skipped.as_deref().unwrap_or(""))
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "## Settings\n");
    for model in &report.models {
        for method in cols.iter().filter(|m| *m != NOISY) {
            if let Some(r) = report.record(model, method) {
                let _ = writeln!(
                    s,
                    "- {} / {}: {}",
                    md_escape(model),
                    md_escape(method),
                    md_escape(&r.params)
                );
            }
        }
    }
    let _ = writeln!(s);
    if !report.pictures.is_empty() {
        let _ = writeln!(s, "## Pictures\n");
        let _ = writeln!(
            s,
            "Faces coloured by angular error against the ground truth (turbo colormap, scale on the right); \
             panels: noisy input, each method, ground truth.\n"
        );
        for (model, file) in &report.pictures {
            let _ = writeln!(
                s,
                "- [{}]({}): ![{}]({})",
                md_escape(model),
                file,
                md_escape(model),
                file
            );
        }
        let _ = writeln!(s);
    }
    if !report.notes.is_empty() {
        let _ = writeln!(s, "## Notes\n");
        for n in &report.notes {
            let _ = writeln!(s, "- {}", md_escape(n));
        }
    }
    s
}

/// The `## Group means` table of `table.md`: per group, each column's mean
/// E_a and E_v / l_e over the group's models, the best ranked in bold.
fn group_means_markdown(report: &BenchReport, s: &mut String) {
    let cols = report.columns();
    let _ = writeln!(s, "## Group means\n");
    let _ = writeln!(s, "| group | pairs | metric | {} |", cols.join(" | "));
    let _ = writeln!(s, "|---|---:|---|{}", "---:|".repeat(cols.len()));
    for g in &report.groups {
        for (k, metric) in METRIC_ROWS[..2].iter().enumerate() {
            let means = report.means_over(&g.models, metric);
            let ranked: Vec<Option<f64>> = cols
                .iter()
                .zip(&means)
                .map(|(c, v)| if report.ranked(c) { *v } else { None })
                .collect();
            let best = best_cells(&ranked, metric.decimals);
            let cells: Vec<String> = means
                .iter()
                .zip(&best)
                .map(|(v, &b)| match v {
                    Some(v) => {
                        let t = format!("{v:.p$}", p = metric.decimals);
                        if b { format!("**{t}**") } else { t }
                    }
                    None => "–".to_string(),
                })
                .collect();
            let (name, n) = if k == 0 {
                (md_escape(&g.name), g.models.len().to_string())
            } else {
                (String::new(), String::new())
            };
            let _ = writeln!(
                s,
                "| {name} | {n} | {} | {} |",
                metric.label,
                cells.join(" | ")
            );
        }
    }
    let _ = writeln!(s);
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map(|x| format!("{x}"))
        .unwrap_or_default()
}

/// `results.csv`: one line per run, full precision, empty cells for missing values.
pub fn results_csv(report: &BenchReport) -> String {
    let mut s = String::from(
        "model,noise,method,params,e_a_deg,e_v,e_v_over_le,hausdorff,denoise_seconds,total_seconds,error,skipped\n",
    );
    for r in &report.records {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            csv_field(&r.model),
            csv_field(&r.noise),
            csv_field(&r.method),
            csv_field(&r.params),
            opt(r.e_a_deg),
            opt(r.e_v),
            opt(r.e_v_over_le),
            opt(r.hausdorff),
            opt(r.denoise_seconds),
            opt(r.total_seconds),
            csv_field(r.error.as_deref().unwrap_or("")),
            csv_field(r.skipped.as_deref().unwrap_or("")),
        );
    }
    s
}

/// `results.json`: the whole report (records, models, methods, pictures,
/// notes) and, when it has groups, `group_means` ([`BenchReport::group_means`]).
pub fn results_json(report: &BenchReport) -> Result<String, RenderError> {
    #[derive(Serialize)]
    struct WithGroupMeans<'a> {
        #[serde(flatten)]
        report: &'a BenchReport,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        group_means: Vec<GroupMean>,
    }
    let json = WithGroupMeans {
        report,
        group_means: report.group_means(),
    };
    serde_json::to_string_pretty(&json).map_err(|e| RenderError::Report {
        path: "results.json".into(),
        message: e.to_string(),
    })
}

/// `index.html`: a static page with the table and the pictures.
pub fn index_html(report: &BenchReport) -> String {
    let cols = report.columns();
    let mut s = String::new();
    let title = html_escape(&report.title);
    let _ = writeln!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>\
         body{{font-family:sans-serif;margin:2em;color:#222}} table{{border-collapse:collapse}} \
         td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}} td.l,th.l{{text-align:left}} \
         tr.first td{{border-top:2px solid #555}} .fail{{color:#b00}} img{{max-width:100%;border:1px solid #ddd}} \
         </style></head><body>\n<h1>{title}</h1>\n<p>Best method per row in <b>bold</b>; {who} \
         shown for reference and not ranked. E<sub>a</sub>: mean face-normal angle error (degrees); \
         E<sub>v</sub>/l<sub>e</sub>: area-weighted RMS vertex distance to the ground-truth surface over its \
         mean edge length; time: the denoising call alone (seconds).</p>",
        who = html_escape(&unranked_phrase(report))
    );
    let _ = write!(
        s,
        "<table>\n<tr><th class=\"l\">model</th><th class=\"l\">noise</th><th class=\"l\">metric</th>"
    );
    for c in &cols {
        let _ = write!(s, "<th>{}</th>", html_escape(c));
    }
    let _ = writeln!(s, "</tr>");
    for model in &report.models {
        let (name, noise) = report.name_and_noise(model);
        for (k, metric) in METRIC_ROWS.iter().enumerate() {
            let _ = write!(s, "<tr{}>", if k == 0 { " class=\"first\"" } else { "" });
            if k == 0 {
                let _ = write!(
                    s,
                    "<td class=\"l\" rowspan=\"{n}\">{}</td><td class=\"l\" rowspan=\"{n}\">{}</td>",
                    html_escape(&name),
                    html_escape(&noise),
                    n = METRIC_ROWS.len()
                );
            }
            let _ = write!(s, "<td class=\"l\">{}</td>", html_escape(metric.label));
            for c in report.row_cells(model, metric) {
                let _ = match c {
                    Cell::Value(v, true) => write!(s, "<td><b>{v}</b></td>"),
                    Cell::Value(v, false) => write!(s, "<td>{v}</td>"),
                    Cell::Failed => write!(s, "<td class=\"fail\">failed</td>"),
                    Cell::Skipped => write!(s, "<td>skipped</td>"),
                    Cell::Missing => write!(s, "<td>–</td>"),
                };
            }
            let _ = writeln!(s, "</tr>");
        }
    }
    let _ = writeln!(s, "</table>");
    let failures = report.failures();
    if !failures.is_empty() {
        let failed = |r: &RunRecord| {
            let error = html_escape(r.error.as_deref().unwrap_or(""));
            format!("<span class=\"fail\">{error}</span>")
        };
        write_run_list(&mut s, "Failed runs", failures.into_iter(), failed);
    }
    let skips = report.skips();
    if !skips.is_empty() {
        let skipped = |r: &RunRecord| html_escape(r.skipped.as_deref().unwrap_or(""));
        write_run_list(&mut s, "Skipped runs", skips.into_iter(), skipped);
    }
    let runs = report.records.iter().filter(|r| r.method != NOISY);
    write_run_list(&mut s, "Settings", runs, |r| html_escape(&r.params));
    if !report.pictures.is_empty() {
        let _ = writeln!(
            s,
            "<h2>Pictures</h2><p>Faces coloured by angular error against the ground truth; panels: noisy \
             input, each method, ground truth.</p>"
        );
        for (model, file) in &report.pictures {
            let f = html_escape(file);
            let _ = writeln!(
                s,
                "<h3>{}</h3><a href=\"{f}\"><img src=\"{f}\" alt=\"{}\"></a>",
                html_escape(model),
                html_escape(model)
            );
        }
    }
    if !report.notes.is_empty() {
        let _ = writeln!(s, "<h2>Notes</h2><ul>");
        for n in &report.notes {
            let _ = writeln!(s, "<li>{}</li>", html_escape(n));
        }
        let _ = writeln!(s, "</ul>");
    }
    let _ = writeln!(s, "</body></html>");
    s
}

/// Writes `table.md`, `results.csv`, `results.json` and `index.html` into
/// `dir` (which must exist), each atomically.
pub fn write_report(dir: &Path, report: &BenchReport) -> Result<(), RenderError> {
    let files = [
        ("table.md", table_markdown(report)),
        ("results.csv", results_csv(report)),
        ("results.json", results_json(report)?),
        ("index.html", index_html(report)),
    ];
    for (name, text) in files {
        normalnet_mesh::io::write_atomically(&dir.join(name), |w| w.write_all(text.as_bytes()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(model: &str, method: &str, e_a: f64, e_v: f64) -> RunRecord {
        RunRecord {
            model: model.into(),
            noise: split_model_name(model).1,
            method: method.into(),
            params: "x=1".into(),
            e_a_deg: Some(e_a),
            e_v: Some(e_v),
            e_v_over_le: Some(e_v * 10.0),
            hausdorff: Some(0.5),
            flipped_faces: Some(3),
            denoise_seconds: Some(1.0),
            total_seconds: Some(2.0),
            error: None,
            skipped: None,
        }
    }

    fn report() -> BenchReport {
        let mut failed = rec("Block0.4", "normalnet", 0.0, 0.0);
        failed.error = Some("model bundle not found: models/lite".into());
        BenchReport {
            title: "t".into(),
            models: vec!["Fandisk0.3".into(), "Block0.4".into()],
            methods: vec!["gnf".into(), "bnf".into(), "normalnet".into()],
            records: vec![
                rec("Fandisk0.3", NOISY, 28.0, 0.01),
                rec("Fandisk0.3", "gnf", 2.93, 0.0065),
                rec("Fandisk0.3", "bnf", 3.49, 0.0060),
                rec("Fandisk0.3", "normalnet", 2.5, 0.0070),
                rec("Block0.4", NOISY, 33.0, 0.02),
                rec("Block0.4", "gnf", 4.11, 0.009),
                rec("Block0.4", "bnf", 4.11, 0.010),
                failed,
            ],
            pictures: vec![("Fandisk0.3".into(), "Fandisk0.3.png".into())],
            notes: vec!["a note".into()],
            unranked: vec![],
            ..Default::default()
        }
    }

    #[test]
    fn group_means_follow_the_table_and_go_into_the_json() {
        let mut r = report();
        r.groups = vec![
            ReportGroup {
                name: "cad".into(),
                models: vec!["Fandisk0.3".into(), "Block0.4".into()],
            },
            ReportGroup {
                name: "sharp".into(),
                models: vec!["Fandisk0.3".into()],
            },
        ];
        r.noise_labels = vec![("Block0.4".into(), "gaussian L=0.4".into())];
        let md = table_markdown(&r);
        let table = md.split("## Group means").nth(1).expect("a group table");
        // cad: gnf (2.93 + 4.11) / 2 = 3.52, bnf 3.80, normalnet failed on Block
        assert!(
            table.contains("| cad | 2 | E_a (deg) | 30.50 | **3.52** | 3.80 | – |"),
            "{table}"
        );
        assert!(
            table.contains("| sharp | 1 | E_a (deg) | 28.00 | 2.93 | 3.49 | **2.50** |"),
            "{table}"
        );
        assert!(
            md.contains("| Block0.4 | gaussian L=0.4 | E_a (deg) |"),
            "{md}"
        );
        let json: serde_json::Value = serde_json::from_str(&results_json(&r).unwrap()).unwrap();
        let means = json["group_means"].as_array().unwrap();
        let gnf_cad = means
            .iter()
            .find(|m| m["group"] == "cad" && m["method"] == "gnf")
            .unwrap();
        assert!((gnf_cad["e_a_deg"].as_f64().unwrap() - 3.52).abs() < 1e-12);
        assert_eq!(gnf_cad["pairs"], 2);
        // a report without groups writes no group table or means
        assert!(!table_markdown(&report()).contains("Group means"));
        assert!(
            results_json(&report())
                .unwrap()
                .find("group_means")
                .is_none()
        );
    }

    #[test]
    fn bolding_picks_the_minimum() {
        assert_eq!(
            best_cells(&[Some(3.0), Some(2.0), Some(5.0)], 2),
            vec![false, true, false]
        );
        assert_eq!(
            best_cells(&[None, Some(2.0), Some(1.0)], 2),
            vec![false, false, true]
        );
        // ties at the shown precision are all bold
        assert_eq!(
            best_cells(&[Some(2.001), Some(2.004), Some(2.1)], 2),
            vec![true, true, false]
        );
        assert_eq!(
            best_cells(&[Some(f64::NAN), Some(7.0)], 2),
            vec![false, true]
        );
        assert_eq!(best_cells(&[None, None], 2), vec![false, false]);
    }

    #[test]
    fn model_names_split_into_name_and_noise() {
        assert_eq!(
            split_model_name("Fandisk0.3"),
            ("Fandisk".into(), "0.3".into())
        );
        assert_eq!(
            split_model_name("Twelve0.5Impulsive"),
            ("Twelve".into(), "0.5 impulsive".into())
        );
        assert_eq!(split_model_name("cube"), ("cube".into(), "-".into()));
    }

    #[test]
    fn markdown_table_bolds_best_method_and_reports_failures() {
        let md = table_markdown(&report());
        assert!(
            md.contains("| model | noise | metric | noisy | gnf | bnf | normalnet |"),
            "{md}"
        );
        // Fandisk E_a: normalnet best; the noisy column is never bold
        assert!(
            md.contains("| Fandisk | 0.3 | E_a (deg) | 28.00 | 2.93 | 3.49 | **2.50** |"),
            "{md}"
        );
        // Fandisk E_v/l_e: bnf best
        assert!(
            md.contains("| E_v / l_e | 0.1000 | 0.0650 | **0.0600** | 0.0700 |"),
            "{md}"
        );
        // Block: tie between gnf and bnf, normalnet failed
        assert!(
            md.contains("| Block | 0.4 | E_a (deg) | 33.00 | **4.11** | **4.11** | failed |"),
            "{md}"
        );
        assert!(
            md.contains("Block0.4 / normalnet: model bundle not found"),
            "{md}"
        );
        // the mean row skips normalnet (missing on Block)
        assert!(
            md.contains("| mean | | E_a (deg) | 30.50 | **3.52** | 3.80 | – |"),
            "{md}"
        );
        assert!(md.contains("![Fandisk0.3](Fandisk0.3.png)"));
    }

    #[test]
    fn skipped_runs_are_marked_not_failed() {
        let mut r = report();
        r.records.push(RunRecord {
            model: "Fandisk0.3".into(),
            method: "sun07".into(),
            skipped: Some("too slow here".into()),
            ..Default::default()
        });
        r.methods.push("sun07".into());
        let md = table_markdown(&r);
        assert!(md.contains("| **2.50** | skipped |"), "{md}");
        assert!(
            md.contains("## Skipped runs\n\n- Fandisk0.3 / sun07: too slow here"),
            "{md}"
        );
        assert!(!md.contains("Fandisk0.3 / sun07: too slow here\n\n## Failed"));
    }

    #[test]
    fn unranked_columns_are_never_bold() {
        let mut r = report();
        r.unranked = vec!["normalnet".into()];
        let md = table_markdown(&r);
        assert!(
            md.contains("| Fandisk | 0.3 | E_a (deg) | 28.00 | **2.93** | 3.49 | 2.50 |"),
            "{md}"
        );
        assert!(
            md.contains("(the noisy input and normalnet are shown"),
            "{md}"
        );
    }

    #[test]
    fn csv_and_json_hold_every_record() {
        let r = report();
        let csv = results_csv(&r);
        assert_eq!(csv.lines().count(), 1 + r.records.len());
        assert!(
            csv.contains("Fandisk0.3,0.3,gnf,x=1,2.93,0.0065,0.065,0.5,1,2,,\n"),
            "{csv}"
        );
        let json: serde_json::Value = serde_json::from_str(&results_json(&r).unwrap()).unwrap();
        assert_eq!(json["records"].as_array().unwrap().len(), r.records.len());
        assert_eq!(json["records"][1]["e_a_deg"].as_f64(), Some(2.93));
    }

    #[test]
    fn html_is_self_contained_and_escaped() {
        let mut r = report();
        r.notes.push("<script>".into());
        let html = index_html(&r);
        assert!(html.contains("<b>2.50</b>"));
        assert!(html.contains("&lt;script&gt;"));
        assert!(!html.contains("http"), "no network references");
        assert!(html.contains("<img src=\"Fandisk0.3.png\""));
    }

    #[test]
    fn write_report_writes_four_files() {
        let dir = tempfile::tempdir().unwrap();
        write_report(dir.path(), &report()).unwrap();
        for f in ["table.md", "results.csv", "results.json", "index.html"] {
            assert!(dir.path().join(f).is_file(), "{f}");
        }
    }
}
