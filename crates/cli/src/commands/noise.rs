//! `normalnet noise` (not built yet).

/// Arguments of `normalnet noise`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet noise`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet noise` is not implemented yet")
}
