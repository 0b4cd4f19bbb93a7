//! Radio map: smoothing between walked lines, honest spread far from them,
//! fallbacks, rejections, the file, and `tcpf` tracking with a map alone.

use std::sync::Arc;

use super::*;
use crate::engine::replay::replay;
use crate::engines::{EngineConfig, EngineData, build_engine_with};
use crate::events::{BleObservation, LogEvent, TruthPoint};
use crate::site::testkit::{beacon_site, open_map};

/// A transmitter's hidden field: RSSI at `p`, or `None` when not heard.
type Field<'a> = &'a dyn Fn(usize, usize, Vec2) -> Option<f64>;

fn id(k: usize) -> String {
    format!("mac:00:00:00:00:00:{k:02X}")
}

/// Walk `walk` along the polyline `pts` at 1 m/s from `t0_s`: truth at
/// every vertex, a reading of each of `n_tx` transmitters every 0.5 s.
fn survey_walk(walk: usize, pts: &[Vec2], n_tx: usize, field: Field<'_>) -> Vec<LogEvent> {
    let mut ev = Vec::new();
    let mut t = 0.0;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = (b - a).norm();
        let steps = (len / 0.5).round().max(1.0) as usize;
        for s in 0..steps {
            let u = s as f64 / steps as f64;
            let p = a + (b - a) * u;
            let t_ns = ((t + u * len) * 1e9) as i64;
            if s % 8 == 0 {
                ev.push(LogEvent::Truth(TruthPoint {
                    t_ns,
                    x_m: p.x,
                    y_m: p.y,
                    floor: Some(0),
                }));
            }
            for k in 0..n_tx {
                if let Some(r) = field(walk, k, p) {
                    ev.push(LogEvent::Ble(BleObservation {
                        t_ns: t_ns + 1,
                        beacon_id: id(k),
                        rssi_dbm: r,
                        tx_power_dbm: None,
                    }));
                }
            }
        }
        t += len;
    }
    if let Some(p) = pts.last() {
        ev.push(LogEvent::Truth(TruthPoint {
            t_ns: (t * 1e9) as i64,
            x_m: p.x,
            y_m: p.y,
            floor: Some(0),
        }));
    }
    ev
}

/// A zigzag over horizontal lines y = `ys` from x = 4 to 36.
fn zigzag(ys: &[f64]) -> Vec<Vec2> {
    let mut v = Vec::new();
    for (i, y) in ys.iter().enumerate() {
        let (a, b) = if i % 2 == 0 { (4.0, 36.0) } else { (36.0, 4.0) };
        v.push(Vec2::new(a, *y));
        v.push(Vec2::new(b, *y));
    }
    v
}

/// A log-distance field from (20, 15) with a deterministic +-2 dB ripple.
fn field(_walk: usize, _k: usize, p: Vec2) -> Option<f64> {
    let d = (p - Vec2::new(20.0, 15.0)).norm().max(0.5);
    Some(-50.0 - 25.0 * d.log10() + 2.0 * (p.x * 1.3 + p.y * 0.7).sin())
}

fn truth_mean(p: Vec2) -> f64 {
    let d = (p - Vec2::new(20.0, 15.0)).norm().max(0.5);
    -50.0 - 25.0 * d.log10()
}

fn build(site: &Site, logs: &[Vec<LogEvent>], cfg: &RadioMapConfig) -> (RadioMap, Vec<TxReport>) {
    let mut b = RadioMapBuilder::new(site, cfg).unwrap();
    for l in logs {
        b.add_log(l);
    }
    let (m, r, _) = b.finish().unwrap();
    (m, r)
}

/// Defaults, but every surveyed transmitter gets a grid (the test sites
/// mostly have no beacon entries).
fn open_cfg() -> RadioMapConfig {
    RadioMapConfig {
        site_transmitters_only: false,
        ..RadioMapConfig::default()
    }
}

/// A 40 x 30 m open floor with `beacons` (path loss -59 dBm at 1 m,
/// exponent 2).
fn open_site(beacons: &[(f64, f64)]) -> Arc<Site> {
    beacon_site(
        "rm",
        vec![open_map(40, 30)],
        beacons,
        crate::ble::pathloss::PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.0,
        },
    )
}

fn lines_survey(n_tx: usize, f: Field<'_>) -> Vec<Vec<LogEvent>> {
    (0..2)
        .map(|w| survey_walk(w, &zigzag(&[6.0, 12.0, 18.0, 24.0]), n_tx, f))
        .collect()
}

#[test]
fn smooths_between_walked_lines_with_a_larger_spread_off_them() {
    let site = open_site(&[]);
    let (m, rep) = build(&site, &lines_survey(1, &field), &open_cfg());
    assert_eq!(rep.len(), 1);
    assert!(rep[0].rejected.is_none(), "{rep:?}");
    let i = m.lookup(TxKind::Ble, &id(0)).unwrap();
    // the peak sits near the field's centre
    assert!(
        (m.transmitters()[i].pos - Vec2::new(20.0, 15.0)).norm() < 4.0,
        "{:?}",
        m.transmitters()[i]
    );
    // on a walked line and 3 m off it (between two lines): near the field
    for p in [
        Vec2::new(10.0, 12.0),
        Vec2::new(10.0, 9.0),
        Vec2::new(30.0, 21.0),
    ] {
        let (mu, _) = m.expected(i, 0, p).unwrap();
        assert!(
            (mu - truth_mean(p)).abs() < 3.5,
            "{p:?}: {mu:.1} vs {:.1}",
            truth_mean(p)
        );
    }
    let (_, on) = m.expected(i, 0, Vec2::new(10.0, 12.0)).unwrap();
    let (_, off) = m.expected(i, 0, Vec2::new(10.0, 9.0)).unwrap();
    let (_, far) = m.expected(i, 0, Vec2::new(10.0, 30.5)).unwrap();
    assert!(
        on < off && off < far,
        "sd on {on:.2}, between {off:.2}, far {far:.2}"
    );
    // beyond the grid: the site has no model of it, so the weak prior
    let fb = m.expected(i, 0, Vec2::new(50.0, 15.0)).unwrap();
    assert_eq!(fb, (-92.0, 10.0));
    // unknown index, other kind
    assert!(
        m.expected(m.transmitters().len(), 0, Vec2::zeros())
            .is_none()
    );
    assert_eq!(m.lookup(TxKind::Wifi, &id(0)), None);
}

#[test]
fn falls_back_to_the_site_path_loss_model_far_from_the_walks() {
    let model = crate::ble::pathloss::PathLoss {
        rssi_1m_dbm: -55.0,
        exponent: 2.0,
    };
    let maps = vec![open_map(100, 30)];
    let site = beacon_site("rm", maps, &[(20.0, 15.0), (90.0, 15.0)], model);
    let (m, _) = build(&site, &lines_survey(1, &field), &open_cfg());
    let i = m.lookup(TxKind::Ble, &id(0)).unwrap();
    assert!(!m.entries()[i].grids.is_empty() && m.entries()[i].has_pathloss);
    // 60 m east of the walks: the path-loss formula with the fallback spread
    let p = Vec2::new(80.0, 15.0);
    let (mu, sd) = m.expected(i, 0, p).unwrap();
    let d = ((p - Vec2::new(20.0, 15.0)).norm_squared() + 0.0f64).sqrt();
    assert!((mu - (-55.0 - 20.0 * d.log10())).abs() < 1e-9, "{mu}");
    assert_eq!(sd, m.fallback().ble_sd_db);
    // the beacon never heard is in the map with its model only
    let j = m.lookup(TxKind::Ble, &id(1)).unwrap();
    assert!(m.entries()[j].grids.is_empty());
    assert!((m.expected(j, 0, Vec2::new(90.0, 16.0)).unwrap().0 + 55.0).abs() < 1e-9);
    // the batch query is the point query, on the grid, at its holes and
    // edges, on the fallback (there within 1e-8 dB: its logarithm is
    // `ln_normal`)
    let ps: Vec<Vec2> = (0..3000)
        .map(|k| {
            Vec2::new(
                f64::from(k % 100) * 1.013 - 1.0,
                f64::from(k / 100) * 1.07 - 0.5,
            )
        })
        .collect();
    let (mut mean, mut sd) = (vec![0.0; ps.len()], vec![0.0; ps.len()]);
    for tx in [i, j] {
        assert!(m.expected_many(tx, 0, &ps, &mut mean, &mut sd));
        for (k, p) in ps.iter().enumerate() {
            let (a, b) = m.expected(tx, 0, *p).unwrap();
            assert!((mean[k] - a).abs() < 1e-8 && sd[k] == b, "{p:?}");
        }
    }
    assert!(!m.expected_many(m.transmitters().len(), 0, &ps, &mut mean, &mut sd));
}

#[test]
fn rejects_moving_and_rarely_heard_transmitters() {
    let site = open_site(&[]);
    // 0: fixed; 1: somewhere else on every walk; 2: heard once
    let f = |walk: usize, k: usize, p: Vec2| match k {
        0 => field(walk, k, p),
        1 => {
            let at = if walk == 0 {
                Vec2::new(5.0, 5.0)
            } else {
                Vec2::new(35.0, 25.0)
            };
            Some(-45.0 - 25.0 * (p - at).norm().max(0.5).log10())
        }
        _ => (walk == 0 && p.x < 5.0 && p.y < 7.0).then_some(-70.0),
    };
    let (m, rep) = build(&site, &lines_survey(3, &f), &open_cfg());
    let by = |k: usize| {
        rep.iter()
            .find(|r| r.id == id(k))
            .unwrap_or_else(|| panic!("{rep:?}"))
    };
    assert!(by(0).rejected.is_none(), "{:?}", by(0));
    let moving = by(1).rejected.clone().unwrap_or_default();
    assert!(moving.contains("moving"), "{:?}", by(1));
    assert!(by(1).disagreement_db.unwrap() > 6.0);
    assert!(by(0).disagreement_db.unwrap() < 2.0, "{:?}", by(0));
    assert!(by(2).rejected.is_some(), "{:?}", by(2));
    assert!(m.lookup(TxKind::Ble, &id(0)).is_some());
    assert!(m.lookup(TxKind::Ble, &id(1)).is_none());
    assert!(m.lookup(TxKind::Ble, &id(2)).is_none());
    // by default only transmitters the site has get a grid
    let (m, rep) = build(&site, &lines_survey(3, &f), &RadioMapConfig::default());
    assert!(m.transmitters().is_empty());
    assert!(rep.iter().all(|r| {
        r.rejected
            .as_deref()
            .is_some_and(|w| w.contains("not in the site"))
    }));
}

#[test]
fn the_file_round_trips_and_bad_files_name_the_field() {
    let site = open_site(&[(20.0, 15.0)]);
    let (m, _) = build(&site, &lines_survey(1, &field), &open_cfg());
    let text = m.to_json().unwrap();
    assert!(text.contains("\"format\":\"fpbp-radio-map\""));
    let back = RadioMap::from_json(&text, &site).unwrap();
    assert_eq!(back.transmitters().len(), m.transmitters().len());
    for i in 0..m.transmitters().len() {
        for (x, y) in [(1.0, 1.0), (10.0, 9.0), (20.3, 15.2), (39.0, 29.0)] {
            let p = Vec2::new(x, y);
            let (a, b) = (
                m.expected(i, 0, p).unwrap(),
                back.expected(i, 0, p).unwrap(),
            );
            assert!(
                (a.0 - b.0).abs() < 0.05 && (a.1 - b.1).abs() < 1e-9,
                "{a:?} {b:?}"
            );
        }
    }
    let err = |t: &str| RadioMap::from_json(t, &site).unwrap_err().to_string();
    let e = err(&text.replace("fpbp-radio-map", "fpbp-site"));
    assert!(e.contains("`format`"), "{e}");
    // a type error deep inside: the path
    let file = m.to_file();
    let mut v: serde_json::Value = serde_json::to_value(&file).unwrap();
    v["transmitters"][0]["grids"][0]["nx"] = serde_json::json!("wide");
    let e = err(&serde_json::to_string_pretty(&v).unwrap());
    assert!(e.contains("transmitters[0].grids[0].nx"), "{e}");
    // arrays not nx x ny long
    let mut f2 = file.clone();
    f2.transmitters[0].grids[0].mean_dbm_x10.pop();
    let e = RadioMap::from_file(&f2, &site).unwrap_err().to_string();
    assert!(e.contains("transmitters[0].grids[0].mean_dbm_x10"), "{e}");
    // a huge grid is refused before anything is allocated for it
    let mut f3 = file.clone();
    f3.transmitters[0].grids[0].nx = usize::MAX / 2;
    let e = RadioMap::from_file(&f3, &site).unwrap_err().to_string();
    assert!(
        e.contains("transmitters[0].grids[0].nx") && e.contains("limit"),
        "{e}"
    );
    // a floor the site does not have
    let mut f4 = file.clone();
    f4.transmitters[0].floor = 7;
    let e = RadioMap::from_file(&f4, &site).unwrap_err().to_string();
    assert!(e.contains("transmitters[0].floor"), "{e}");
    // NaN is not JSON
    let e = err(&text.replacen("\"x_m\":", "\"x_m\":NaN,\"q\":", 1));
    assert!(e.contains("x_m") || e.contains("NaN"), "{e}");
    // a bad fallback setting
    let mut f5 = file;
    f5.fallback.prior_sd_db = -1.0;
    let e = RadioMap::from_file(&f5, &site).unwrap_err().to_string();
    assert!(e.contains("fallback.prior_sd_db"), "{e}");
}

#[test]
fn bad_configs_name_the_field() {
    let cfg = RadioMapConfig {
        bandwidth_m: f64::NAN,
        ..RadioMapConfig::default()
    };
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("radio_map.bandwidth_m"), "{e}");
    let cfg = RadioMapConfig {
        max_cells_per_grid: usize::MAX,
        ..RadioMapConfig::default()
    };
    assert!(cfg.validate().is_err());
    let cfg: RadioMapConfig =
        serde_json::from_str(r#"{"wall_prior": {"enabled": true, "min_bins": 1}}"#).unwrap();
    let e = cfg.validate().unwrap_err().to_string();
    assert!(e.contains("radio_map.wall_prior.min_bins"), "{e}");
    assert!(serde_json::from_str::<RadioMapConfig>(r#"{"wall_prior": {"walls": 3}}"#).is_err());
}

/// `tcpf` with a radio map alone (the site has no beacon entries) tracks
/// the walk of the walled test site from its own start.
#[test]
fn tcpf_tracks_a_walk_with_a_radio_map_from_a_survey() {
    use crate::engines::prox_pf::testkit::{MODEL, beacons, walk_north, walled_map};
    let bs = beacons();
    // survey: two walks over north-south lines of the left room
    let field = |_w: usize, k: usize, p: Vec2| {
        let d = crate::ble::pathloss::range_m(p, bs[k], 0.0, 0.5);
        Some(MODEL.rssi_at(d, 0.5) + 1.5 * (p.y * 0.9 + k as f64).sin())
    };
    let lines: Vec<Vec2> = [3.0, 5.5, 8.0]
        .iter()
        .enumerate()
        .flat_map(|(i, x)| {
            let (a, b) = if i % 2 == 0 { (1.0, 39.0) } else { (39.0, 1.0) };
            [Vec2::new(*x, a), Vec2::new(*x, b)]
        })
        .collect();
    let survey: Vec<Vec<LogEvent>> = (0..2)
        .map(|w| survey_walk(w, &lines, bs.len(), &field))
        .collect();
    let bare = beacon_site("rm-walled", vec![walled_map()], &[], MODEL);
    let (m, rep) = build(&bare, &survey, &open_cfg());
    assert!(
        rep.iter().filter(|r| r.rejected.is_none()).count() >= 10,
        "{rep:?}"
    );
    let data = EngineData {
        radio_map: Some(Arc::new(m)),
        ..EngineData::default()
    };
    let cfg = EngineConfig::default();
    let mut e = build_engine_with("tcpf", bare.clone(), &cfg, None, &data).unwrap();
    let out = replay(e.as_mut(), walk_north(30, None));
    let errs: Vec<f64> = out.scored.iter().filter_map(|s| s.error_m()).collect();
    assert!(errs.len() >= 25, "{} scored", errs.len());
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(mean < 3.0, "mean error {mean:.2} m");
    // without the map the bare site knows no transmitter: no radio start
    let mut plain = build_engine_with("tcpf", bare, &cfg, None, &EngineData::default()).unwrap();
    let out = replay(plain.as_mut(), walk_north(10, None));
    assert!(out.scored.iter().all(|s| s.error_m().is_none()));
}

#[test]
fn the_tenths_table_is_the_division() {
    for x in i16::MIN..=i16::MAX {
        assert_eq!(tenths(x).to_bits(), (f64::from(x) / 10.0).to_bits(), "{x}");
    }
}

#[test]
fn the_batched_grid_sampler_is_grid_sample_bit_for_bit() {
    // cells of 2 m (power of two: multiplied) and 0.7 m (divided), values
    // in and out of the table, holes, points outside and on the edges
    for (cell_m, x0_m) in [(2.0, 180.189_042_152_872_56), (0.7, -3.3), (1.0, 0.0)] {
        let (nx, ny) = (13usize, 9usize);
        let n = nx * ny;
        let mean: Vec<i16> = (0..n)
            .map(|k| {
                if k % 11 == 3 {
                    NO_VALUE
                } else {
                    -2500 + (k as i16 * 37) % 2600
                }
            })
            .collect();
        let sd: Vec<i16> = (0..n)
            .map(|k| {
                if k % 17 == 5 {
                    NO_VALUE
                } else {
                    20 + (k as i16 * 13) % 700
                }
            })
            .collect();
        let g = Grid {
            floor: 0,
            x0_m,
            y0_m: 7.25,
            cell_m,
            nx,
            ny,
            mean_dbm_x10: mean,
            sd_dbm_x10: sd,
        };
        let gs = GridSampler::new(&g);
        let w = nx as f64 * cell_m;
        let h = ny as f64 * cell_m;
        let mut checked = 0;
        let mut ps = Vec::new();
        for i in -20..=420 {
            for j in -20..=300 {
                let p = Vec2::new(
                    x0_m + w * f64::from(i) / 400.0 + 1e-3 * f64::from(j % 7),
                    7.25 + h * f64::from(j) / 280.0,
                );
                checked += usize::from(g.sample(p).is_some());
                ps.push(p);
            }
        }
        assert!(checked > 50_000, "{checked}");
        // the two passes against the per-point sample, else the fallback
        let t_ = Transmitter {
            id: "t".into(),
            kind: TxKind::Wifi,
            floor: 0,
            pos: Vec2::new(x0_m + 3.0, 9.0),
            dz_m: 1.5,
            model: crate::ble::pathloss::PathLoss {
                rssi_1m_dbm: -45.0,
                exponent: 2.6,
            },
        };
        // every point, and a cloud of a few cells (the corner table's
        // case), with the table forced on, off, and chosen
        let cloud: Vec<Vec2> = ps
            .iter()
            .copied()
            .filter(|p| {
                (p.x - x0_m - 0.4 * w).abs() < 2.5 * cell_m
                    && (p.y - 7.25 - 0.5 * h).abs() < 2.0 * cell_m
            })
            .collect();
        assert!(cloud.len() > 100, "{}", cloud.len());
        for (has_pathloss, table, ps) in [true, false]
            .into_iter()
            .flat_map(|hp| [None, Some(true), Some(false)].map(move |t| (hp, t)))
            .flat_map(|(hp, t)| [(hp, t, &ps), (hp, t, &cloud)])
        {
            let fast = FastFallback::new(&t_, has_pathloss, &FallbackParams::default(), 0);
            let (mut mean, mut sd) = (vec![0.0; ps.len()], vec![0.0; ps.len()]);
            gs.sample_many_as(ps, &fast, &mut mean, &mut sd, table);
            for (i, p) in ps.iter().enumerate() {
                let (m, s) = g.sample(*p).unwrap_or_else(|| fast.at(*p));
                assert_eq!(
                    (m.to_bits(), s.to_bits()),
                    (mean[i].to_bits(), sd[i].to_bits())
                );
            }
        }
    }
}

/// `logs` with a magnetometer sample every 0.1 s between their first and
/// last truth points, |B| = 40 + 10 sin(x / 3) uT at the walker's
/// (interpolated) position.
fn with_magnetometer(logs: &[Vec<LogEvent>]) -> Vec<Vec<LogEvent>> {
    use crate::events::{SensorData, SensorEvent};
    logs.iter()
        .map(|l| {
            let truth: Vec<&TruthPoint> = l.iter().filter_map(LogEvent::as_truth).collect();
            let mut out = l.clone();
            for w in truth.windows(2) {
                let (a, b) = (w[0], w[1]);
                let mut t = a.t_ns;
                while t < b.t_ns {
                    let u = (t - a.t_ns) as f64 / (b.t_ns - a.t_ns) as f64;
                    let x = a.x_m + u * (b.x_m - a.x_m);
                    let m = 40.0 + 10.0 * (x / 3.0).sin();
                    out.push(LogEvent::Sensor(SensorEvent {
                        t_ns: t,
                        data: SensorData::Magnetometer([m * 0.6, 0.0, -m * 0.8]),
                    }));
                    t += 100_000_000;
                }
            }
            out.sort_by_key(LogEvent::t_ns);
            out
        })
        .collect()
}

#[test]
fn the_magnetic_section_is_built_from_the_walks_and_round_trips() {
    let site = open_site(&[(20.0, 15.0)]);
    // without magnetometer samples: no section, and a version-2 file
    let (plain, _) = build(&site, &lines_survey(1, &field), &open_cfg());
    assert!(plain.magnetic().is_none());
    assert_eq!(plain.to_file().version, 2);
    let logs = with_magnetometer(&lines_survey(1, &field));
    let (m, _) = build(&site, &logs, &open_cfg());
    let mag = m.magnetic().expect("a magnetic grid from the walks");
    // on a walked line the grid holds the field
    for x in [8.0, 15.0, 27.0] {
        let p = Vec2::new(x, 12.0);
        let (mu, sd) = mag.sample(0, p).expect("on the walk");
        let truth = 40.0 + 10.0 * (x / 3.0).sin();
        assert!((mu - truth).abs() < 2.0, "x {x}: {mu:.2} vs {truth:.2}");
        assert!(sd >= 1.5, "sd {sd}");
    }
    // switched off: no section
    let off = RadioMapConfig {
        magnetic: crate::radio::magnetic_map::MagneticMapConfig {
            enabled: false,
            ..Default::default()
        },
        ..open_cfg()
    };
    assert!(build(&site, &logs, &off).0.magnetic().is_none());
    // the file: version 3, the same grid back
    let file = m.to_file();
    assert_eq!(file.version, 3);
    let back = RadioMap::from_json(&m.to_json().unwrap(), &site).unwrap();
    assert_eq!(back.magnetic(), m.magnetic());
    // bad sections name the field
    let mut f1 = file.clone();
    let g = &mut f1.magnetic.as_mut().unwrap().grids[0];
    let k = g.mean_dbm_x10.iter().position(|v| *v != NO_VALUE).unwrap();
    g.mean_dbm_x10[k] = -50;
    let e = RadioMap::from_file(&f1, &site).unwrap_err().to_string();
    assert!(
        e.contains(&format!("magnetic.grids[0].mean_dbm_x10[{k}]")) && e.contains("uT"),
        "{e}"
    );
    let mut f2 = file;
    let g = f2.magnetic.as_ref().unwrap().grids[0].clone();
    f2.magnetic.as_mut().unwrap().grids.push(g);
    let e = RadioMap::from_file(&f2, &site).unwrap_err().to_string();
    assert!(e.contains("magnetic.grids[1].floor"), "{e}");
}

/// Walks 0 and 1 read the field as it is on lines y = 6 and 12; walk 2, a
/// phone 8 dB strong, walks lines 12, 18 and 24: only line 12 is shared.
fn offset_survey() -> Vec<Vec<LogEvent>> {
    let strong = |w: usize, k: usize, p: Vec2| field(w, k, p).map(|r| r + 8.0);
    vec![
        survey_walk(0, &zigzag(&[6.0, 12.0]), 6, &field),
        survey_walk(1, &zigzag(&[12.0, 6.0]), 6, &field),
        survey_walk(2, &zigzag(&[12.0, 18.0, 24.0]), 6, &strong),
    ]
}

#[test]
fn a_survey_walks_own_offset_is_removed_before_smoothing() {
    let site = open_site(&[]);
    let (a, b) = (Vec2::new(10.0, 6.0), Vec2::new(10.0, 24.0));
    let truth = truth_mean(b) - truth_mean(a);
    let slope = |cfg: &RadioMapConfig| {
        let mut builder = RadioMapBuilder::new(&site, cfg).unwrap();
        for l in offset_survey() {
            builder.add_log(&l);
        }
        let (m, _, s) = builder.finish().unwrap();
        let i = m.lookup(TxKind::Ble, &id(0)).unwrap();
        let mu = |p| m.expected(i, 0, p).unwrap().0;
        (mu(b) - mu(a), s)
    };
    // as walked, the strong phone's lines read ~8 dB high against the others'
    let (raw, s) = slope(&RadioMapConfig {
        walk_offsets: false,
        ..open_cfg()
    });
    assert!(raw - truth > 5.0, "raw {raw:.1} vs {truth:.1}");
    assert_eq!(s.walks_with_offset(), 0);
    let (fixed, s) = slope(&RadioMapConfig {
        walk_offsets: true,
        ..open_cfg()
    });
    assert!(
        (fixed - truth).abs() < 2.0,
        "fixed {fixed:.1} vs {truth:.1}"
    );
    assert_eq!(s.walks_with_offset(), 3);
    let off = &s.ble_walk_offsets_db;
    assert!((off[&2] - off[&0] - 8.0).abs() < 1.0, "{off:?}");
    assert!(s.wifi_walk_offsets_db.is_empty());
    // the reference scans take the same correction, walk by walk
    let scans = |offsets: bool| {
        let mut b = crate::radio::reference_scans::ReferenceScanBuilder::new(
            &crate::radio::reference_scans::ReferenceScanConfig::default(),
            Some(0),
        )
        .unwrap();
        for l in offset_survey() {
            b.add_log(&l);
        }
        let set = if offsets {
            b.finish_with_walk_offsets(|w, _| if w == 2 { 8.0 } else { 0.0 })
        } else {
            b.finish()
        };
        set.unwrap().scans().to_vec()
    };
    let (plain, shifted) = (scans(false), scans(true));
    assert_eq!(plain.len(), shifted.len());
    let n = plain.len();
    assert!(n > 10, "{n} scans");
    let last = (&plain[n - 1].tx[0], &shifted[n - 1].tx[0]);
    assert_eq!(last.0.1 - last.1.1, 80, "walk 2's last scan 8 dB lower");
    assert_eq!(plain[0].tx, shifted[0].tx, "walk 0 unchanged");
}

/// The walks' offsets grouped by the phone model that recorded them go
/// into the map and its file (version 4); a survey with no model named
/// writes the file as before.
#[test]
fn the_survey_phone_models_offsets_come_from_their_walks_and_round_trip() {
    let site = open_site(&[]);
    // walks 0 and 1 at the field's level by model "a", walk 2 and a copy
    // of it 8 dB stronger by model "b"
    let mut logs = offset_survey();
    logs.push(survey_walk(3, &zigzag(&[18.0, 12.0]), 6, &|w, k, p| {
        field(w, k, p).map(|r| r + 8.0)
    }));
    let devices = [Some("a"), Some("a"), Some("b"), Some("b")];
    let mut builder = RadioMapBuilder::new(&site, &open_cfg()).unwrap();
    for (l, d) in logs.iter().zip(devices) {
        builder.add_log_of(l, d);
    }
    let (m, _, _) = builder.finish().unwrap();
    let d = m.device_offsets();
    assert_eq!(d.len(), 2, "{d:?}");
    let (a, b) = (d["a"].ble_db.unwrap(), d["b"].ble_db.unwrap());
    assert!((b - a - 8.0).abs() < 1.0, "a {a:.2}, b {b:.2}");
    assert_eq!(d["a"].wifi_db, None);
    assert_eq!(m.device_offset_db("b", TxKind::Ble), Some(b));
    let text = m.to_json().unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["version"], 4);
    let back = RadioMap::from_json(&text, &site).unwrap();
    assert_eq!(back.device_offsets(), d);
    // no model named: no section, the version of before
    let mut builder = RadioMapBuilder::new(&site, &open_cfg()).unwrap();
    for l in &logs {
        builder.add_log(l);
    }
    let (plain, _, _) = builder.finish().unwrap();
    assert!(plain.device_offsets().is_empty());
    let plain: serde_json::Value = serde_json::from_str(&plain.to_json().unwrap()).unwrap();
    assert!(plain.get("device_offsets").is_none());
    assert_eq!(plain["version"], 2);
    // bad sections name the field
    let bad = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = json.clone();
        edit(&mut v);
        RadioMap::from_json(&v.to_string(), &site)
            .unwrap_err()
            .to_string()
    };
    let e = bad(&|v| {
        let b = v["device_offsets"]["b"].clone();
        v["device_offsets"]["\u{7}"] = b;
    });
    assert!(
        e.contains("device_offsets") && e.contains("phone model"),
        "{e}"
    );
    let e = bad(&|v| v["device_offsets"]["b"]["ble_db"] = 1e9.into());
    assert!(e.contains("device_offsets.b.ble_db"), "{e}");
}

/// A 60 x 30 m floor split by a wall along x = 30 m (one pixel wide).
fn walled_site() -> Arc<Site> {
    use crate::map::{Feature, FloorMap};
    let (w, h) = (60, 30);
    let features = (0..w * h)
        .map(|k| {
            if k % w == 30 {
                Feature::Wall
            } else {
                Feature::Walkable
            }
        })
        .collect();
    let model = crate::ble::pathloss::PathLoss {
        rssi_1m_dbm: -55.0,
        exponent: 2.0,
    };
    beacon_site(
        "walls",
        vec![FloorMap::from_features(w, h, 1.0, features)],
        &[(15.0, 15.0)],
        model,
    )
}

/// The walled site's field: the site's model less 6 dB behind the wall.
fn walled_mean(p: Vec2) -> f64 {
    let d = (p - Vec2::new(15.0, 15.0)).norm().max(0.5);
    -55.0 - 20.0 * d.log10() - if p.x > 30.5 { 6.0 } else { 0.0 }
}

#[test]
fn the_wall_prior_counts_the_walls_where_the_survey_never_went() {
    let site = walled_site();
    let west = |w| {
        survey_walk(
            w,
            &zigzag(&[6.0, 12.0, 18.0, 24.0])
                .iter()
                .map(|p| Vec2::new(p.x * 0.75, p.y))
                .collect::<Vec<_>>(),
            1,
            &|_, _, p| Some(walled_mean(p)),
        )
    };
    let east = |w| {
        let line = [
            Vec2::new(32.0, 6.0),
            Vec2::new(38.0, 6.0),
            Vec2::new(38.0, 12.0),
            Vec2::new(32.0, 12.0),
        ];
        survey_walk(w, &line, 1, &|_, _, p| Some(walled_mean(p)))
    };
    let logs = vec![west(0), west(1), east(2), east(3)];
    let cfg = RadioMapConfig {
        max_distance_m: 4.0,
        ..RadioMapConfig::default()
    };
    let on = RadioMapConfig {
        wall_prior: crate::radio::wall_prior::WallPriorConfig {
            enabled: true,
            ..Default::default()
        },
        ..cfg.clone()
    };
    let mut b = RadioMapBuilder::new(&site, &on).unwrap();
    for l in &logs {
        b.add_log(l);
    }
    let (with, _, summary) = b.finish().unwrap();
    let fit = summary.ble_wall_prior.expect("fitted");
    assert!((fit.loss.wall_db - 6.0).abs() < 1.0, "{fit:?}");
    assert!(summary.wifi_wall_prior.is_none());
    let (without, _) = build(&site, &logs, &cfg);
    let i = with.lookup(TxKind::Ble, &id(0)).unwrap();
    // behind the wall, 10 m from the survey: the prior counts the wall,
    // the path-loss fallback does not
    let p = Vec2::new(41.0, 22.0);
    let (mu_with, sd_with) = with.expected(i, 0, p).unwrap();
    let (mu_without, sd_without) = without.expected(i, 0, p).unwrap();
    assert!(
        (mu_with - walled_mean(p)).abs() < 1.0,
        "{mu_with:.1} vs {:.1}",
        walled_mean(p)
    );
    assert!(
        (mu_without - walled_mean(p) - 6.0).abs() < 1e-6,
        "{mu_without:.1}"
    );
    assert_eq!(sd_with, sd_without);
    // on the survey both follow the readings
    for p in [Vec2::new(10.0, 12.0), Vec2::new(35.0, 6.0)] {
        let a = with.expected(i, 0, p).unwrap().0;
        let b = without.expected(i, 0, p).unwrap().0;
        assert!(
            (a - walled_mean(p)).abs() < 1.5 && (b - walled_mean(p)).abs() < 1.5,
            "{p:?}: {a:.1} {b:.1}"
        );
    }
}
