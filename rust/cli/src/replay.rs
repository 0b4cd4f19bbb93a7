//! `fpbp replay` (being implemented).

/// Arguments of `fpbp replay`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp replay` is not implemented yet")
}
