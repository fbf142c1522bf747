//! `normalnet info` (not built yet).

/// Arguments of `normalnet info`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet info`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet info` is not implemented yet")
}
