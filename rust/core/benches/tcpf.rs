//! The work of one `tcpf` radio update and one step, 1000 particles, on an
//! open 60 x 40 m floor: the per-particle likelihood of 10 heard beacons
//! and of 10 beacons + 30 access points (`radio::likelihood`), with the
//! site's path-loss model and with a radio map (1 m grids; the demo
//! site's floor 0), the weighting and the offset residuals, as
//! `engines::tcpf` does them ("batch": `CloudLikelihood`; "reference":
//! the per-particle `log_likelihood` and a second pass of `expected` for
//! the residuals, as before issue 16); and one step (predict + ESS
//! resampling); and the engine itself (`TcpfEngine` on the demo site, its
//! path-loss model, 1000 particles started at a point): one radio task
//! and one fusion task with the 10 nearest beacons heard, i.e. the
//! weighting, offset, resampling, recovery checks (a likelihood surface
//! every 5th update) and the published point with its accuracy radius,
//! without a PDR step. Compare the cases within one run.
//!
//! Run: `FPBP_BENCH_CLOCK=cpu cargo bench -p fpbp-core --bench tcpf`.

use std::hint::black_box;

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::ble::pathloss::PathLoss;
use fpbp_core::engine::{Engine, InitialPosition, Task};
use fpbp_core::engines::EngineConfig;
use fpbp_core::engines::tcpf::TcpfEngine;
use fpbp_core::events::BleObservation;
use fpbp_core::fast_math::exp_many;
use fpbp_core::fusion::ParticleFilter;
use fpbp_core::radio::likelihood::{CloudLikelihood, log_likelihood};
use fpbp_core::radio::model::{PathLossModel, PathLossParams, Transmitter, TxKind};
use fpbp_core::radio::radio_map::{FallbackParams, Grid, NO_VALUE};
use fpbp_core::radio::radio_map_file::{KindFile, PathLossFile, RadioMapFile, TxFile};
use fpbp_core::radio::{LikelihoodConfig, Measurement, RadioMap, RadioModel};
use fpbp_core::site::{Site, SiteSpec};

const DZ_M: f64 = 1.3;
const PL: PathLoss = PathLoss {
    rssi_1m_dbm: -60.0,
    exponent: 2.2,
};

/// Position of transmitter `k` of a grid over 60 x 40 m.
fn tx_pos(k: usize) -> Vec2 {
    Vec2::new(3.0 + (k % 8) as f64 * 7.5, 3.0 + (k / 8) as f64 * 7.0)
}

/// A path-loss model of `n` transmitters (the first 10 BLE, then WiFi).
fn model(n: usize) -> PathLossModel {
    let tx: Vec<Transmitter> = (0..n)
        .map(|k| Transmitter {
            id: format!("t{k}"),
            kind: if k < 10 { TxKind::Ble } else { TxKind::Wifi },
            floor: 0,
            pos: tx_pos(k),
            dz_m: DZ_M,
            model: PL,
        })
        .collect();
    PathLossModel::from_transmitters(
        tx,
        PathLossParams {
            ble_sd_db: 6.0,
            wifi_sd_db: 6.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            phone_height_m: 1.2,
        },
    )
}

/// The demo site (maps/demo).
fn demo_site() -> Site {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../maps/demo");
    let bytes = std::fs::read(dir.join("site.json")).expect("maps/demo/site.json");
    let spec = SiteSpec::from_json(&bytes, "site.json").expect("demo spec");
    Site::build(spec, "site.json", &mut |p: &str| std::fs::read(dir.join(p))).expect("demo site")
}

/// A radio map of `n` transmitters placed as in [`model`], each with a
/// 1 m grid over 60 x 40 m on floor 0 (the path-loss curve, spreads
/// 4-8 dB varying by cell, one cell in 29 without a value) and a
/// path-loss fallback.
fn radio_map(site: &Site, n: usize) -> RadioMap {
    let (nx, ny) = (60usize, 40usize);
    let transmitters = (0..n)
        .map(|k| {
            let pos = tx_pos(k);
            let (mut mean, mut sd) = (Vec::new(), Vec::new());
            for j in 0..ny {
                for i in 0..nx {
                    let c = Vec2::new(i as f64 + 0.5, j as f64 + 0.5);
                    let d = ((c - pos).norm_squared() + DZ_M * DZ_M).sqrt();
                    let hole = (i * 7 + j * 13 + k) % 29 == 0;
                    mean.push(if hole {
                        NO_VALUE
                    } else {
                        (PL.rssi_at(d, 0.5) * 10.0).round() as i16
                    });
                    sd.push(if hole {
                        NO_VALUE
                    } else {
                        40 + ((i + 2 * j + k) % 40) as i16
                    });
                }
            }
            TxFile {
                id: if k < 10 {
                    format!("ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:7:{k}")
                } else {
                    format!("02:00:00:00:00:{k:02x}")
                },
                kind: if k < 10 {
                    KindFile::Ble
                } else {
                    KindFile::Wifi
                },
                floor: 0,
                x_m: pos.x,
                y_m: pos.y,
                pathloss: Some(PathLossFile {
                    dz_m: DZ_M,
                    rssi_1m_dbm: PL.rssi_1m_dbm,
                    exponent: PL.exponent,
                }),
                samples: 100,
                walks: 2,
                grids: vec![Grid {
                    floor: 0,
                    x0_m: 0.0,
                    y0_m: 0.0,
                    cell_m: 1.0,
                    nx,
                    ny,
                    mean_dbm_x10: mean,
                    sd_dbm_x10: sd,
                }],
            }
        })
        .collect();
    let file = RadioMapFile {
        format: fpbp_core::radio::radio_map_file::FORMAT.into(),
        version: fpbp_core::radio::radio_map_file::VERSION,
        site: "bench".into(),
        fallback: FallbackParams::default(),
        transmitters,
        reference_scans: None,
        magnetic: None,
        device_offsets: Default::default(),
    };
    RadioMap::from_file(&file, site).expect("bench radio map")
}

/// What one radio update of `engines::tcpf` computes per particle besides
/// the likelihood: the cloud's mean likelihood, its log-sum-exp, the
/// tempered weighting; `residual(k)` gives transmitter k's weighted
/// (mean, sd, weight) sums.
fn weigh(pf: &mut ParticleFilter, log_l: &mut [f64], m: usize, alpha: f64) -> f64 {
    let m = m.max(1) as f64;
    // the exponentials in one pass each, as the engine takes them
    let mut xs: Vec<f64> = log_l.iter().map(|l| l / m).collect();
    let mut ex = vec![0.0; xs.len()];
    exp_many(&xs, &mut ex);
    let mean_l = ex.iter().sum::<f64>();
    let lmax = log_l
        .iter()
        .fold(f64::NEG_INFINITY, |a, u| a.max(alpha * u));
    xs.clear();
    xs.extend(log_l.iter().map(|u| alpha * u - lmax));
    exp_many(&xs, &mut ex);
    let lse = lmax + ex.iter().sum::<f64>().ln();
    log_l.iter_mut().for_each(|u| *u *= alpha);
    pf.weight_log(log_l);
    mean_l + lse
}

fn radio_update(c: &mut Criterion) {
    let cfg = LikelihoodConfig::default();
    let fusion = fpbp_core::engines::tcpf::TcpfConfig::default().filter();
    let site = demo_site();
    for n in [10usize, 40] {
        let pl = model(n);
        let map = radio_map(&site, n);
        let models: [(&str, &dyn RadioModel); 2] = [("path loss", &pl), ("radio map", &map)];
        for (name, m) in models {
            let at = Vec2::new(30.0, 20.0);
            let meas: Vec<Measurement> = (0..n)
                .map(|tx| Measurement {
                    tx,
                    rssi_dbm: m.expected(tx, 0, at).unwrap().0 - 3.0,
                    readings: 1,
                })
                .collect();
            let mut pf = ParticleFilter::new(&fusion, 1);
            pf.init_at(at, 8.0, |_| true);
            let mut log_l = Vec::with_capacity(1000);
            let alpha = cfg.alpha(n);
            let label = if n == 10 {
                "10 tx".to_string()
            } else {
                "10 beacons + 30 APs".to_string()
            };
            c.bench_function(
                &format!("tcpf radio update, {name}, 1000 particles, {label}, batch"),
                |b| {
                    let mut cloud = CloudLikelihood::default();
                    common::run(b, || {
                        cloud.evaluate(m, &cfg, &meas, 0, pf.particles(), -3.0, &mut log_l);
                        let mut acc = weigh(&mut pf, &mut log_l, n, alpha);
                        for k in 0..meas.len() {
                            acc += cloud
                                .weighted_expected(k, pf.weights())
                                .map_or(0.0, |r| r.0);
                        }
                        black_box(acc)
                    })
                },
            );
            c.bench_function(
                &format!("tcpf radio update, {name}, 1000 particles, {label}, reference"),
                |b| {
                    common::run(b, || {
                        log_l.clear();
                        for p in pf.particles() {
                            log_l.push(log_likelihood(m, &cfg, &meas, 0, *p, -3.0));
                        }
                        let mut acc = weigh(&mut pf, &mut log_l, n, alpha);
                        let (ps, ws) = (pf.particles(), pf.weights());
                        for mm in &meas {
                            let mut mu = 0.0;
                            for (p, w) in ps.iter().zip(ws) {
                                mu += w * m.expected(mm.tx, 0, *p).unwrap().0;
                            }
                            acc += mu;
                        }
                        black_box(acc)
                    })
                },
            );
        }
    }
    let mut pf = ParticleFilter::new(&fusion, 1);
    pf.init_at(Vec2::new(30.0, 20.0), 8.0, |_| true);
    c.bench_function(
        "tcpf step (predict + ESS resampling), 1000 particles",
        |b| {
            common::run(b, || {
                pf.predict(0.7, 0.3);
                pf.resample_if_degenerate();
                black_box(pf.mean())
            })
        },
    );
}

/// One radio task and one fusion task of the engine with the 10 beacons
/// nearest to a point heard 3 dB below the site's path-loss model, after
/// a told start: with the defaults (the fit check on, as without a radio
/// map) and with the fit off (neither the fit check nor the radius's fit
/// term: their cost is the difference).
fn engine_update(c: &mut Criterion) {
    let site = std::sync::Arc::new(demo_site());
    let mut off = EngineConfig::default();
    off.tcpf.integrity.fit_free_z2 = 0.0;
    off.tcpf.integrity.fit_accuracy_m_per_z2_without_map = 0.0;
    for (cfg, name) in [(EngineConfig::default(), ""), (off, ", fit off")] {
        engine_update_with(c, &site, &cfg, name);
    }
}

fn engine_update_with(
    c: &mut Criterion,
    site: &std::sync::Arc<Site>,
    cfg: &EngineConfig,
    name: &str,
) {
    let at = Vec2::new(30.0, 20.0);
    let init = InitialPosition {
        x_m: at.x,
        y_m: at.y,
        floor: 0,
        heading_rad: None,
    };
    let mut e = TcpfEngine::new(site.clone(), cfg, Some(init)).expect("tcpf on the demo site");
    let mut heard: Vec<(f64, String, f64)> = e
        .model()
        .transmitters()
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let mu = e.model().expected(k, 0, at).unwrap().0;
            ((t.pos - at).norm(), t.id.clone(), mu - 3.0)
        })
        .collect();
    heard.sort_by(|a, b| a.0.total_cmp(&b.0));
    heard.truncate(10);
    let mut t_ns = 0i64;
    c.bench_function(
        &format!(
            "tcpf engine radio + fusion task, 1000 particles, 10 beacons heard (no step){name}"
        ),
        |b| {
            common::run(b, || {
                t_ns += 1_000_000_000;
                for (_, id, rssi) in &heard {
                    e.on_ble(&BleObservation {
                        t_ns,
                        beacon_id: id.clone(),
                        rssi_dbm: *rssi,
                        tx_power_dbm: None,
                    });
                }
                e.run_task(Task::Radio, t_ns);
                e.run_task(Task::Fusion, t_ns);
                black_box(e.pose())
            })
        },
    );
}

criterion_group!(benches, radio_update, engine_update);
criterion_main!(benches);
