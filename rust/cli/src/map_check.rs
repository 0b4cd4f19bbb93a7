//! `fpbp map_check` (being implemented).

/// Arguments of `fpbp map_check`.
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`fpbp map_check` is not implemented yet")
}
