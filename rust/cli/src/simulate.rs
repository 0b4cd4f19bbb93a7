//! `fpbp simulate` (being implemented).

/// Arguments of `fpbp simulate`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp simulate` is not implemented yet")
}
