//! `fpbp realism`: simulated and real logs side by side: step frequency,
//! vertical acceleration peak-to-peak (p10/p50/p90), BLE report rate and
//! per-beacon repeat interval, and the RSSI-versus-distance slope (for
//! simulated logs against the site's beacons; for IPIN logs against
//! BLE_Locations.csv through the map georeference of the dataset README;
//! ILC gives no beacon positions). Every figure is computed by the same code
//! (`fpbp_sim::stats`) for every log; a group's column is the median over
//! its logs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::geo::mcs_from_wgs84;
use fpbp_core::site::GeoRef;
use fpbp_logs::{LogFormat, ReadOptions, open_log};
use fpbp_sim::stats::{KnownBeacon, Realism, realism};

/// Arguments of `fpbp realism`.
#[derive(clap::Args)]
pub struct Args {
    /// Simulated logs (native).
    #[arg(long, num_args = 1..)]
    pub sim: Vec<PathBuf>,
    /// Site of the simulated logs (its beacons give their RSSI slope).
    #[arg(long)]
    pub site: Option<PathBuf>,
    /// Real logs (ILC, IPIN or native; format detected).
    #[arg(long, num_args = 1..)]
    pub real: Vec<PathBuf>,
    /// IPIN beacon positions (BLE_Locations.csv); default: ../BLE_Locations.csv
    /// next to the first IPIN log's folder.
    #[arg(long)]
    pub ipin_beacons: Option<PathBuf>,
    /// Also print one column per log.
    #[arg(long)]
    pub per_log: bool,
    /// Write every log's figures as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// The IPIN 2023 map centre and rotation (datasets/README.md, "Map
/// georeference"): MCS = local east/north metres at the centre, so the
/// rotation is 0 and beacons and POSI truth share the frame.
const IPIN_CENTRE_LAT_DEG: f64 = 49.461_151_81;
const IPIN_CENTRE_LON_DEG: f64 = 11.111_149_11;
const IPIN_UUID: &str = "11111111-1111-BEAC-2023-111111111111";

fn ipin_georef() -> GeoRef {
    GeoRef {
        lat_deg: IPIN_CENTRE_LAT_DEG,
        lon_deg: IPIN_CENTRE_LON_DEG,
        x_m: 0.0,
        y_m: 0.0,
    }
}

/// Reads BLE_Locations.csv into known beacons keyed by the logs' ids.
/// Minor n is BLEn, except minors 2 and 3, which are BLE3 and BLE2
/// (datasets/README.md, "BLE beacon id mapping").
fn ipin_beacons(path: &Path) -> Result<BTreeMap<String, KnownBeacon>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let g = ipin_georef();
    let mut out = BTreeMap::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line
            .split(',')
            .map(|s| s.trim().trim_matches('"'))
            .collect();
        let at = || format!("{}:{}", path.display(), i + 1);
        if f.len() < 4 {
            bail!("{}: expected bleID,Lat,Lon,floor", at());
        }
        let n: u32 = f[0]
            .strip_prefix("BLE")
            .and_then(|s| s.parse().ok())
            .with_context(|| format!("{}: bad bleID `{}`", at(), f[0]))?;
        let lat: f64 = f[1].parse().with_context(|| format!("{}: bad Lat", at()))?;
        let lon: f64 = f[2].parse().with_context(|| format!("{}: bad Lon", at()))?;
        let floor: i32 = f[3]
            .parse()
            .with_context(|| format!("{}: bad floor", at()))?;
        let minor = match n {
            2 => 3,
            3 => 2,
            k => k,
        };
        let p: Vec2 = mcs_from_wgs84(&g, 0.0, lat, lon);
        out.insert(
            format!("ibeacon:{IPIN_UUID}:1:{minor}"),
            KnownBeacon {
                x_m: p.x,
                y_m: p.y,
                floor,
            },
        );
    }
    Ok(out)
}

struct Row {
    group: String,
    file: String,
    r: Realism,
}

fn read_events(
    path: &Path,
    opts: &ReadOptions,
) -> Result<(Vec<fpbp_core::events::LogEvent>, LogFormat)> {
    let mut reader = open_log(path, opts).with_context(|| format!("opening {}", path.display()))?;
    let format = reader.format();
    let mut ev = Vec::new();
    while let Some(e) = reader
        .try_next()
        .with_context(|| format!("reading {}", path.display()))?
    {
        ev.push(e);
    }
    Ok((ev, format))
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    fpbp_core::stats::median(&v)
}

pub fn run(args: Args) -> Result<()> {
    if args.sim.is_empty() && args.real.is_empty() {
        bail!("give at least one log with --sim or --real");
    }
    let mut rows: Vec<Row> = Vec::new();
    let sim_beacons: BTreeMap<String, KnownBeacon> = match &args.site {
        Some(p) => {
            let site = fpbp_core::site::files::load_site(p)?;
            site.spec
                .beacons
                .iter()
                .map(|b| {
                    (
                        b.id.clone(),
                        KnownBeacon {
                            x_m: b.x_m,
                            y_m: b.y_m,
                            floor: b.floor,
                        },
                    )
                })
                .collect()
        }
        None => BTreeMap::new(),
    };
    for p in &args.sim {
        let (ev, _) = read_events(p, &ReadOptions::default())?;
        rows.push(Row {
            group: "sim".into(),
            file: p.display().to_string(),
            r: realism(&ev, &sim_beacons),
        });
    }
    let mut ipin_known: Option<BTreeMap<String, KnownBeacon>> = None;
    let ipin_opts = ReadOptions {
        site_georef: Some((ipin_georef(), 0.0)),
        ..ReadOptions::default()
    };
    for p in &args.real {
        let (ev, format) = read_events(p, &ipin_opts)?;
        let (group, known) = match format {
            LogFormat::Ipin => {
                if ipin_known.is_none() {
                    let csv = match &args.ipin_beacons {
                        Some(c) => c.clone(),
                        None => p
                            .parent()
                            .and_then(|d| d.parent())
                            .map(|d| d.join("BLE_Locations.csv"))
                            .unwrap_or_default(),
                    };
                    ipin_known = Some(if csv.is_file() {
                        ipin_beacons(&csv)?
                    } else {
                        eprintln!(
                            "note: {} not found: no RSSI slope for IPIN logs",
                            csv.display()
                        );
                        BTreeMap::new()
                    });
                }
                ("IPIN", ipin_known.clone().unwrap_or_default())
            }
            LogFormat::Ilc => ("ILC", BTreeMap::new()),
            LogFormat::Native => ("native", BTreeMap::new()),
        };
        rows.push(Row {
            group: group.into(),
            file: p.display().to_string(),
            r: realism(&ev, &known),
        });
    }

    // Columns: each group (median over its logs), then per log if asked.
    let mut groups: Vec<String> = Vec::new();
    for r in &rows {
        if !groups.contains(&r.group) {
            groups.push(r.group.clone());
        }
    }
    type Getter = fn(&Realism) -> Option<f64>;
    let metrics: Vec<(&str, Getter)> = vec![
        ("duration s", |r| Some(r.duration_s)),
        ("steps detected", |r| Some(r.gait.steps as f64)),
        ("step frequency Hz", |r| r.gait.step_freq_hz),
        ("vert. acc p-p p10 m/s2", |r| r.gait.pp_p10_mps2),
        ("vert. acc p-p p50 m/s2", |r| r.gait.pp_p50_mps2),
        ("vert. acc p-p p90 m/s2", |r| r.gait.pp_p90_mps2),
        ("BLE reports /s", |r| Some(r.ble.reports_per_s)),
        ("BLE ids heard", |r| Some(r.ble.beacons as f64)),
        ("same-id repeat p25 s", |r| r.ble.repeat_p25_s),
        ("same-id repeat p50 s", |r| r.ble.repeat_p50_s),
        ("same-id repeat p75 s", |r| r.ble.repeat_p75_s),
        ("RSSI median dBm", |r| r.ble.rssi_p50_dbm),
        ("RSSI slope dB/decade", |r| {
            r.rssi.as_ref().map(|s| s.slope_db_per_decade)
        }),
        ("  fit RSSI at 1 m dBm", |r| {
            r.rssi.as_ref().map(|s| s.intercept_dbm)
        }),
        ("  fit residual sigma dB", |r| {
            r.rssi.as_ref().map(|s| s.residual_sigma_db)
        }),
        ("  fit points", |r| r.rssi.as_ref().map(|s| s.points as f64)),
    ];
    let mut header = vec!["metric".to_string()];
    for g in &groups {
        let n = rows.iter().filter(|r| &r.group == g).count();
        header.push(format!("{g} ({n} logs)"));
    }
    if args.per_log {
        for r in &rows {
            let name = Path::new(&r.file)
                .file_name()
                .map_or(r.file.clone(), |s| s.to_string_lossy().into_owned());
            header.push(name.chars().take(28).collect());
        }
    }
    let fmt = |v: Option<f64>| v.map_or("n/a".to_string(), |x| format!("{x:.2}"));
    let mut table: Vec<Vec<String>> = vec![header];
    for (name, get) in &metrics {
        let mut line = vec![name.to_string()];
        for g in &groups {
            let vals: Vec<f64> = rows
                .iter()
                .filter(|r| &r.group == g)
                .filter_map(|r| get(&r.r))
                .collect();
            line.push(fmt(median(vals)));
        }
        if args.per_log {
            for r in &rows {
                line.push(fmt(get(&r.r)));
            }
        }
        table.push(line);
    }
    let ncol = table[0].len();
    let widths: Vec<usize> = (0..ncol)
        .map(|c| table.iter().map(|l| l[c].len()).max().unwrap_or(0))
        .collect();
    for (i, l) in table.iter().enumerate() {
        let cells: Vec<String> = l
            .iter()
            .enumerate()
            .map(|(c, s)| {
                if c == 0 {
                    format!("{s:<w$}", w = widths[c])
                } else {
                    format!("{s:>w$}", w = widths[c])
                }
            })
            .collect();
        println!("| {} |", cells.join(" | "));
        if i == 0 {
            let sep: Vec<String> = widths.iter().map(|w| "-".repeat(*w)).collect();
            println!("|-{}-|", sep.join("-|-"));
        }
    }
    if let Some(j) = &args.json {
        let v: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| serde_json::json!({"group": r.group, "file": r.file, "figures": r.r}))
            .collect();
        std::fs::write(j, serde_json::to_string_pretty(&v)?)
            .with_context(|| format!("writing {}", j.display()))?;
    }
    Ok(())
}
