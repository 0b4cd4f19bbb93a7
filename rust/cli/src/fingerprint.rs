//! `fpbp fingerprint build`: a walked-survey fingerprint database (BMW eq. 3
//! with start/end compensation, eqs. 4-6 fill, AP clusters + outlier rule)
//! from logs with known points, written as JSON (`fpbp-fingerprints` v1,
//! docs/fingerprints.md). The work is done by
//! `fpbp_core::fingerprint::SurveyBuilder`; this is file glue.
//!
//! Also prints the step-length scale each log's PDR shows against its known
//! points (truth / PDR displacement) and the C (`pdr.step_length_beta`)
//! that would remove it on these logs.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, bail};
use fpbp_core::engine::EngineData;
use fpbp_core::fingerprint::{FingerprintSet, SurveyBuilder};
use fpbp_core::site::Site;

use crate::common;
use crate::eval::{Split, select_logs};

/// `fpbp fingerprint ...`
#[derive(clap::Subcommand)]
pub enum Command {
    /// Build a fingerprint database from walked survey logs with known points.
    Build(BuildArgs),
}

/// Arguments of `fpbp fingerprint build`.
#[derive(clap::Args, Debug)]
pub struct BuildArgs {
    /// Site file (site.json) the logs were walked on.
    #[arg(long)]
    pub site: PathBuf,
    /// Survey logs with known points (ILC waypoints, IPIN/native truth; gzip ok).
    #[arg(long, num_args = 1.., required = true)]
    pub logs: Vec<PathBuf>,
    /// Use only this half of the logs (sorted by file name).
    #[arg(long, value_enum, default_value = "all")]
    pub split: Split,
    /// Engine config JSON (`ble`, `pdr` and `ekf.fingerprint` sections are used).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Floor of known points whose log does not say (ILC); default: the site's floor when it has one.
    #[arg(long, allow_hyphen_values = true)]
    pub floor: Option<i32>,
    /// Output file (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Write the site's model database instead (path-loss models at grid points; no logs read).
    #[arg(long)]
    pub model: bool,
}

pub fn run(cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Build(a) => build(&a),
    }
}

fn build(args: &BuildArgs) -> anyhow::Result<()> {
    let site = common::load_site(&args.site)?;
    let cfg = common::load_config(args.config.as_deref(), None)?;
    let fcfg = &cfg.ekf.fingerprint;
    let set = if args.model {
        FingerprintSet::model(&site, &cfg.ble, fcfg)
    } else {
        let logs = select_logs(&args.logs, args.split);
        if logs.is_empty() {
            bail!("no logs left after --split {:?}", args.split);
        }
        let opts = common::read_options(&site, args.floor, false);
        let mut b = SurveyBuilder::new(&site, &cfg.ble, &cfg.pdr, fcfg);
        let (mut truth_m, mut pdr_m) = (0.0, 0.0);
        println!(
            "{:<48} {:>8} {:>8} {:>8} {:>7} {:>10}",
            "log", "segments", "skipped", "samples", "steps", "truth/pdr"
        );
        for path in &logs {
            let log = common::load_log(path, &opts)?;
            let rep = b.add_log(&log.events);
            truth_m += rep.truth_displacement_m;
            pdr_m += rep.pdr_displacement_m;
            println!(
                "{:<48} {:>8} {:>8} {:>8} {:>7} {:>10}",
                log.name,
                rep.segments,
                rep.segments_skipped,
                rep.samples,
                rep.steps,
                common::fmt_opt(rep.step_scale(), 3)
            );
        }
        if b.samples() == 0 {
            bail!(
                "no RSSI sample could be placed: the logs have no two consecutive known points on \
                 one floor with BLE of that floor's site beacons between them (floor ids of the \
                 truth vs site.json? --floor?)"
            );
        }
        if pdr_m > 1.0 {
            println!(
                "step length: truth/PDR displacement {:.3} over {:.0} m -> C = pdr.step_length_beta {:.3} (now {:.3})",
                truth_m / pdr_m,
                truth_m,
                cfg.pdr.step_length_beta * truth_m / pdr_m,
                cfg.pdr.step_length_beta
            );
        }
        b.finish()
    };
    for (floor, f) in &set.floors {
        let outliers = f.sub.reassigned;
        println!(
            "floor {floor}: {} points, {} beacons, {} clusters, {} outliers reassigned",
            f.db.points.len(),
            f.db.beacons.len(),
            f.sub.members.iter().filter(|m| !m.is_empty()).count(),
            outliers
        );
    }
    let file = set.to_file(&site);
    let text = serde_json::to_string(&file)? + "\n";
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    std::fs::write(&args.out, text)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    println!(
        "wrote {} ({} points on {} floors)",
        args.out.display(),
        set.points(),
        set.floors.len()
    );
    Ok(())
}

/// Reads a fingerprint database file and resolves it against `site`
/// (errors name the file, and the field or line at fault).
pub fn load(
    path: &Path,
    site: &Site,
    cfg: &fpbp_core::engine::EngineConfig,
) -> anyhow::Result<FingerprintSet> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read fingerprint database {}", path.display()))?;
    FingerprintSet::from_json(&text, site, &cfg.ble).with_context(|| format!("{}", path.display()))
}

/// The engine data of an eval: the database of `--fingerprints FILE`, else,
/// when `engines` include `robust-ekf`, the site's model database built once
/// here (instead of once per log inside each engine).
pub fn engine_data(
    path: Option<&Path>,
    engines: &[String],
    site: &Arc<Site>,
    cfg: &fpbp_core::engine::EngineConfig,
) -> anyhow::Result<EngineData> {
    let fingerprints = match path {
        Some(p) => Some(Arc::new(load(p, site, cfg)?)),
        None if engines.iter().any(|e| e.trim() == "robust-ekf") => Some(Arc::new(
            FingerprintSet::model(site, &cfg.ble, &cfg.ekf.fingerprint),
        )),
        None => None,
    };
    Ok(EngineData {
        fingerprints,
        ..EngineData::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repo() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    #[test]
    fn bad_input_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("fpbp-fp-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let site_path = repo().join("maps/demo/site.json");
        let site = common::load_site(&site_path).unwrap();
        let cfg = fpbp_core::engine::EngineConfig::default();
        // missing file
        let missing = dir.join("nope.json");
        let e = format!("{:#}", load(&missing, &site, &cfg).unwrap_err());
        assert!(e.contains("nope.json"), "{e}");
        // syntax error: file and line
        let bad = dir.join("bad.json");
        std::fs::write(&bad, "{\n\"format\": \"fpbp-fingerprints\",\n oops").unwrap();
        let e = format!("{:#}", load(&bad, &site, &cfg).unwrap_err());
        assert!(e.contains("bad.json") && e.contains("line 3"), "{e}");
        // a beacon the site does not have: file and field
        let alien = dir.join("alien.json");
        std::fs::write(
            &alien,
            r#"{"format":"fpbp-fingerprints","version":1,"site":"x","source":"survey","floors":[
               {"floor":0,"missing_rssi_dbm":-100,"beacons":["mac:11:22:33:44:55:66"],
                "clusters":1,"reassigned":0,"points":[{"x_m":1,"y_m":1,"cluster":0,"rssi_dbm":[-70]}]}]}"#,
        )
        .unwrap();
        let e = format!("{:#}", load(&alien, &site, &cfg).unwrap_err());
        assert!(
            e.contains("alien.json") && e.contains("floors[0].beacons[0]"),
            "{e}"
        );
        // build: a log file that does not exist is named
        let e = build(&BuildArgs {
            site: site_path.clone(),
            logs: vec![dir.join("missing-log.txt")],
            split: Split::All,
            config: None,
            floor: None,
            out: dir.join("fp.json"),
            model: false,
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("missing-log.txt"), "{e:#}");
        // build from the shipped simulated logs (truth every second) and use it
        let logs: Vec<PathBuf> = std::fs::read_dir(repo().join("host-tests/logs"))
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.to_string_lossy().ends_with(".log.gz"))
            .collect();
        assert!(!logs.is_empty());
        let out = dir.join("fp.json");
        build(&BuildArgs {
            site: site_path,
            logs,
            split: Split::All,
            config: None,
            floor: None,
            out: out.clone(),
            model: false,
        })
        .unwrap();
        let set = load(&out, &site, &cfg).unwrap();
        assert!(set.points() > 50, "{}", set.points());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
