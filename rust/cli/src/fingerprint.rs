//! `fpbp fingerprint build`: a walked-survey fingerprint database (BMW eq. 3
//! with start/end compensation, eqs. 4-6 fill, AP clusters + outlier rule)
//! from logs with known points, written as JSON (`fpbp-fingerprints` v1,
//! docs/fingerprints.md). The work is done by
//! `fpbp_core::fingerprint::SurveyBuilder`; this is file glue.
//!
//! Also prints the step-length scale each log's PDR shows against its known
//! points (truth / PDR displacement) and the C (`pdr.step_length_beta`)
//! that would remove it on these logs.

use std::path::PathBuf;

use anyhow::{Context, bail};
use fpbp_core::fingerprint::{FingerprintSet, SurveyBuilder};

use fpbp_eval::eval::{Split, select_logs};

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
    let site = fpbp_eval::runner::load_site(&args.site)?;
    let cfg = fpbp_eval::runner::load_config(args.config.as_deref(), None)?;
    let fcfg = &cfg.ekf.fingerprint;
    let set = if args.model {
        FingerprintSet::model(&site, &cfg.ble, fcfg)
    } else {
        let logs = select_logs(&args.logs, args.split);
        if logs.is_empty() {
            bail!("no logs left after --split {:?}", args.split);
        }
        let opts = fpbp_eval::runner::read_options(&site, args.floor, false);
        let mut b = SurveyBuilder::new(&site, &cfg.ble, &cfg.pdr, fcfg);
        let (mut truth_m, mut pdr_m) = (0.0, 0.0);
        println!(
            "{:<48} {:>8} {:>8} {:>8} {:>7} {:>10}",
            "log", "segments", "skipped", "samples", "steps", "truth/pdr"
        );
        for path in &logs {
            let log = fpbp_eval::runner::load_log(path, &opts)?;
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
                fpbp_eval::metrics::fmt_opt(rep.step_scale(), 3)
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

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_eval::engine_data::load;

    fn repo() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    #[test]
    fn bad_input_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("fpbp-fp-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let site_path = repo().join("maps/demo/site.json");
        let site = fpbp_eval::runner::load_site(&site_path).unwrap();
        let cfg = fpbp_core::engines::EngineConfig::default();
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
