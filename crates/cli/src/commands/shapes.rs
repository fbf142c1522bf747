//! `normalnet shapes` (not built yet).

/// Arguments of `normalnet shapes`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `normalnet shapes`.
pub fn run(_args: Args, _quiet: bool) -> anyhow::Result<()> {
    anyhow::bail!("`normalnet shapes` is not implemented yet")
}
