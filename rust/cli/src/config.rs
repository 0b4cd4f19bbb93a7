//! `fpbp config`: an engine's settings as the JSON `--config` reads
//! (`fpbp_core::engines::engine_settings_json`), the defaults or a config
//! file's values over them. File glue only.

use std::path::PathBuf;

/// Arguments of `fpbp config`.
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The engine whose settings to print (`fpbp eval --engine` names).
    #[arg(long, default_value = "tcpf")]
    pub engine: String,
    /// A config (JSON file, or the JSON itself) to print with every
    /// setting it leaves out at its default; without it, the defaults.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = fpbp_eval::runner::load_config(args.config.as_deref(), None)?;
    let text = fpbp_core::engines::engine_settings_json(&args.engine, &cfg)?;
    print!("{text}");
    Ok(())
}
