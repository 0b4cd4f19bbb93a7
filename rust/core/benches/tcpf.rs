//! The work of one `tcpf` radio update and one step, 1000 particles, on an
//! open 60 x 40 m floor: the per-particle likelihood of 10 heard beacons
//! and of 10 beacons + 30 access points (`radio::likelihood`), the
//! weighting, and one step (predict + ESS resampling). No target from the
//! issue is claimed here; compare before / after in one run.
//!
//! Run: `FPBP_BENCH_CLOCK=cpu cargo bench -p fpbp-core --bench tcpf`.

use std::hint::black_box;

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use fpbp_core::Vec2;
use fpbp_core::ble::pathloss::PathLoss;
use fpbp_core::fusion::ParticleFilter;
use fpbp_core::radio::likelihood::log_likelihood;
use fpbp_core::radio::model::{PathLossModel, PathLossParams, Transmitter, TxKind};
use fpbp_core::radio::{LikelihoodConfig, Measurement, RadioModel};

/// A model of `n` transmitters on a grid over 60 x 40 m.
fn model(n: usize) -> PathLossModel {
    let tx: Vec<Transmitter> = (0..n)
        .map(|k| Transmitter {
            id: format!("t{k}"),
            kind: if k < 10 { TxKind::Ble } else { TxKind::Wifi },
            floor: 0,
            pos: Vec2::new(3.0 + (k % 8) as f64 * 7.5, 3.0 + (k / 8) as f64 * 7.0),
            dz_m: 1.3,
            model: PathLoss {
                rssi_1m_dbm: -60.0,
                exponent: 2.2,
            },
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

fn radio_update(c: &mut Criterion) {
    let cfg = LikelihoodConfig::default();
    let fusion = fpbp_core::engines::tcpf::TcpfConfig::default().filter();
    for n in [10usize, 40] {
        let m = model(n);
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
        c.bench_function(&format!("tcpf radio update, 1000 particles, {n} tx"), |b| {
            common::run(b, || {
                log_l.clear();
                for p in pf.particles() {
                    log_l.push(alpha * log_likelihood(&m, &cfg, &meas, 0, *p, -3.0));
                }
                pf.weight_log(&log_l);
                black_box(pf.effective_sample_size())
            })
        });
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

criterion_group!(benches, radio_update);
criterion_main!(benches);
