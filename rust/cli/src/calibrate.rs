//! `fpbp calibrate` (being implemented).

/// Arguments of `fpbp calibrate`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp calibrate` is not implemented yet")
}
