//! `normalnet voxelize` (not built yet).

/// Arguments of `normalnet voxelize`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet voxelize`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet voxelize` is not implemented yet")
}
