//! Radio-only engines: `gml`, `trilat`, `frbw`, `ml`, `wcentroid` on BLE, and
//! `wifi-wcentroid`, the same task on WiFi access points (a causal yardstick
//! for WiFi: the site's `access_points` stand in for beacons, each new scan
//! result is one observation). One task (front end + positioner + eq. 22
//! mean filter) every `tasks.radio_period_ms`; no fusion task. The pose is the
//! last fix; a run without a fix leaves it unchanged and counts `no_fix`.

use std::sync::Arc;

use crate::Result;
use crate::Vec2;
use crate::ble::{BeaconRegistry, BleFrontEnd, BleTask, PositionerKind};
use crate::engine::{Engine, EngineStats, InitialPosition, Pose, Task};
use crate::engines::EngineConfig;
use crate::events::{BleObservation, SensorEvent, WifiScan};
use crate::site::{BeaconSpec, Site};
use crate::wifi::FreshResults;

/// Names of the WiFi engines and their positioners.
pub const WIFI_ENGINES: [(&str, PositionerKind); 1] =
    [("wifi-wcentroid", PositionerKind::WeightedCentroid)];

/// What a WiFi engine keeps to turn scans into observations.
struct WifiInput {
    name: &'static str,
    fresh: FreshResults,
    max_age_ns: i64,
    min_rssi_dbm: f64,
}

/// A BLE-only (or WiFi-only) engine.
pub struct BleOnlyEngine {
    kind: PositionerKind,
    /// `Some` for the WiFi engines: BLE is then ignored.
    wifi: Option<WifiInput>,
    task: BleTask,
    period_ns: i64,
    pose: Option<Pose>,
    /// Start position (used as the previous position of the first run only).
    init: Option<InitialPosition>,
    /// Whether `init` came from `set_position` since the last run.
    given: bool,
    site: Arc<Site>,
    stats: EngineStats,
}

impl BleOnlyEngine {
    pub fn new(
        kind: PositionerKind,
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Self {
        let task = BleTask::new(kind, &config.ble, &site);
        Self::assemble(kind, None, task, config, init, site)
    }

    /// The engine around `task`, before its first run.
    fn assemble(
        kind: PositionerKind,
        wifi: Option<WifiInput>,
        task: BleTask,
        config: &EngineConfig,
        init: Option<InitialPosition>,
        site: Arc<Site>,
    ) -> Self {
        BleOnlyEngine {
            kind,
            wifi,
            task,
            period_ns: i64::from(config.tasks.radio_period_ms) * 1_000_000,
            pose: None,
            init,
            given: false,
            site,
            stats: EngineStats::default(),
        }
    }
}

/// The BLE front end's id of an access point (`mac:` + upper-case BSSID).
fn ap_id(bssid: &str) -> String {
    format!("mac:{}", bssid.to_ascii_uppercase())
}

impl BleOnlyEngine {
    /// WiFi engine `name` of [`WIFI_ENGINES`]: the BLE task's front end,
    /// positioner and mean filter over the site's access points, with
    /// `wifi.wcentroid_*` for the weighted centroid.
    pub fn new_wifi(
        name: &str,
        site: Arc<Site>,
        config: &EngineConfig,
        init: Option<InitialPosition>,
    ) -> Option<Self> {
        let (name, kind) = WIFI_ENGINES.into_iter().find(|(n, _)| *n == name)?;
        let mut ble = config.ble.clone();
        ble.wcentroid.top_n = config.wifi.wcentroid_top_n;
        ble.wcentroid.exponent = config.wifi.wcentroid_exponent;
        ble.min_rssi_dbm = config.wifi.min_rssi_dbm;
        let aps: Vec<BeaconSpec> = site
            .spec
            .access_points
            .iter()
            .map(|a| BeaconSpec {
                id: ap_id(&a.id),
                ..a.clone()
            })
            .collect();
        let front = BleFrontEnd::with_registry(&ble, BeaconRegistry::new(&aps));
        let wifi = WifiInput {
            name,
            fresh: FreshResults::default(),
            max_age_ns: config.wifi.max_age_ns(),
            min_rssi_dbm: config.wifi.min_rssi_dbm,
        };
        let task = BleTask::with_parts(&ble, front, kind.build(&ble), Default::default());
        Some(Self::assemble(kind, Some(wifi), task, config, init, site))
    }
}

impl Engine for BleOnlyEngine {
    fn name(&self) -> &'static str {
        self.wifi.as_ref().map_or(self.kind.name(), |w| w.name)
    }

    fn on_sensor(&mut self, event: &SensorEvent) {
        self.task.on_sensor(event);
    }

    fn on_ble(&mut self, obs: &BleObservation) {
        if self.wifi.is_none() {
            self.task.on_observation(obs);
        }
    }

    fn on_wifi(&mut self, scan: &WifiScan) {
        // The BLE engines do not use WiFi: ignored.
        let Some(w) = self.wifi.as_mut() else { return };
        for r in w.fresh.of(scan, w.max_age_ns) {
            if r.rssi_dbm < w.min_rssi_dbm {
                continue;
            }
            // At the scan's time: the front end's filters run forward in time.
            self.task.on_observation(&BleObservation {
                t_ns: scan.t_ns,
                beacon_id: ap_id(&r.bssid),
                rssi_dbm: r.rssi_dbm,
                tx_power_dbm: None,
            });
        }
    }

    /// The pose becomes `at` now; the mean filter forgets the fixes from
    /// before and the next run searches around `at` (its previous position).
    fn set_position(&mut self, t_ns: i64, at: InitialPosition) -> Result<()> {
        crate::engine::check_initial_position(&self.site, &at)?;
        self.task.reset_position();
        let heading_rad = at
            .heading_rad
            .or(self.pose.map(|p| p.heading_rad))
            .unwrap_or(0.0);
        self.pose = Some(Pose {
            t_ns,
            x_m: at.x_m,
            y_m: at.y_m,
            floor: at.floor,
            heading_rad,
            accuracy_m: 2.0,
            floor_prob: 1.0,
            source: crate::engine::PoseSource::Radio,
        });
        self.init = Some(at);
        self.given = true;
        Ok(())
    }

    fn run_task(&mut self, task: Task, t_ns: i64) {
        if task != Task::Radio {
            return;
        }
        // the start (or a position set since the last run) is the previous
        // position of the next run only
        let given = std::mem::take(&mut self.given);
        let prev = match (self.pose, self.init.take()) {
            (None, Some(i)) => Some(Vec2::new(i.x_m, i.y_m)),
            (Some(_), Some(i)) if given => Some(Vec2::new(i.x_m, i.y_m)),
            _ => None,
        };
        match self.task.run(t_ns, prev) {
            Some(fix) => {
                let heading_rad = match self.pose {
                    Some(p)
                        if p.floor == fix.floor
                            && (fix.pos - Vec2::new(p.x_m, p.y_m)).norm() > 0.1 =>
                    {
                        (fix.pos.y - p.y_m).atan2(fix.pos.x - p.x_m)
                    }
                    Some(p) => p.heading_rad,
                    None => 0.0,
                };
                self.pose = Some(Pose {
                    t_ns,
                    x_m: fix.pos.x,
                    y_m: fix.pos.y,
                    floor: fix.floor,
                    heading_rad,
                    // crude: a floor of 2 m plus the mean filter's last correction
                    accuracy_m: 2.0 + (fix.raw - fix.pos).norm(),
                    floor_prob: 1.0,
                    source: crate::engine::PoseSource::Radio,
                });
            }
            None => self.stats.no_fix += 1,
        }
    }

    fn task_period_ns(&self, task: Task) -> Option<i64> {
        (task == Task::Radio).then_some(self.period_ns)
    }

    fn pose(&self) -> Option<Pose> {
        self.pose
    }

    fn ble_position(&self) -> Option<Pose> {
        self.pose
    }

    fn stats(&self) -> EngineStats {
        self.stats.with_stages(self.task.front().counts(), 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ble::pathloss::{PathLoss, range_m};
    use crate::engine::replay::replay;
    use crate::engines::build_engine;
    use crate::events::{LogEvent, TruthPoint};
    use crate::site::testkit::{beacon_site, open_map};

    const MODEL: PathLoss = PathLoss {
        rssi_1m_dbm: -59.0,
        exponent: 2.0,
    };

    fn site(beacons: &[(f64, f64)]) -> Arc<Site> {
        beacon_site("test", vec![open_map(40, 30)], beacons, MODEL)
    }

    const SQUARE: [(f64, f64); 4] = [(5.0, 5.0), (35.0, 5.0), (35.0, 25.0), (5.0, 25.0)];

    /// Adverts of every beacon every 0.2 s along a straight walk, noise-free,
    /// with a truth point every second.
    fn walk(beacons: &[(f64, f64)], rssi_override: Option<f64>, seconds: i64) -> Vec<LogEvent> {
        let mut ev = Vec::new();
        for k in 0..seconds * 5 {
            let t_ns = k * 200_000_000;
            let p = Vec2::new(8.5 + 0.1 * k as f64, 12.5);
            for (i, &(x, y)) in beacons.iter().enumerate() {
                let r = MODEL.rssi_at(range_m(p, Vec2::new(x, y), 0.0, 0.5), 0.5);
                ev.push(LogEvent::Ble(BleObservation {
                    t_ns,
                    beacon_id: format!("mac:00:00:00:00:00:{i:02X}"),
                    rssi_dbm: rssi_override.unwrap_or(r),
                    tx_power_dbm: None,
                }));
            }
            if k % 5 == 0 {
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
        }
        ev
    }

    fn run(name: &str, site: Arc<Site>, ev: Vec<LogEvent>) -> crate::engine::replay::ReplayOutput {
        let mut e = build_engine(name, site, &EngineConfig::default(), None).unwrap();
        replay(e.as_mut(), ev)
    }

    #[test]
    fn every_ble_engine_tracks_a_noise_free_walk() {
        for name in ["gml", "trilat", "frbw", "ml", "wcentroid"] {
            let out = run(name, site(&SQUARE), walk(&SQUARE, None, 20));
            let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
            assert!(errs.len() >= 18, "{name}: {} fixes", errs.len());
            let mean = errs.iter().sum::<f64>() / errs.len() as f64;
            // eq. 22 averages with previous outputs: in steady walking at v it lags by
            // 3 v = 1.5 m here (n = 3, 1 s period); centroids are biased
            let limit = if matches!(name, "frbw" | "wcentroid") {
                12.0
            } else {
                2.0
            };
            assert!(mean < limit, "{name}: mean error {mean}");
            assert_eq!(out.stats.no_fix, 0, "{name}");
            assert!(
                out.track
                    .iter()
                    .all(|p| p.x_m.is_finite() && p.y_m.is_finite())
            );
        }
    }

    /// A tap sets the pose at once; the next fix starts a fresh mean filter
    /// (the tap point is only its search prior), so it lies near the truth.
    #[test]
    fn set_position_sets_the_pose_and_restarts_the_mean_filter() {
        for name in ["gml", "trilat", "frbw", "ml", "wcentroid"] {
            let mut e = build_engine(name, site(&SQUARE), &EngineConfig::default(), None).unwrap();
            let mut events = walk(&SQUARE, None, 6).into_iter();
            for ev in events.by_ref().take(60) {
                if let LogEvent::Ble(o) = ev {
                    e.on_ble(&o);
                }
            }
            e.run_task(Task::Radio, 1_000_000_000);
            let at = InitialPosition {
                x_m: 30.0,
                y_m: 20.0,
                floor: 0,
                heading_rad: None,
            };
            e.set_position(1_100_000_000, at).unwrap();
            let p = e.pose().unwrap();
            assert_eq!(
                (p.t_ns, p.x_m, p.y_m),
                (1_100_000_000, 30.0, 20.0),
                "{name}"
            );
            assert!(
                e.set_position(1_200_000_000, InitialPosition { floor: 9, ..at })
                    .is_err()
            );
            e.run_task(Task::Radio, 2_000_000_000);
            let p = e.pose().unwrap();
            assert_eq!(p.t_ns, 2_000_000_000, "{name}");
            // eq. 22 would average the fix with the tap point; after the reset
            // the output is the fix itself (y* = x_B)
            let b = e.ble_position().unwrap();
            assert!(p.x_m.is_finite() && (p.x_m - b.x_m).abs() < 1e-9, "{name}");
        }
    }

    #[test]
    fn bad_input_gives_no_fix_and_no_nan() {
        for name in ["gml", "trilat", "frbw", "ml", "wcentroid"] {
            // RSSI of 0 and above: rejected and counted
            for r in [0.0, 3.0, f64::NAN, f64::INFINITY] {
                let out = run(name, site(&SQUARE), walk(&SQUARE, Some(r), 5));
                assert!(out.track.is_empty(), "{name} rssi {r}");
                assert!(
                    out.stats.rejected_inputs > 0 && out.stats.no_fix > 0,
                    "{name}"
                );
            }
            // fewer than 3 heard
            let out = run(name, site(&SQUARE), walk(&SQUARE[..2], None, 5));
            assert!(
                out.track.is_empty() && out.stats.no_fix > 0,
                "{name} two beacons"
            );
            // a site with no beacons: everything unknown
            let out = run(name, site(&[]), walk(&SQUARE, None, 5));
            assert!(
                out.track.is_empty() && out.stats.no_fix > 0,
                "{name} no beacons"
            );
            assert!(out.stats.unknown_beacons > 0);
            // each beacon heard once
            let once: Vec<LogEvent> = walk(&SQUARE, None, 5).into_iter().take(5).collect();
            let out = run(name, site(&SQUARE), once);
            assert!(
                out.track
                    .iter()
                    .all(|p| p.x_m.is_finite() && p.y_m.is_finite()),
                "{name} once"
            );
            // a single beacon heard once
            let single: Vec<LogEvent> = walk(&SQUARE, None, 5).into_iter().take(1).collect();
            let out = run(name, site(&SQUARE), single);
            assert!(out.track.is_empty(), "{name} single");
            // collinear beacons: trilateration refuses, nobody returns NaN
            let line = [(5.0, 5.0), (15.0, 5.0), (25.0, 5.0), (35.0, 5.0)];
            let out = run(name, site(&line), walk(&line, None, 5));
            assert!(
                out.track
                    .iter()
                    .all(|p| p.x_m.is_finite() && p.y_m.is_finite()),
                "{name} collinear"
            );
            if name == "trilat" {
                assert!(out.track.is_empty() && out.stats.no_fix > 0);
            }
        }
    }

    /// The walk's adverts of beacon i as WiFi results of BSSID 02:..:0i, one
    /// scan per second (results 0.2 s old), with the BLE adverts kept too.
    fn as_wifi(ev: Vec<LogEvent>) -> Vec<LogEvent> {
        let mut out = Vec::new();
        let mut pending: Vec<crate::events::WifiResult> = Vec::new();
        for e in ev {
            if let LogEvent::Ble(b) = &e
                && b.t_ns % 1_000_000_000 == 0
            {
                let i = &b.beacon_id[b.beacon_id.len() - 2..];
                pending.push(crate::events::WifiResult {
                    bssid: format!("02:00:00:00:00:{}", i.to_ascii_lowercase()),
                    rssi_dbm: b.rssi_dbm,
                    freq_mhz: 2412,
                    seen_t_ns: b.t_ns,
                });
            }
            if let LogEvent::Truth(t) = &e {
                out.push(LogEvent::Wifi(crate::events::WifiScan {
                    t_ns: t.t_ns + 200_000_000,
                    results: std::mem::take(&mut pending),
                }));
            }
            out.push(e);
        }
        out.sort_by_key(|e| e.t_ns());
        out
    }

    #[test]
    fn wifi_wcentroid_positions_from_access_points_only() {
        let mut spec = site(&[]).spec.clone();
        spec.access_points = SQUARE
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| BeaconSpec {
                id: format!("02:00:00:00:00:{i:02x}"),
                floor: 0,
                x_m: x,
                y_m: y,
                z_m: 1.2,
                rssi_1m_dbm: MODEL.rssi_1m_dbm,
                path_loss_exponent: MODEL.exponent,
            })
            .collect();
        let aps = Arc::new(Site {
            spec,
            floors: site(&[]).floors.clone(),
        });
        let ev = as_wifi(walk(&SQUARE, None, 20));
        let out = run("wifi-wcentroid", aps.clone(), ev.clone());
        let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
        assert!(errs.len() >= 18, "{} fixes", errs.len());
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        assert!(mean < 12.0, "mean error {mean}");
        assert_eq!(out.stats.wifi_scans, 20);
        // the BLE adverts of the same log were counted, not used: a site whose
        // beacons are the same points gives no WiFi fix without the scans
        let ble_only: Vec<LogEvent> = ev
            .into_iter()
            .filter(|e| !matches!(e, LogEvent::Wifi(_)))
            .collect();
        let out = run("wifi-wcentroid", aps, ble_only);
        assert!(out.track.is_empty() && out.stats.ble_observations > 0);
        // and the BLE engines ignore the scans
        let out = run("wcentroid", site(&[]), as_wifi(walk(&SQUARE, None, 5)));
        assert!(out.track.is_empty() && out.stats.wifi_scans == 5);
    }
}
