//! `normalnet batch INPUT... --out DIR`: denoises a collection with one
//! method (built once: NormalNet's model loads once). INPUT is a folder
//! (its mesh files, not recursive), a file, or a pattern with `*` / `?` in
//! the file name (quoted, so the shell leaves it). Resumable: an output that
//! exists is skipped (outputs appear whole or not at all, so an interrupted
//! run leaves none half-written); `--overwrite` redoes them. A file that
//! cannot be read or denoised is reported in the summary and the run goes
//! on; the command then ends with an error (exit status 1) naming how many
//! failed. Progress over files with ETA on stderr; `DIR/batch_summary.csv`
//! and `.json` list every input (faces, seconds, status done / skipped /
//! failed, error), rewritten after each failure, at least every second and
//! at the end (a killed run's summary is up to a second behind; the
//! outputs, not the summary, decide what a rerun skips). The output folder may not be
//! the folder of an input (outputs would replace or join the inputs).
//! Outputs keep what their input file carries, as with `denoise` (issue
//! 38; `--triangulate` for triangles instead of the input's polygons).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use normalnet_denoise::Denoiser;
use normalnet_mesh::{NoProgress, Progress};
use serde::Serialize;

use super::denoise::{MethodArgs, given_params};
use crate::mesh_output::write_result;
use crate::output;
use crate::progress::Bar;
use normalnet_mesh::io::FileWriteOptions;

/// The summary is rewritten at most this often (seconds), besides after
/// each failure and at the end.
const SUMMARY_SECONDS: f64 = 1.0;

/// Arguments of `normalnet batch`.
#[derive(clap::Args)]
pub struct Args {
    /// Folders, files or file-name patterns (`scans/*.ply`).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output folder (created): one mesh per input, same name.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Output format as a suffix (`.obj`, `.ply`, ...; default: the input's).
    #[arg(long)]
    pub suffix: Option<String>,
    /// Redo inputs whose output exists.
    #[arg(long)]
    pub overwrite: bool,
    /// Write triangles instead of each input's polygons.
    #[arg(long)]
    pub triangulate: bool,
    /// The method and its parameters.
    #[command(flatten)]
    pub choice: MethodArgs,
}

/// One line of the summary.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// the input file
    pub input: PathBuf,
    /// the output file
    pub output: PathBuf,
    /// `done`, `skipped` (output existed) or `failed`
    pub status: &'static str,
    /// faces of the input (when it was read)
    pub faces: Option<usize>,
    /// seconds spent on it
    pub seconds: f64,
    /// why it failed
    pub error: Option<String>,
}

/// `*` and `?` in one file name.
fn matches(pattern: &[u8], name: &[u8]) -> bool {
    match (pattern.first(), name.first()) {
        (None, None) => true,
        (Some(b'*'), _) => {
            matches(&pattern[1..], name) || (!name.is_empty() && matches(pattern, &name[1..]))
        }
        (Some(b'?'), Some(_)) => matches(&pattern[1..], &name[1..]),
        (Some(p), Some(n)) if p == n => matches(&pattern[1..], &name[1..]),
        _ => false,
    }
}

fn is_mesh(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| output::MESH.contains(&e.to_ascii_lowercase().as_str()))
}

/// The input files, sorted within each argument, without repeats.
pub fn collect_inputs(inputs: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        let name = input.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let mut found: Vec<PathBuf> = if input.is_dir() {
            std::fs::read_dir(input)
                .with_context(|| format!("reading {}", input.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && is_mesh(p))
                .collect()
        } else if name.contains(['*', '?']) {
            let dir = match input.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            std::fs::read_dir(&dir)
                .with_context(|| format!("reading {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file()
                        && p.file_name()
                            .and_then(|n| n.to_str())
                            .is_some_and(|n| matches(name.as_bytes(), n.as_bytes()))
                })
                .collect()
        } else if input.is_file() {
            vec![input.clone()]
        } else {
            bail!("{}: no such file or folder", input.display());
        };
        found.sort();
        for f in found {
            if !files.contains(&f) {
                files.push(f);
            }
        }
    }
    if files.is_empty() {
        bail!(
            "no mesh files (.obj, .off, .ply, .stl, .gltf, .glb) in {:?}",
            inputs
        );
    }
    Ok(files)
}

/// Output file names (without suffix): the input's stem, or
/// `<folder>-<stem>` for inputs whose stems collide (`cnr/block_n1/Noisy.obj`
/// and `cnr/cube_n1/Noisy.obj` become `block_n1-Noisy` and `cube_n1-Noisy`).
pub fn output_stems(files: &[PathBuf]) -> Vec<String> {
    let stem = |f: &PathBuf| {
        f.file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned()
    };
    let stems: Vec<String> = files.iter().map(stem).collect();
    files
        .iter()
        .zip(&stems)
        .map(|(f, s)| {
            if stems.iter().filter(|t| *t == s).count() > 1 {
                let folder = f
                    .parent()
                    .and_then(|p| p.file_name())
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                format!("{folder}-{s}")
            } else {
                s.clone()
            }
        })
        .collect()
}

fn write_summary(out: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut csv = String::from("input,output,status,faces,seconds,error\n");
    let quote = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{},{:.3},{}\n",
            quote(&r.input.display().to_string()),
            quote(&r.output.display().to_string()),
            r.status,
            r.faces.map_or(String::new(), |f| f.to_string()),
            r.seconds,
            r.error.as_deref().map_or(String::new(), quote)
        ));
    }
    for (name, bytes) in [
        ("batch_summary.csv", csv.into_bytes()),
        ("batch_summary.json", serde_json::to_vec_pretty(rows)?),
    ] {
        let path = out.join(name);
        normalnet_mesh::io::write_atomically(&path, |w| w.write_all(&bytes))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// Runs `normalnet batch`: the inputs checked and paired with their outputs
/// before any work, each denoised in turn (a failure is a row of the
/// summary, not the end), the summary kept current, the totals printed.
pub fn run(args: Args, quiet: bool) -> anyhow::Result<()> {
    let info = normalnet_denoise::find(&args.choice.method)?;
    if info.needs_gt() {
        bail!(
            "--method {} reads the ground truth; batch has none",
            info.name
        );
    }
    if let Some(s) = &args.suffix {
        let ext = s.trim_start_matches('.');
        if !output::MESH.contains(&ext) {
            bail!("--suffix {s}: expected one of .obj, .off, .ply, .stl, .gltf, .glb");
        }
    }
    let jobs = jobs(&args)?;
    let denoiser = Denoiser::new(info.name, &given_params(&args.choice, info)?)?;
    let bar = Bar::new(quiet);
    bar.start(&format!("batch {}", info.name), jobs.len() as u64);
    let mut rows = Vec::with_capacity(jobs.len());
    let started = Instant::now();
    let mut summary_written = Instant::now();
    for (input, output) in jobs {
        bar.message(&input.display().to_string());
        let row = denoise_one(&args, &denoiser, input, output);
        if let Some(e) = &row.error
            && !quiet
        {
            stderr_line!("{}: failed: {e}", row.input.display());
        }
        let failed = row.status == "failed";
        rows.push(row);
        // not after every file: the summary grows with the rows, and
        // rewriting it after each of 20,000 files wrote tens of GB (issue 39)
        if failed || summary_written.elapsed().as_secs_f64() >= SUMMARY_SECONDS {
            write_summary(&args.out, &rows)?;
            summary_written = Instant::now();
        }
        bar.advance(1);
    }
    write_summary(&args.out, &rows)?;
    bar.finish();
    print_totals(&rows, started, &args.out)
}

/// Every input with its output file, checked before any work: the output
/// folder is none of the inputs' folders (created), no two inputs write the
/// same output.
fn jobs(args: &Args) -> anyhow::Result<Vec<(PathBuf, PathBuf)>> {
    let files = collect_inputs(&args.inputs)?;
    let out_dir = output::canonical(&args.out);
    if let Some(input) = files
        .iter()
        .find(|f| output::canonical(&output::folder_of(f)) == out_dir)
    {
        bail!(
            "--out {}: is the folder of the input {}; outputs would replace or mix with the \
             inputs (choose another folder)",
            args.out.display(),
            input.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let stems = output_stems(&files);
    if let Some(dup) = stems
        .iter()
        .enumerate()
        .find(|(i, s)| stems[..*i].contains(s))
    {
        bail!("two inputs would both write {}: rename one", dup.1);
    }
    Ok(files
        .into_iter()
        .zip(&stems)
        .map(|(input, stem)| {
            let suffix = match &args.suffix {
                Some(s) => s.trim_start_matches('.').to_string(),
                None => input
                    .extension()
                    .map(|e| e.to_string_lossy().to_ascii_lowercase())
                    .unwrap_or_else(|| "obj".into()),
            };
            let output = args.out.join(format!("{stem}.{suffix}"));
            (input, output)
        })
        .collect())
}

/// One input denoised into `output` (skipped when it exists, unless
/// `--overwrite`), as its summary row.
fn denoise_one(args: &Args, denoiser: &Denoiser, input: PathBuf, output: PathBuf) -> Row {
    let started = Instant::now();
    let mut row = Row {
        input,
        output,
        status: "done",
        faces: None,
        seconds: 0.0,
        error: None,
    };
    if row.output.exists() && !args.overwrite {
        row.status = "skipped";
    } else {
        let (input, output) = (&row.input, &row.output);
        let mut faces = None;
        let result = (|| -> anyhow::Result<()> {
            output::check_not_input(output, &[input])?;
            normalnet_mesh::io::check_writable(output)?;
            let file = crate::input::read_mesh_file(input)?;
            let mesh = &file.mesh;
            faces = Some(mesh.num_faces());
            let format = super::info::format_for(output, None)?;
            normalnet_mesh::io::check_encodable(output, mesh, format)?;
            let out = denoiser.denoise(mesh, None, &NoProgress)?;
            let options = FileWriteOptions {
                triangulate: args.triangulate,
                ply_ascii: false,
            };
            write_result(output, format, &out, &file.attributes, input, &options)?;
            Ok(())
        })();
        row.faces = faces;
        if let Err(e) = result {
            row.status = "failed";
            row.error = Some(format!("{e:#}"));
        }
    }
    row.seconds = started.elapsed().as_secs_f64();
    row
}

/// The totals line on stdout; an error when any input failed.
fn print_totals(rows: &[Row], started: Instant, out: &Path) -> anyhow::Result<()> {
    let count = |s: &str| rows.iter().filter(|r| r.status == s).count();
    let summary = out.join("batch_summary.csv");
    writeln!(
        std::io::stdout().lock(),
        "{} files: {} done, {} skipped, {} failed in {:.1} s; summary in {}",
        rows.len(),
        count("done"),
        count("skipped"),
        count("failed"),
        started.elapsed().as_secs_f64(),
        summary.display()
    )?;
    let failed = count("failed");
    if failed > 0 {
        bail!(
            "{failed} of {} inputs failed (see {})",
            rows.len(),
            summary.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_file_names() {
        assert!(matches(b"*.ply", b"scan.ply"));
        assert!(matches(b"s?an*.obj", b"scan01.obj"));
        assert!(!matches(b"*.ply", b"scan.obj"));
        assert!(matches(b"*", b""));
        assert!(!matches(b"a?", b"a"));
    }

    #[test]
    fn colliding_stems_take_their_folder_name() {
        let files: Vec<PathBuf> = [
            "d/block_n1/Noisy.obj",
            "d/cube_n1/Noisy.obj",
            "d/x/other.ply",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        assert_eq!(
            output_stems(&files),
            ["block_n1-Noisy", "cube_n1-Noisy", "other"]
        );
    }
}
