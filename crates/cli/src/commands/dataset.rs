//! `normalnet dataset` (not built yet).

/// Arguments of `normalnet dataset`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet dataset`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet dataset` is not implemented yet")
}
