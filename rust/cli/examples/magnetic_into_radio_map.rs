//! Adds (or replaces) the `magnetic` section of a radio map file: the
//! survey's magnetic field learned from the given logs with truth
//! (`fpbp_core::radio::magnetic_map`, the default radio map settings),
//! without
//! recomputing the transmitters' grids. `fpbp calibrate --radio-map`
//! builds the section itself; this serves maps built before it (radio map
//! version 3) and experiments on fixed radio maps.
//!
//! `--survey-track pdr` places the samples along each log's PDR track
//! mapped onto its truth points (`fpbp_core::radio::survey_track`, as
//! `fpbp calibrate --survey-track pdr`) instead of straight lines between
//! them: the field changes within a metre or two, so where a sample was
//! matters more than for the radio.
//!
//! Usage: cargo run --release -p fpbp-cli --example magnetic_into_radio_map --
//!        SITE RADIO_MAP OUT LOG... [--floor F] [--survey-track linear|pdr]

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use fpbp_core::Vec2;
use fpbp_core::engine::InitialPosition;
use fpbp_core::engine::replay::replay;
use fpbp_core::engines::{EngineConfig, build_engine};
use fpbp_core::events::{LogEvent, TruthPoint};
use fpbp_core::radio::RadioMap;
use fpbp_core::radio::RadioMapConfig;
use fpbp_core::radio::magnetic_map::{MagneticMapBuilder, MagneticMapConfig, valued_cells};
use fpbp_core::radio::survey_track::{ShapeLimits, pdr_shaped_truth, with_truth};
use fpbp_core::site::Site;
use fpbp_core::site::files::load_site;
use fpbp_logs::{ReadOptions, read_all};

fn main() -> Result<()> {
    let mut pos: Vec<String> = Vec::new();
    let mut floor: Option<i32> = None;
    let mut pdr_track = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--floor" => floor = Some(args.next().context("--floor needs an id")?.parse()?),
            "--survey-track" => {
                pdr_track = match args.next().as_deref() {
                    Some("pdr") => true,
                    Some("linear") => false,
                    other => bail!("--survey-track: expected linear or pdr, got {other:?}"),
                }
            }
            _ => pos.push(a),
        }
    }
    if pos.len() < 4 {
        bail!("usage: SITE RADIO_MAP OUT LOG... [--floor F]");
    }
    let site = load_site(&PathBuf::from(&pos[0]))?;
    let text = std::fs::read_to_string(&pos[1]).with_context(|| pos[1].clone())?;
    let mut map = RadioMap::from_json(&text, &site).with_context(|| pos[1].clone())?;
    let single = (site.spec.floors.len() == 1).then(|| site.default_floor());
    let read = ReadOptions {
        site_georef: site.spec.georef.map(|g| (g, site.spec.map_from_enu_rad)),
        default_floor: floor.or(single),
        ..ReadOptions::default()
    };
    let opts = RadioMapConfig::default().survey_options(floor.or(single));
    let mut b = MagneticMapBuilder::new(&MagneticMapConfig::default())?;
    let (mut seen, mut placed) = (0, 0);
    for l in &pos[3..] {
        let (mut events, _) = read_all(&PathBuf::from(l), &read).with_context(|| l.clone())?;
        if pdr_track {
            events = pdr_shaped(&site, events)?;
        }
        let (s, p) = b.add_log(&events, &opts);
        seen += s;
        placed += p;
    }
    let (mag, _) = b.finish()?;
    let cells: usize = mag
        .as_ref()
        .map_or(0, |m| m.grids().iter().map(valued_cells).sum());
    map.set_magnetic(mag);
    std::fs::write(&pos[2], map.to_json()?).with_context(|| pos[2].clone())?;
    println!(
        "{}: {} logs, {seen} magnetometer samples ({placed} placed), {cells} cells with a value",
        pos[2],
        pos.len() - 3
    );
    Ok(())
}

/// `events` with their truth points densified along the `pdr` engine's
/// track started at the first truth point (as `fpbp calibrate
/// --survey-track pdr`, which takes its track from the same engine).
fn pdr_shaped(site: &std::sync::Arc<Site>, events: Vec<LogEvent>) -> Result<Vec<LogEvent>> {
    let truth: Vec<TruthPoint> = events
        .iter()
        .filter_map(LogEvent::as_truth)
        .copied()
        .collect();
    let Some(first) = truth.first() else {
        return Ok(events);
    };
    let init = InitialPosition {
        x_m: first.x_m,
        y_m: first.y_m,
        floor: first.floor.unwrap_or_else(|| site.default_floor()),
        heading_rad: None,
    };
    let mut engine = build_engine("pdr", site.clone(), &EngineConfig::default(), Some(init))?;
    let out = replay(
        engine.as_mut(),
        events.iter().filter(|e| e.t_ns() >= first.t_ns).cloned(),
    );
    let track: Vec<(i64, Vec2)> = out
        .track
        .iter()
        .map(|p| (p.t_ns, Vec2::new(p.x_m, p.y_m)))
        .collect();
    let (dense, _) = pdr_shaped_truth(&truth, &track, &ShapeLimits::default());
    Ok(with_truth(events, dense))
}
