//! `normalnet bench` (not built yet).

/// Arguments of `normalnet bench`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet bench`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet bench` is not implemented yet")
}
