//! `normalnet metrics` (not built yet).

/// Arguments of `normalnet metrics`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet metrics`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet metrics` is not implemented yet")
}
