//! Recovery and its likelihood surface: the cell cache, the bound that
//! skips the surface, the told start on an open floor.

use super::*;

#[test]
fn the_cell_cache_gives_the_models_values() {
    use crate::ble::pathloss::PathLoss;
    use crate::radio::model::{PathLossModel, PathLossParams, Transmitter};
    let tx: Vec<Transmitter> = (0..4)
        .map(|k| Transmitter {
            id: format!("t{k}"),
            kind: TxKind::Ble,
            floor: 0,
            pos: Vec2::new(2.0 + 5.0 * f64::from(k), 3.0),
            dz_m: 1.0,
            model: PathLoss {
                rssi_1m_dbm: -60.0,
                exponent: 2.1,
            },
        })
        .collect();
    let model = PathLossModel::from_transmitters(
        tx,
        PathLossParams {
            ble_sd_db: 6.0,
            wifi_sd_db: 6.0,
            floor_loss_db: 15.0,
            other_floor_sd_db: 4.0,
            min_range_m: 0.5,
            phone_height_m: 1.2,
        },
    );
    let cells: Vec<Vec2> = (0..300)
        .map(|i| Vec2::new(f64::from(i % 20), f64::from(i / 20)))
        .collect();
    let meas: Vec<Measurement> = [1usize, 3, 99]
        .iter()
        .map(|&tx| Measurement {
            tx,
            rssi_dbm: -70.0,
            readings: 1,
        })
        .collect();
    let mut cache = CellExpected::default();
    cache.fill(&model, 0, &cells, &meas);
    // the known transmitters held, the unknown one not
    assert_eq!(cache.by.len(), 2);
    assert_eq!(cache.pairs, 2 * cells.len());
    let with = WithCells {
        model: &model,
        floor: 0,
        cells: &cells,
        cache: &cache,
    };
    let copy = cells.clone();
    let n = cells.len();
    for (floor, ps) in [(0, &cells), (0, &copy), (1, &cells)] {
        for tx in 0..5 {
            let (mut a, mut b) = ((vec![0.0; n], vec![0.0; n]), (vec![0.0; n], vec![0.0; n]));
            let ka = with.expected_many(tx, floor, ps, &mut a.0, &mut a.1);
            let kb = model.expected_many(tx, floor, ps, &mut b.0, &mut b.1);
            assert_eq!(ka, kb);
            if ka {
                assert_eq!(a, b, "tx {tx}, floor {floor}");
            }
        }
    }
}

#[test]
fn on_an_open_floor_the_radio_alone_reseeds_a_told_start() {
    // the walk along x = 7 on a floor without walls, told to start 4 m east
    // of it: nothing but the radio can say the cloud is off, so by default
    // its dips re-seed the cloud from the likelihood surface
    use crate::site::testkit::{beacon_site, open_map};
    let bs: Vec<(f64, f64)> = beacons().iter().map(|p| (p.x, p.y)).collect();
    let site = beacon_site("open", vec![open_map(20, 40)], &bs, MODEL);
    let ev = walk_north(30, None);
    let init = InitialPosition {
        x_m: 11.0,
        y_m: 4.0,
        floor: 0,
        heading_rad: None,
    };
    let reseeded = |at: Option<InitialPosition>| {
        let cfg = EngineConfig::default();
        let mut e = TcpfEngine::new(Arc::clone(&site), &cfg, at).unwrap();
        let _ = replay(&mut e, ev.iter().cloned());
        e.counts.reseeded
    };
    assert!(reseeded(Some(init)) > 0);
}

/// The path-loss model with a spread that grows along x (as a radio
/// map's does away from the survey walks): the surface's bound must hold
/// where the sd differs between cells.
struct SpreadAlongX(crate::radio::PathLossModel);

impl RadioModel for SpreadAlongX {
    fn transmitters(&self) -> &[crate::radio::Transmitter] {
        self.0.transmitters()
    }

    fn lookup(&self, kind: TxKind, id: &str) -> Option<usize> {
        self.0.lookup(kind, id)
    }

    fn expected(&self, tx: usize, floor: i32, p: Vec2) -> Option<(f64, f64)> {
        let (mu, sd) = self.0.expected(tx, floor, p)?;
        Some((mu, sd * (0.5 + 0.1 * p.x.abs())))
    }
}

/// [`TcpfEngine::surface_gap_bound`] is at least the gap of the surface it
/// stands for (with the cloud's log-likelihood 0, so the surface's own
/// log-sum-exp less the log of its weights' sum), on the path-loss model
/// and on one whose spread varies over the cells, for readings near and
/// far from the model, with and without a prior: the surface it
/// lets the engine skip could not have re-seeded.
#[test]
fn the_surface_bound_is_never_below_the_surface() {
    let s = site();
    let cfg = EngineConfig::default();
    let plain = PathLossModel::for_site(&s, TcpfEngine::path_loss_params(&cfg));
    let models: [Arc<dyn RadioModel>; 2] = [Arc::new(plain.clone()), Arc::new(SpreadAlongX(plain))];
    for model in models {
        let mut e = TcpfEngine::with_model(Arc::clone(&s), &cfg, None, model).unwrap();
        let n = e.model().transmitters().len();
        let all: Vec<usize> = (0..n).collect();
        for (trial, at) in [(0, Vec2::new(7.0, 4.0)), (1, Vec2::new(15.0, 30.0))] {
            for shift in [-30.0, -9.0, 0.0, 4.0, 25.0] {
                for heard in [&all[..1], &all[..n / 2], &all[..]] {
                    let meas: Vec<Measurement> = heard
                        .iter()
                        .map(|&tx| Measurement {
                            tx,
                            rssi_dbm: e.model().expected(tx, 0, at).unwrap().0
                                + shift
                                + 3.0 * (tx as f64 * 1.3 + f64::from(trial)).sin(),
                            readings: 1,
                        })
                        .collect();
                    for prior in [(0.0, 4.0), (-9.0, 1.0)] {
                        let bound = e.surface_gap_bound(0, &meas, 0.0).expect("cells held");
                        let surf = e.surface(0, &meas, &[], prior).unwrap();
                        let gap = surf.lse - surf.w.iter().sum::<f64>().ln();
                        assert!(bound >= gap, "{bound} < {gap} (shift {shift})");
                    }
                }
            }
        }
    }
}
