//! `normalnet render` (not built yet).

/// Arguments of `normalnet render`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet render`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet render` is not implemented yet")
}
