//! What several integration tests share: the demo site and radio maps
//! surveyed by simulated walks of it. Each test binary uses its own part.
#![allow(dead_code)]

use std::path::Path;
use std::sync::Arc;

use fpbp_core::events::LogEvent;
use fpbp_core::radio::RadioMap;
use fpbp_core::radio::radio_map::{RadioMapBuilder, RadioMapConfig};
use fpbp_core::radio::reference_scans::ReferenceScanConfig;
use fpbp_core::site::Site;
use fpbp_sim::{SimRequest, simulate};

/// The shipped demo site (maps/demo/site.json).
pub fn demo_site() -> Arc<Site> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo/site.json");
    fpbp_core::site::files::load_site(&path).unwrap()
}

/// Each of `events` with the walker's x when it was logged: that of the
/// last truth point before it (`None` before the first).
pub fn with_truth_x(events: &[LogEvent]) -> impl Iterator<Item = (Option<f64>, &LogEvent)> {
    events.iter().scan(None, |x, e| {
        if let LogEvent::Truth(t) = e {
            *x = Some(t.x_m);
        }
        Some((*x, e))
    })
}

/// The radio map of simulated survey walks of `site` (240 s, one per sim
/// seed of `seeds`), with their reference scans, as `fpbp calibrate
/// --radio-map` builds it; each walk's events pass through `edit` first
/// (readings left out, or made wrong).
pub fn surveyed_map(
    site: &Site,
    seeds: &[u64],
    edit: impl Fn(&[LogEvent]) -> Vec<LogEvent>,
) -> RadioMap {
    let mut b = RadioMapBuilder::new(site, &RadioMapConfig::default())
        .unwrap()
        .with_reference_scans(&ReferenceScanConfig::default())
        .unwrap();
    for &seed in seeds {
        let log = simulate(site, &SimRequest::new(240.0, seed)).unwrap();
        b.add_log(&edit(&log.events));
    }
    b.finish().unwrap().0
}
