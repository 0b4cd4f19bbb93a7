//! `fpbp eval` (being implemented).

/// Arguments of `fpbp eval`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp eval` is not implemented yet")
}
