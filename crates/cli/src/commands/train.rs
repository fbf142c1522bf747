//! `normalnet train` (not built yet).

/// Arguments of `normalnet train`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet train`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet train` is not implemented yet")
}
