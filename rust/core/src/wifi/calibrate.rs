//! AP calibration from survey walks with ground truth: the BLE calibration
//! (`ble::calibrate::calibrate_with`: position + path-loss fit, rejection of
//! moving and carried transmitters) on WiFi results. Each new result (see
//! [`super::FreshResults`]) is one sample at its own last-seen time, so the
//! walker's position is interpolated where the AP was really heard (ILC
//! results are often seconds older than their scan). Results are grouped
//! into transmitters by [`super::BssidGrouping`]; an accepted group is
//! written to the site as one `access_points` entry per member BSSID, all
//! with the group's position and model.

use std::collections::{BTreeMap, BTreeSet};

use super::{FreshResults, WifiConfig};
use crate::Result;
use crate::ble::BleConfig;
use crate::ble::calibrate::{CalibrationSummary, SurveyPath, TransmitterReport, calibrate_with};
use crate::events::{BleObservation, TruthPoint, WifiScan};
use crate::site::SiteSpec;

/// One survey walk: its WiFi scans and truth points (MCS).
#[derive(Debug, Clone, Default)]
pub struct WifiSurveyPath {
    pub name: String,
    pub scans: Vec<WifiScan>,
    pub truth: Vec<TruthPoint>,
}

/// Result of [`calibrate_aps`].
#[derive(Debug, Clone, Default)]
pub struct ApCalibration {
    /// One report per transmitter (group), sorted by id.
    pub reports: Vec<TransmitterReport>,
    pub summary: CalibrationSummary,
    /// Group id -> the BSSIDs heard in it.
    pub members: BTreeMap<String, BTreeSet<String>>,
    /// Results in the scans, and those used (new, fresh, strong enough).
    pub results: usize,
    pub used: usize,
}

/// Calibrates every AP heard in `paths`.
pub fn calibrate_aps(
    paths: &[WifiSurveyPath],
    wifi: &WifiConfig,
    ble: &BleConfig,
) -> Result<ApCalibration> {
    wifi.validate()?;
    let mut out = ApCalibration::default();
    let mut survey = Vec::with_capacity(paths.len());
    for p in paths {
        let mut fresh = FreshResults::default();
        let mut obs = Vec::new();
        for s in &p.scans {
            out.results += s.results.len();
            for r in fresh.of(s, wifi.max_age_ns()) {
                if r.rssi_dbm < wifi.min_rssi_dbm {
                    continue;
                }
                let key = wifi.grouping.key(&r.bssid, r.freq_mhz);
                out.members
                    .entry(key.clone())
                    .or_default()
                    .insert(r.bssid.clone());
                obs.push(BleObservation {
                    t_ns: r.seen_t_ns,
                    beacon_id: key,
                    rssi_dbm: r.rssi_dbm,
                    tx_power_dbm: None,
                });
            }
        }
        out.used += obs.len();
        obs.sort_by_key(|o| o.t_ns);
        survey.push(SurveyPath {
            name: p.name.clone(),
            observations: obs,
            truth: p.truth.clone(),
        });
    }
    let (reports, summary) =
        calibrate_with(&survey, ble, &wifi.calibration, &|id| Some(id.to_string()))?;
    out.reports = reports;
    out.summary = summary;
    Ok(out)
}

/// `site` with one `access_points` entry per member BSSID of every accepted
/// group (same id: replaced), at height `z_m`. Groups on floors the site does
/// not have are left out.
pub fn apply_aps_to_site(site: &SiteSpec, cal: &ApCalibration, z_m: f64) -> SiteSpec {
    let mut out = site.clone();
    for r in &cal.reports {
        let Some(spec) = r.to_spec(z_m) else { continue };
        if !out.floors.iter().any(|f| f.id == spec.floor) {
            continue;
        }
        for b in cal.members.get(&r.id).into_iter().flatten() {
            out.access_points.retain(|a| &a.id != b);
            let mut s = spec.clone();
            s.id = b.clone();
            out.access_points.push(s);
        }
    }
    out.access_points.sort_by(|a, b| a.id.cmp(&b.id));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use crate::ble::pathloss::PathLoss;
    use crate::events::WifiResult;
    use crate::wifi::BssidGrouping;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn gauss(rng: &mut Pcg64) -> f64 {
        let u1: f64 = rng.random::<f64>().max(1e-12);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    const AP_24: &str = "0a:74:9c:2b:62:7a";
    const AP_5: &str = "0a:74:9c:2b:62:7b";
    const AP_B: &str = "00:22:6c:ea:3d:14";
    const HOTSPOT: &str = "da:a1:19:00:00:01";

    /// Six walks across a 50 x 30 m floor at 1 m/s, truth every 5 s, a scan
    /// every 2 s whose results are 0-3 s old (cached results repeat). Fixed
    /// APs: one dual-band AP at (12, 9) (5 GHz 8 dB weaker), one at (38, 22);
    /// a phone hotspot carried to a different place on every walk.
    fn survey(seed: u64) -> Vec<WifiSurveyPath> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let m24 = PathLoss {
            rssi_1m_dbm: -38.0,
            exponent: 2.4,
        };
        let m5 = PathLoss {
            rssi_1m_dbm: -46.0,
            exponent: 2.6,
        };
        let fixed = [
            (AP_24, 2437, Vec2::new(12.0, 9.0), m24),
            (AP_5, 5180, Vec2::new(12.0, 9.0), m5),
            (AP_B, 2412, Vec2::new(38.0, 22.0), m24),
        ];
        (0..6)
            .map(|p| {
                let y0 = 3.0 + 5.0 * p as f64;
                let (a, b) = if p % 2 == 0 {
                    (Vec2::new(2.0, y0), Vec2::new(48.0, y0 + 2.0))
                } else {
                    (Vec2::new(48.0, y0), Vec2::new(2.0, y0 - 1.0))
                };
                let dur_s = (b - a).norm();
                let at = |t_s: f64| a + (b - a) * (t_s / dur_s).min(1.0);
                let t0 = p as i64 * 1_000_000_000_000;
                let ns = |t_s: f64| t0 + (t_s * 1e9) as i64;
                let truth = (0..=(dur_s / 5.0) as usize)
                    .map(|k| {
                        let q = at(5.0 * k as f64);
                        TruthPoint {
                            t_ns: ns(5.0 * k as f64),
                            x_m: q.x,
                            y_m: q.y,
                            floor: Some(0),
                        }
                    })
                    .collect();
                let hotspot = Vec2::new(5.0 + 8.0 * p as f64, 25.0 - 4.0 * p as f64);
                let mut last: BTreeMap<&str, WifiResult> = BTreeMap::new();
                let mut scans = Vec::new();
                let mut t = 2.0;
                while t < dur_s {
                    let mut results = Vec::new();
                    for (id, f, pos, m) in fixed {
                        // a new measurement 0-3 s ago, or the cached one again
                        if last.contains_key(id) && rng.random::<f64>() < 0.3 {
                            results.push(last[id].clone());
                            continue;
                        }
                        let seen = t - 3.0 * rng.random::<f64>();
                        let r = WifiResult {
                            bssid: id.into(),
                            rssi_dbm: (m.rssi_at((at(seen) - pos).norm(), 0.5)
                                + 3.0 * gauss(&mut rng))
                            .round(),
                            freq_mhz: f,
                            seen_t_ns: ns(seen),
                        };
                        last.insert(id, r.clone());
                        results.push(r);
                    }
                    results.push(WifiResult {
                        bssid: HOTSPOT.into(),
                        rssi_dbm: (m24.rssi_at((at(t) - hotspot).norm(), 0.5)
                            + 2.0 * gauss(&mut rng))
                        .round(),
                        freq_mhz: 2462,
                        seen_t_ns: ns(t),
                    });
                    scans.push(WifiScan {
                        t_ns: ns(t),
                        results,
                    });
                    t += 2.0;
                }
                WifiSurveyPath {
                    name: format!("p{p}"),
                    scans,
                    truth,
                }
            })
            .collect()
    }

    fn lenient() -> WifiConfig {
        let mut w = WifiConfig::default();
        // 2 s scans: fewer bins than BLE's 5 adverts a second
        w.calibration.min_bins = 10;
        w
    }

    #[test]
    fn fixed_aps_are_found_and_a_moving_hotspot_is_rejected() {
        let paths = survey(3);
        let cal = calibrate_aps(&paths, &lenient(), &BleConfig::default()).unwrap();
        let rep = |id: &str| cal.reports.iter().find(|r| r.id == id).unwrap();
        for (id, pos) in [
            (AP_24, Vec2::new(12.0, 9.0)),
            (AP_5, Vec2::new(12.0, 9.0)),
            (AP_B, Vec2::new(38.0, 22.0)),
        ] {
            let r = rep(id);
            assert!(r.accepted(), "{id}: {:?}", r.rejected);
            let p = Vec2::new(r.x_m.unwrap(), r.y_m.unwrap());
            assert!((p - pos).norm() < 2.5, "{id}: {p:?}");
        }
        let h = rep(HOTSPOT);
        assert!(!h.accepted(), "moving hotspot accepted: {h:?}");
        assert!(h.rejected.as_deref().unwrap().contains("moving"), "{h:?}");
        // cached repeats are not counted twice
        assert!(cal.used < cal.results, "{} of {}", cal.used, cal.results);
        let site = open_site();
        let out = apply_aps_to_site(&site.spec, &cal, 1.2);
        let ids: Vec<&str> = out.access_points.iter().map(|a| a.id.as_str()).collect();
        assert_eq!(ids, vec![AP_B, AP_24, AP_5]);
        out.validate("w.json").unwrap();
    }

    /// The survey's 50 x 30 m floor without transmitters.
    fn open_site() -> std::sync::Arc<crate::site::Site> {
        let model = PathLoss {
            rssi_1m_dbm: -38.0,
            exponent: 2.4,
        };
        crate::site::testkit::beacon_site(
            "w",
            vec![crate::site::testkit::open_map(50, 30)],
            &[],
            model,
        )
    }

    #[test]
    fn grouped_bands_share_a_position_and_write_every_member() {
        let paths = survey(4);
        let mut w = lenient();
        w.grouping = BssidGrouping::Ap;
        let cal = calibrate_aps(&paths, &w, &BleConfig::default()).unwrap();
        let key = BssidGrouping::Ap.key(AP_24, 2437);
        let members: Vec<&String> = cal.members[&key].iter().collect();
        assert_eq!(members, vec![AP_24, AP_5]);
        let r = cal.reports.iter().find(|r| r.id == key).unwrap();
        let site = open_site();
        let out = apply_aps_to_site(&site.spec, &cal, 1.2);
        if r.accepted() {
            let a: Vec<_> = out
                .access_points
                .iter()
                .filter(|a| a.id == AP_24 || a.id == AP_5)
                .collect();
            assert_eq!(a.len(), 2);
            assert_eq!((a[0].x_m, a[0].y_m), (a[1].x_m, a[1].y_m));
        }
        // with one model for two bands 8 dB apart the fit is worse than per band
        let per_band = calibrate_aps(&paths, &lenient(), &BleConfig::default()).unwrap();
        let resid = |c: &ApCalibration, id: &str| {
            c.reports
                .iter()
                .find(|r| r.id == id)
                .unwrap()
                .residual_dbm
                .unwrap()
        };
        assert!(
            resid(&cal, &key) > resid(&per_band, AP_24),
            "grouping across bands fits better?"
        );
    }
}
