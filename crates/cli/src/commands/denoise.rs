//! `normalnet denoise` (not built yet).

/// Arguments of `normalnet denoise`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet denoise`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet denoise` is not implemented yet")
}
