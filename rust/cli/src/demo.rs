//! `fpbp demo` (being implemented).

/// Arguments of `fpbp demo`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp demo` is not implemented yet")
}
