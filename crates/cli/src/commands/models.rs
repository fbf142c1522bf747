//! `normalnet models`: what a NormalNet model bundle is (preset, voxel grid,
//! training data, per-network validation errors) — the built-in one by
//! default — and `normalnet models convert` for bundles of format 1.

use std::io::Write;
use std::path::PathBuf;

use normalnet_denoise::normalnet::NormalnetParams;
use normalnet_net::Bundle;
use normalnet_net::Int8Range;

/// Arguments of `normalnet models`.
#[derive(clap::Args)]
pub struct Args {
    /// Bundle folder to describe (default: `$NORMALNET_MODEL`, else the
    /// built-in models/lite).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Print the description as JSON (the whole manifest).
    #[arg(long)]
    pub json: bool,
    #[command(subcommand)]
    pub action: Option<Action>,
}

/// What `normalnet models` does besides describing.
#[derive(clap::Subcommand)]
pub enum Action {
    /// Convert a format-1 bundle (burn records, net1.bpk ...) into a
    /// format-2 bundle (safetensors) in a new folder (needs a build with
    /// `--features burn`).
    Convert {
        /// the format-1 bundle folder
        from: PathBuf,
        /// the new folder
        to: PathBuf,
    },
}

/// Runs `normalnet models`.
pub fn run(args: Args, _quiet: bool) -> anyhow::Result<()> {
    if let Some(Action::Convert { from, to }) = &args.action {
        return convert(from, to);
    }
    let bundle = NormalnetParams {
        model: args.model.clone(),
        ..NormalnetParams::default()
    }
    .load_bundle()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        let mut v = serde_json::to_value(&bundle.manifest)?;
        v["isa"] = normalnet_denoise::isa::active().name().into();
        v["int8_range"] = bundle.manifest.int8_range.name().into();
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        write!(out, "{}", describe(&bundle))?;
        writeln!(out, "kernels     {}", kernel_paths())?;
    }
    Ok(())
}

/// The kernel path that runs and the best this CPU has, e.g. `avx2 (forced
/// by NORMALNET_ISA; the CPU runs up to avx512vnni)`.
fn kernel_paths() -> String {
    use normalnet_denoise::isa::{self, Isa};
    let (active, detected) = (isa::active(), Isa::detected());
    if std::env::var_os(isa::ENV).is_some() {
        format!(
            "{active} (forced by {}; the CPU runs up to {detected})",
            isa::ENV
        )
    } else {
        format!("{active} (the best this CPU runs)")
    }
}

/// A few lines saying what `bundle` is.
pub fn describe(bundle: &Bundle) -> String {
    let m = &bundle.manifest;
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(format!("bundle      {}", bundle.path.display()));
    line(format!(
        "preset      {} (grid {}³, channels {:?}, hidden {:?}); format {}",
        m.preset, m.model.grid, m.model.channels, m.model.hidden, m.format
    ));
    line(format!(
        "voxel       T_s {}, alpha_c {}; outputs for mu_g {:?}",
        m.voxel.t_s, m.voxel.alpha_c, m.mu_gs
    ));
    line(format!("code        {}", m.code_version));
    // what the default arithmetic runs on this process's kernel path
    let isa = normalnet_denoise::isa::active();
    line(format!(
        "int8        {} ranges ({}); on {isa} the default runs {}",
        m.int8_range.name(),
        match m.int8_range {
            Int8Range::Full => "block inputs 0..=255, weights ±127, stem inputs ±127",
            Int8Range::Narrow => "block inputs 0..=127, weights ±63, stem inputs ±63",
        },
        match isa.has_avx2() {
            true => m.int8_range.default_on(isa).name(),
            false => "f32 (no int8 kernels)",
        }
    ));
    line(format!(
        "training    {} sources, validation on {}; seed {}, batch {}",
        m.training.sources.len(),
        m.training.validation.join(", "),
        m.training.seed,
        m.training.batch
    ));
    line("network  iterations  samples   seconds  validation E (input)  form".into());
    for (i, n) in m.networks.iter().enumerate() {
        let last = if n.interval[1] == 0 {
            "N_f".to_string()
        } else {
            n.interval[1].to_string()
        };
        line(format!(
            "{:>7}  {:>4}-{:<5}  {:>7}  {:>8.0}  {:>6.2}° ({:>6.2}°)     {}",
            i + 1,
            n.interval[0],
            last,
            n.samples_seen,
            n.train_seconds,
            n.validation_error_deg,
            n.validation_baseline_deg,
            if n.residual { "residual" } else { "normal" }
        ));
    }
    match &m.switch {
        Some(w) => {
            let notes = if w.notes.is_empty() {
                String::new()
            } else {
                format!("\n            {}", w.notes)
            };
            let candidates = |t: &normalnet_net::switch::SwitchWeights| {
                normalnet_net::switch::CANDIDATES[..t.num_candidates()].join(", ")
            };
            let late = match &w.late {
                Some(late) => format!(
                    "\n            after iteration {}: a late table, {} hidden units, candidates {}; {}",
                    w.max_iteration,
                    late.hidden,
                    candidates(late),
                    late.notes
                ),
                None => String::new(),
            };
            let heavy = match &w.heavy {
                Some(heavy) => format!(
                    "\n            runs with noise level ≥ {:.3} rad in iteration 1: a heavy-noise table, {} hidden units, candidates {}; {}",
                    heavy.from_noise_level,
                    heavy.table.hidden,
                    candidates(&heavy.table),
                    heavy.table.notes
                ),
                None => String::new(),
            };
            line(format!(
                "switch      learned, {} hidden units, candidates {} (--no-switch: the paper's form){notes}{heavy}{late}",
                w.hidden,
                candidates(w),
            ))
        }
        None => line("switch      none (the paper's form)".into()),
    }
    s
}

#[cfg(feature = "burn")]
fn convert(from: &std::path::Path, to: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context;
    crate::output::check_dir(to)?;
    let manifest = normalnet_net::convert::convert_format1(from, to)
        .with_context(|| format!("converting {} into {}", from.display(), to.display()))?;
    let bundle = Bundle::load(to).with_context(|| format!("reading back {}", to.display()))?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{} ({} preset) converted to format {} in {}",
        from.display(),
        manifest.preset,
        manifest.format,
        to.display()
    )?;
    write!(out, "{}", describe(&bundle))?;
    Ok(())
}

#[cfg(not(feature = "burn"))]
fn convert(from: &std::path::Path, _to: &std::path::Path) -> anyhow::Result<()> {
    anyhow::bail!(
        "converting {} needs burn to read format-1 records: build with \
         `cargo build --release --features burn` (or `cargo run --release --features burn -- models convert ...`)",
        from.display()
    )
}
