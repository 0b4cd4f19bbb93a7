//! `fpbp simulate`: a simulated walk on a site, written as a native log
//! (gzip when the output name ends in `.gz`) with ground truth at every step
//! and at 10 Hz. The same site, profile and seed give the same file byte
//! for byte.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use fpbp_logs::native::{NativeHeader, NativeWriter};
use fpbp_sim::{SimLog, SimProfile, SimRequest};

/// Arguments of `fpbp simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Site file (site.json).
    #[arg(long)]
    pub site: PathBuf,
    /// Length of the log, seconds (0 < s <= 86400).
    #[arg(long, default_value_t = 180.0, allow_hyphen_values = true, value_parser = seconds_arg)]
    pub seconds: f64,
    /// Seed of the simulator's random generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output log (native format; gzip if the name ends in .gz).
    #[arg(long)]
    pub out: PathBuf,
    /// Profile: a name (default, swinging, ilc-like, ipin-like, wifi, wifi-throttled) or a JSON file
    /// of `SimProfile` (missing fields take the defaults).
    #[arg(long, default_value = "default")]
    pub profile: String,
    /// Floor to walk on (default: the site's first floor).
    #[arg(long)]
    pub floor: Option<i32>,
    /// Fraction of adverts given an extra NLOS attenuation (overrides the profile).
    #[arg(long)]
    pub nlos_rate: Option<f64>,
    /// RSSI bias of the simulated phone, dB (overrides the profile).
    #[arg(long, allow_hyphen_values = true)]
    pub rssi_bias_dbm: Option<f64>,
}

/// `--seconds`: a finite number of seconds in (0, 86400].
fn seconds_arg(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| {
        format!(
            "`{}` is not a number of seconds",
            fpbp_core::bounds::echo(s)
        )
    })?;
    if v.is_finite() && v > 0.0 && v <= 86_400.0 {
        Ok(v)
    } else {
        Err(format!("must be in (0, 86400] seconds, got {v}"))
    }
}

/// Resolves `--profile`: a known name or a JSON file.
pub fn load_profile(spec: &str) -> Result<SimProfile> {
    if spec.ends_with(".json") {
        let bytes = std::fs::read(spec).with_context(|| format!("reading profile {spec}"))?;
        let mut p: SimProfile =
            serde_json::from_slice(&bytes).with_context(|| format!("parsing profile {spec}"))?;
        if p.name == "default" {
            p.name = Path::new(spec)
                .file_stem()
                .map_or("custom".into(), |s| s.to_string_lossy().into_owned());
        }
        Ok(p)
    } else {
        Ok(SimProfile::named(spec)?)
    }
}

/// The native header of a simulated log.
pub fn header_of(log: &SimLog, site_file: &str) -> Result<NativeHeader> {
    let h = &log.header;
    Ok(NativeHeader::new()
        .with("device", "fpbp-sim")
        .with(
            "generator",
            format!("{} {}", h.generator, h.generator_version),
        )
        .with("site", h.site_name.clone())
        .with("site_file", site_file)
        .with("floor", h.floor.to_string())
        .with("seed", h.seed.to_string())
        .with("duration_s", h.duration_s.to_string())
        .with("t0_ns", h.t0_ns.to_string())
        .with("steps", h.steps.to_string())
        .with("distance_m", format!("{:.3}", h.distance_m))
        .with("profile_name", h.profile.name.clone())
        .with("profile", serde_json::to_string(&h.profile)?))
}

/// Writes `log` to `out` (gzip when the name ends in .gz).
pub fn write_log(log: &SimLog, site_file: &str, out: &Path) -> Result<()> {
    let header = header_of(log, site_file)?;
    let f = File::create(out).with_context(|| format!("creating {}", out.display()))?;
    let w: Box<dyn Write> = if out.extension().is_some_and(|e| e == "gz") {
        // GzEncoder writes mtime 0 and no file name: the bytes depend on the content only.
        Box::new(flate2::write::GzEncoder::new(
            BufWriter::new(f),
            flate2::Compression::best(),
        ))
    } else {
        Box::new(BufWriter::new(f))
    };
    // v1 when the log has no WiFi: logs without WiFi stay byte for byte what
    // they were, and readers that know only v1 (the Kotlin recorder's) read them.
    let version = if log
        .events
        .iter()
        .any(|e| matches!(e, fpbp_core::events::LogEvent::Wifi(_)))
    {
        fpbp_logs::native::VERSION
    } else {
        1
    };
    let mut nw = NativeWriter::with_version(w, &header, version)
        .with_context(|| format!("writing {}", out.display()))?;
    for e in &log.events {
        nw.write(e)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    let w = nw
        .finish()
        .with_context(|| format!("writing {}", out.display()))?;
    drop(w);
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    let site = fpbp_core::site::files::load_site(&args.site)?;
    let mut profile = load_profile(&args.profile)?;
    if let Some(x) = args.nlos_rate {
        profile.ble.nlos_rate = x;
    }
    if let Some(b) = args.rssi_bias_dbm {
        profile.ble.device_bias_dbm = b;
    }
    let mut req = SimRequest::new(args.seconds, args.seed);
    req.floor = args.floor;
    req.profile = profile;
    let bar = fpbp_eval::progress::spinner(format!("simulating {} s of walking", args.seconds));
    let log = fpbp_sim::simulate(&site, &req)
        .with_context(|| format!("simulating on {}", args.site.display()))?;
    bar.set_message(format!("writing {}", args.out.display()));
    let site_file = args
        .site
        .file_name()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    write_log(&log, &site_file, &args.out)?;
    bar.finish_and_clear();
    let ble = log
        .events
        .iter()
        .filter(|e| matches!(e, fpbp_core::events::LogEvent::Ble(_)))
        .count();
    let wifi = log
        .events
        .iter()
        .filter(|e| matches!(e, fpbp_core::events::LogEvent::Wifi(_)))
        .count();
    println!(
        "wrote {}: {} events, {:.0} s, {} steps, {:.1} m walked, {} BLE reports, {} WiFi scans, floor {}, profile {}",
        args.out.display(),
        log.events.len(),
        log.header.duration_s,
        log.header.steps,
        log.header.distance_m,
        ble,
        wifi,
        log.header.floor,
        log.header.profile.name
    );
    Ok(())
}
