//! Pure-Rust reference replay for the JVM host tests (host-tests/jvm).
//!
//! Loads a site exactly as the JNI `start` does ([`fpbp::site_loader`]),
//! builds the engine with `fpbp_core::engines::build_engine`, replays a log with
//! `fpbp_core::engine::replay` and writes the track with every f64 as the hex
//! of its bits, so the JVM side can check bit-for-bit equality:
//!
//! ```text
//! # fpbp-replay-reference 2 engine=fpbp events=12345
//! # stats {"engine":"fpbp",...}
//! <t_ns> <x bits> <y bits> <floor> <heading bits> <accuracy bits> <floor_prob bits> <source code>
//! ```
//!
//! Usage: `replay_reference --site SITE.json --log LOG --engine NAME
//! [--config CONFIG.json] [--init-first-truth] --out TRACK.txt`

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use fpbp::session::Session;
use fpbp_core::engine::{InitialPosition, replay::replay};
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::LogEvent;

struct Args {
    site: PathBuf,
    log: PathBuf,
    engine: String,
    config: Option<PathBuf>,
    init_first_truth: bool,
    out: PathBuf,
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let (mut site, mut log, mut engine, mut config, mut out) = (None, None, None, None, None);
    let mut init_first_truth = false;
    while let Some(a) = it.next() {
        let mut val = || it.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--site" => site = Some(PathBuf::from(val()?)),
            "--log" => log = Some(PathBuf::from(val()?)),
            "--engine" => engine = Some(val()?),
            "--config" => config = Some(PathBuf::from(val()?)),
            "--out" => out = Some(PathBuf::from(val()?)),
            "--init-first-truth" => init_first_truth = true,
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(Args {
        site: site.ok_or("--site is required")?,
        log: log.ok_or("--log is required")?,
        engine: engine.ok_or("--engine is required")?,
        config,
        init_first_truth,
        out: out.ok_or("--out is required")?,
    })
}

fn bits(v: f64) -> String {
    format!("{:016x}", v.to_bits())
}

fn run(a: &Args) -> Result<(), String> {
    let site_json =
        std::fs::read_to_string(&a.site).map_err(|e| format!("{}: {e}", a.site.display()))?;
    let site_dir = a.site.parent().unwrap_or(Path::new("."));
    let site = fpbp::site_loader::load_site(&site_json, site_dir).map_err(|e| e.to_string())?;
    let config = match &a.config {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            EngineConfig::from_json(&text).map_err(|e| format!("{}: {e}", p.display()))?
        }
        None => EngineConfig::default(),
    };
    let opts = fpbp_logs::ReadOptions {
        default_floor: Some(site.default_floor()),
        ..Default::default()
    };
    let (events, _report) = fpbp_logs::read_all(&a.log, &opts).map_err(|e| e.to_string())?;
    let init = if a.init_first_truth {
        events
            .iter()
            .find_map(LogEvent::as_truth)
            .map(|t| InitialPosition {
                x_m: t.x_m,
                y_m: t.y_m,
                floor: t.floor.unwrap_or(0),
                heading_rad: None,
            })
    } else {
        None
    };
    let n = events.len();
    let mut engine =
        build_engine(&a.engine, Arc::new(site), &config, init).map_err(|e| e.to_string())?;
    let out = replay(engine.as_mut(), events);
    // Stats as the JNI `stats` call reports them.
    let stats = Session::from_engine(engine).snapshot().stats_json();
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?,
    );
    let mut put = || -> std::io::Result<()> {
        writeln!(
            w,
            "# fpbp-replay-reference 2 engine={} events={n}",
            a.engine
        )?;
        writeln!(w, "# stats {stats}")?;
        for p in &out.track {
            writeln!(
                w,
                "{} {} {} {} {} {} {} {}",
                p.t_ns,
                bits(p.x_m),
                bits(p.y_m),
                p.floor,
                bits(p.heading_rad),
                bits(p.accuracy_m),
                bits(p.floor_prob),
                p.source.code()
            )?;
        }
        w.flush()
    };
    put().map_err(|e| format!("{}: {e}", a.out.display()))?;
    eprintln!(
        "replay_reference: {} events, {} track poses -> {}",
        n,
        out.track.len(),
        a.out.display()
    );
    Ok(())
}

fn main() -> ExitCode {
    match parse_args().and_then(|a| run(&a)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("replay_reference: {e}");
            ExitCode::FAILURE
        }
    }
}
