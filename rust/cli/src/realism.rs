//! `fpbp realism` (being implemented).

/// Arguments of `fpbp realism`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp realism` is not implemented yet")
}
