//! The likelihood: the truth most likely, the batched forms against the
//! per-point ones, misses and outliers.

use super::*;
use crate::ble::pathloss::PathLoss;
use crate::radio::model::{PathLossModel, PathLossParams};
use crate::site::testkit;

fn model() -> PathLossModel {
    let pl = PathLoss {
        rssi_1m_dbm: -60.0,
        exponent: 2.0,
    };
    let bs = [(2.0, 2.0), (18.0, 2.0), (10.0, 18.0)];
    let site = testkit::beacon_site("lik", vec![testkit::open_map(20, 20)], &bs, pl);
    PathLossModel::for_site(
        &site,
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

fn heard(m: &PathLossModel, at: Vec2, offset: f64) -> Vec<Measurement> {
    (0..m.transmitters().len())
        .map(|tx| Measurement {
            tx,
            rssi_dbm: m.expected(tx, 0, at).unwrap().0 + offset,
            readings: 1,
        })
        .collect()
}

#[test]
fn truth_is_most_likely_and_offset_is_profiled() {
    let m = model();
    let cfg = LikelihoodConfig::default();
    let at = Vec2::new(6.0, 9.0);
    let meas = heard(&m, at, -8.0);
    let l_true = log_likelihood(&m, &cfg, &meas, 0, at, -8.0);
    for q in [
        Vec2::new(12.0, 9.0),
        Vec2::new(6.0, 15.0),
        Vec2::new(15.0, 3.0),
    ] {
        assert!(log_likelihood(&m, &cfg, &meas, 0, q, -8.0) < l_true);
    }
    let (o, _, _) = profiled(&m, &cfg, &meas, 0, at, 0.0, 100.0);
    assert!((o + 8.0).abs() < 0.01, "{o}");
    // a tight prior pulls it back towards 0
    let (o2, _, _) = profiled(&m, &cfg, &meas, 0, at, 0.0, 1.0);
    assert!(o2 > -8.0 && o2 < 0.0);
}

/// A model whose spread varies with the position (as a radio map's),
/// through the trait's default `expected_many`.
struct Wavy(PathLossModel);

impl RadioModel for Wavy {
    fn transmitters(&self) -> &[crate::radio::model::Transmitter] {
        self.0.transmitters()
    }
    fn lookup(&self, kind: crate::radio::model::TxKind, id: &str) -> Option<usize> {
        self.0.lookup(kind, id)
    }
    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let (mu, _) = self.0.expected(tx, floor, p)?;
        Some((
            mu,
            3.0 + 2.0 * (0.7 * p.x + 0.3 * p.y + tx as f64).sin().abs(),
        ))
    }
}

#[test]
fn the_cloud_likelihood_is_the_per_particle_one() {
    let pl = PathLossParams {
        ble_sd_db: 6.0,
        wifi_sd_db: 5.0,
        floor_loss_db: 15.0,
        other_floor_sd_db: 4.0,
        min_range_m: 0.5,
        phone_height_m: 1.2,
    };
    // 20 transmitters (more than PRODUCT_TERMS), BLE and WiFi
    let bs: Vec<(f64, f64)> = (0..20)
        .map(|k| (1.0 + (k % 5) as f64 * 4.5, 1.0 + (k / 5) as f64 * 5.5))
        .collect();
    let curve = PathLoss {
        rssi_1m_dbm: -60.0,
        exponent: 2.3,
    };
    let site = testkit::beacon_site("cloud", vec![testkit::open_map(20, 20)], &bs, curve);
    let m = PathLossModel::for_site(&site, pl);
    let wavy = Wavy(m.clone());
    let ps: Vec<Vec2> = (0..400)
        .map(|i| Vec2::new((i % 20) as f64 * 1.03, (i / 20) as f64 * 0.97))
        .chain(bs.iter().map(|b| Vec2::new(b.0, b.1)))
        .collect();
    let mut cloud = CloudLikelihood::default();
    let mut out = Vec::new();
    let cfgs = [1.0, 0.4, 0.75].map(|sd_norm_weight| LikelihoodConfig {
        sd_norm_weight,
        ..LikelihoodConfig::default()
    });
    let cfg = &cfgs[0];
    let cases = [&m as &dyn RadioModel, &wavy].into_iter().enumerate();
    for ((k, model), cfg) in cases.flat_map(|c| cfgs.iter().map(move |g| (c, g))) {
        for n_heard in [1usize, 7, 8, 9, 20] {
            // heard at (7, 11) with an offset, one 25 dB outlier, one
            // unknown transmitter index
            let mut meas: Vec<Measurement> = (0..n_heard)
                .map(|tx| Measurement {
                    tx,
                    rssi_dbm: model.expected(tx, 0, Vec2::new(7.0, 11.0)).unwrap().0 - 5.0
                        + (tx as f64 * 1.7).sin() * 4.0,
                    readings: 1,
                })
                .collect();
            meas[0].rssi_dbm -= 25.0;
            meas.push(Measurement {
                tx: 999,
                rssi_dbm: -70.0,
                readings: 1,
            });
            cloud.evaluate(model, cfg, &meas, 0, &ps, -5.0, &mut out);
            assert_eq!(out.len(), ps.len());
            let mut worst: f64 = 0.0;
            for (p, l) in ps.iter().zip(&out) {
                let exact = log_likelihood(model, cfg, &meas, 0, *p, -5.0);
                worst = worst.max((l - exact).abs());
            }
            assert!(worst < 1e-6, "model {k}, {n_heard} heard: {worst}");
            // each particle with its own offset
            let offs: Vec<f64> = (0..ps.len()).map(|i| -9.0 + (i % 7) as f64).collect();
            let mut each = Vec::new();
            cloud.evaluate_each(model, cfg, &meas, 0, &ps, &offs, &mut each);
            for ((p, l), o) in ps.iter().zip(&each).zip(&offs) {
                let exact = log_likelihood(model, cfg, &meas, 0, *p, *o);
                assert!((l - exact).abs() < 1e-6, "{l} {exact}");
            }
            cloud.evaluate(model, cfg, &meas, 0, &ps, -5.0, &mut out);
            // the residual sums are those of `expected`
            let w: Vec<f64> = (0..ps.len()).map(|i| 1.0 + (i % 3) as f64).collect();
            for (j, mm) in meas.iter().enumerate() {
                let got = cloud.weighted_expected(j, &w);
                if mm.tx == 999 {
                    assert!(got.is_none());
                    continue;
                }
                let (mu, sd, ws) = got.unwrap();
                let (mut mu0, mut sd0, mut ws0) = (0.0, 0.0, 0.0);
                for (p, wi) in ps.iter().zip(&w) {
                    let (a, b) = model.expected(mm.tx, 0, *p).unwrap();
                    (mu0, sd0, ws0) = (mu0 + wi * a, sd0 + wi * b, ws0 + wi);
                }
                assert!((mu / ws - mu0 / ws0).abs() < 1e-8, "{mu} {mu0}");
                assert!((sd / ws - sd0 / ws0).abs() < 1e-9 && ws == ws0);
            }
        }
    }
    // an empty cloud and no measurement
    cloud.evaluate(&m, cfg, &[], 0, &ps, 0.0, &mut out);
    assert!(out.iter().all(|l| *l == 0.0) && out.len() == ps.len());
    cloud.evaluate(&m, cfg, &heard(&m, ps[0], 0.0), 0, &[], 0.0, &mut out);
    assert!(out.is_empty());
}

#[test]
fn the_profiled_surface_is_the_per_point_one() {
    let m = model();
    let wavy = Wavy(m.clone());
    let ps: Vec<Vec2> = (0..400)
        .map(|i| Vec2::new((i % 20) as f64 * 1.03, (i / 20) as f64 * 0.97))
        .collect();
    let (mut offs, mut sds, mut lls) = (Vec::new(), Vec::new(), Vec::new());
    for (model, w) in [(&m as &dyn RadioModel, 1.0), (&wavy, 1.0), (&wavy, 0.3)] {
        let cfg = LikelihoodConfig {
            sd_norm_weight: w,
            ..LikelihoodConfig::default()
        };
        let mut meas = heard(&m, Vec2::new(6.0, 9.0), -7.0);
        meas[1].rssi_dbm -= 20.0;
        meas.push(Measurement {
            tx: 999,
            rssi_dbm: -70.0,
            readings: 1,
        });
        profiled_many(
            model, &cfg, &meas, 0, &ps, -2.0, 4.0, &mut offs, &mut sds, &mut lls,
        );
        assert_eq!((offs.len(), lls.len()), (ps.len(), ps.len()));
        for (((p, o), sd), l) in ps.iter().zip(&offs).zip(&sds).zip(&lls) {
            let (o0, l0, sd0) = profiled(model, &cfg, &meas, 0, *p, -2.0, 4.0);
            assert!((o - o0).abs() < 1e-8 && (l - l0).abs() < 1e-6, "{p:?}");
            assert!((sd - sd0).abs() < 1e-12, "{p:?}");
        }
    }
}

#[test]
fn the_spread_normaliser_is_weighted() {
    let wavy = Wavy(model());
    let meas = heard(&wavy.0, Vec2::new(6.0, 9.0), 0.0);
    let p = Vec2::new(11.0, 4.0);
    let full = LikelihoodConfig {
        sd_norm_weight: 1.0,
        ..LikelihoodConfig::default()
    };
    let none = LikelihoodConfig {
        sd_norm_weight: 0.0,
        ..full.clone()
    };
    let (mut sum_t, mut sum_ln_sd) = (0.0, 0.0);
    for m in &meas {
        let (mu, sd) = wavy.expected(m.tx, 0, p).unwrap();
        sum_t += full.log_t((m.rssi_dbm - mu) / sd);
        sum_ln_sd += sd.ln();
    }
    // weight 0: the residuals alone, a wide spread costs nothing
    assert!((log_likelihood(&wavy, &none, &meas, 0, p, 0.0) - sum_t).abs() < 1e-12);
    let l_full = log_likelihood(&wavy, &full, &meas, 0, p, 0.0);
    assert!((l_full - (sum_t - sum_ln_sd)).abs() < 1e-12);
    let bad = LikelihoodConfig {
        sd_norm_weight: 1.5,
        ..full
    };
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("tcpf.likelihood.sd_norm_weight"), "{e}");
}

#[test]
fn one_outlier_costs_a_bounded_amount() {
    let m = model();
    let cfg = LikelihoodConfig::default();
    let at = Vec2::new(6.0, 9.0);
    let mut meas = heard(&m, at, 0.0);
    let base = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
    meas[0].rssi_dbm -= 20.0;
    let a = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
    meas[0].rssi_dbm -= 20.0;
    let b = log_likelihood(&m, &cfg, &meas, 0, at, 0.0);
    // Gaussian: 20 -> 40 dB would cost 3x more; Student-t far less
    assert!(
        base - a > 0.0 && (base - b) < 2.0 * (base - a),
        "{base} {a} {b}"
    );
    assert!(cfg.alpha(1) > cfg.alpha(16));
    assert_eq!(cfg.alpha(0), 0.0);
    assert!(LikelihoodConfig::default().validate().is_ok());
    let bad = LikelihoodConfig {
        student_nu: 0.0,
        ..Default::default()
    };
    assert!(
        bad.validate()
            .unwrap_err()
            .to_string()
            .contains("student_nu")
    );
}
