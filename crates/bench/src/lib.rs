//! The bench engine behind `normalnet bench` (the CLI parses its flags into
//! [`BenchOptions`] and reports through [`BenchUi`]): runs methods over noisy/clean pairs (`MODEL/Noisy.obj`
//! and `MODEL/Original.obj`) and writes the comparison in the layout of the
//! paper's Table 3 (`table.md`), plus `results.csv`, `results.json`,
//! `index.html` and, with `--render`, one picture per model with the noisy
//! input, every method and the ground truth side by side, coloured by angular
//! error (SPEC §3 metrics, SPEC §7 NormalNet settings per model).
//!
//! Settings come from a TOML file (`configs/bench.toml`): for each method,
//! `[defaults.METHOD]` then `[models."MODEL".METHOD]` override the method's
//! own defaults key by key; keys are the fields of the method's parameters
//! (`normalnet_denoise`'s one mechanism: what `normalnet denoise --json`
//! prints as `parameters`, and `--param` sets). `[models."MODEL"] view = [az, el]`
//! sets the camera of that model's picture and `skip = ["METHOD", ...]`
//! leaves methods out on that model (shown as `skipped`). A column may be a
//! variant `METHOD-NAME` (e.g. `gnf-ref`, `l0-lambda0.1`): it runs METHOD
//! with the settings under its own name, so one method can appear with
//! several settings side by side. `oracle` runs GT-guided GNF (it reads the
//! ground truth: the ceiling of a perfect NormalNet, shown but never ranked)
//! with the model's NormalNet N_f / N_v / μ_g unless `[..oracle]` says otherwise. A failing method is reported as a
//! failed cell and the bench goes on.
//!
//! `--suite FILE` (e.g. `configs/validation.toml`, `normalnet_denoise::suite`)
//! replaces `--data`: the suite's pairs are generated into `--cache` where
//! missing or out of date, benched like model folders (the pair's name is
//! the model), and `table.md` / `results.json` add each group's means.

//!
//! An application-level library: its errors are `anyhow` chains, because a
//! failed cell of the report keeps the whole chain as its text.

pub mod compare;
mod inputs;
mod picture;
mod run;
mod settings;

pub use run::{BenchOptions, BenchUi, run};
pub use settings::{BUILTIN_SETTINGS, NORMALNET, ORACLE, Settings, base_method};
