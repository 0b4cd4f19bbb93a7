//! Realism statistics of a log, simulated or real, computed the same way for
//! both: step frequency and vertical-acceleration peak-to-peak (from a simple
//! gravity-tracking step detector), BLE report rate and per-beacon repeat
//! interval, and the RSSI-versus-distance slope against known beacon
//! positions and interpolated truth. `fpbp realism` prints them side by side.

use std::collections::BTreeMap;

use fpbp_core::events::{LogEvent, SensorData};
use serde::Serialize;

/// Time constant of the gravity estimate (low-pass of the accelerometer), s.
pub const GRAVITY_TAU_S: f64 = 1.0;
/// Time constant of the smoothing of the vertical acceleration, s.
pub const VERTICAL_TAU_S: f64 = 0.04;
/// A step peak must rise above this vertical acceleration, m/s^2.
pub const PEAK_THRESHOLD_MPS2: f64 = 0.6;
/// Shortest time between two steps, s.
pub const MIN_STEP_INTERVAL_S: f64 = 0.3;
/// Intervals up to this long count for the step frequency, s.
pub const MAX_STEP_INTERVAL_S: f64 = 1.0;

/// A step found by [`detect_steps`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DetectedStep {
    /// Time of the peak, s (log clock).
    pub t_s: f64,
    /// Peak minus the lowest value since the previous peak, m/s^2 (None for the first).
    pub pp_mps2: Option<f64>,
}

/// Vertical (gravity-direction) acceleration without gravity, smoothed:
/// (t_s, a_v) per accelerometer sample. Gravity is a low-pass of the
/// accelerometer, so no orientation sensor is needed.
pub fn vertical_accel(events: &[LogEvent]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut g: Option<[f64; 3]> = None;
    let mut v_s = 0.0;
    let mut t_prev = 0.0;
    for e in events {
        let LogEvent::Sensor(s) = e else { continue };
        let SensorData::Accelerometer(a) = s.data else {
            continue;
        };
        let t = s.t_ns as f64 * 1e-9;
        let gv = match g {
            None => {
                g = Some(a);
                t_prev = t;
                continue;
            }
            Some(mut gv) => {
                let dt = (t - t_prev).clamp(0.0, 1.0);
                t_prev = t;
                let k = 1.0 - (-dt / GRAVITY_TAU_S).exp();
                for i in 0..3 {
                    gv[i] += k * (a[i] - gv[i]);
                }
                g = Some(gv);
                let kv = 1.0 - (-dt / VERTICAL_TAU_S).exp();
                let gn = (gv[0] * gv[0] + gv[1] * gv[1] + gv[2] * gv[2]).sqrt();
                if gn > 0.0 {
                    let v = (a[0] * gv[0] + a[1] * gv[1] + a[2] * gv[2]) / gn - gn;
                    v_s += kv * (v - v_s);
                }
                gv
            }
        };
        let _ = gv;
        out.push((t, v_s));
    }
    out
}

/// Vertical acceleration without gravity from the accelerometer rotated to
/// the world by the latest rotation vector, smoothed like
/// [`vertical_accel`]: (t_s, a_v). Empty when the log has no rotation vector.
pub fn vertical_accel_world(events: &[LogEvent]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut q: Option<nalgebra::UnitQuaternion<f64>> = None;
    let mut v_s = 0.0;
    let mut t_prev: Option<f64> = None;
    for e in events {
        let LogEvent::Sensor(s) = e else { continue };
        match s.data {
            SensorData::RotationVector(r) => {
                q = Some(nalgebra::UnitQuaternion::from_quaternion(
                    nalgebra::Quaternion::new(r[3], r[0], r[1], r[2]),
                ));
            }
            SensorData::Accelerometer(a) => {
                let Some(q) = q else { continue };
                let t = s.t_ns as f64 * 1e-9;
                let dt = t_prev.map_or(0.0, |p| (t - p).clamp(0.0, 1.0));
                t_prev = Some(t);
                let w = q * nalgebra::Vector3::new(a[0], a[1], a[2]);
                let kv = 1.0 - (-dt / VERTICAL_TAU_S).exp();
                v_s += kv * (w.z - crate::imu::GRAVITY_MPS2 - v_s);
                out.push((t, v_s));
            }
            _ => {}
        }
    }
    out
}

/// Steps as peaks of the vertical acceleration: a peak above
/// [`PEAK_THRESHOLD_MPS2`] is taken when the signal falls back below zero;
/// peaks closer than [`MIN_STEP_INTERVAL_S`] keep the higher.
pub fn detect_steps(vert: &[(f64, f64)]) -> Vec<DetectedStep> {
    let mut steps: Vec<DetectedStep> = Vec::new();
    let mut cand: Option<(f64, f64)> = None; // (t, value) of the running maximum above threshold
    let mut low = f64::INFINITY; // lowest value since the last accepted peak
    let mut low_before_cand = f64::INFINITY;
    let mut last_peak_v = f64::NAN;
    for &(t, v) in vert {
        match cand {
            Some((_, cv)) if v > cv => cand = Some((t, v)),
            None if v > PEAK_THRESHOLD_MPS2 => {
                cand = Some((t, v));
                low_before_cand = low;
            }
            Some((ct, cv)) if v < 0.0 => {
                let close = steps
                    .last()
                    .is_some_and(|s| ct - s.t_s < MIN_STEP_INTERVAL_S);
                if close {
                    if cv > last_peak_v {
                        let n = steps.len();
                        steps[n - 1].t_s = ct;
                        if let Some(pp) = steps[n - 1].pp_mps2.as_mut() {
                            *pp += cv - last_peak_v;
                        }
                        last_peak_v = cv;
                    }
                } else {
                    let pp = (!steps.is_empty() && low_before_cand.is_finite())
                        .then_some(cv - low_before_cand);
                    steps.push(DetectedStep {
                        t_s: ct,
                        pp_mps2: pp,
                    });
                    last_peak_v = cv;
                    low = f64::INFINITY;
                }
                cand = None;
            }
            _ => {}
        }
        if cand.is_none() {
            low = low.min(v);
        }
    }
    steps
}

pub use fpbp_core::stats::quantile_sorted as quantile;

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

/// Gait figures of a log.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct GaitStats {
    pub steps: usize,
    /// Median of 1 / (interval between consecutive steps), intervals of 0.3-1 s, Hz.
    pub step_freq_hz: Option<f64>,
    /// Vertical acceleration peak-to-peak per step, p10 / p50 / p90, m/s^2.
    pub pp_p10_mps2: Option<f64>,
    pub pp_p50_mps2: Option<f64>,
    pub pp_p90_mps2: Option<f64>,
}

/// Gait figures from the accelerometer.
pub fn gait_stats(events: &[LogEvent]) -> GaitStats {
    let steps = detect_steps(&vertical_accel(events));
    let freqs = sorted(
        steps
            .windows(2)
            .map(|w| w[1].t_s - w[0].t_s)
            .filter(|d| (MIN_STEP_INTERVAL_S..=MAX_STEP_INTERVAL_S).contains(d))
            .map(|d| 1.0 / d)
            .collect(),
    );
    let pps = sorted(steps.iter().filter_map(|s| s.pp_mps2).collect());
    GaitStats {
        steps: steps.len(),
        step_freq_hz: quantile(&freqs, 0.5),
        pp_p10_mps2: quantile(&pps, 0.1),
        pp_p50_mps2: quantile(&pps, 0.5),
        pp_p90_mps2: quantile(&pps, 0.9),
    }
}

/// BLE reporting figures of a log.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BleStats {
    pub reports: usize,
    pub beacons: usize,
    /// Reports per second over the log's span.
    pub reports_per_s: f64,
    /// Interval between consecutive reports of the same beacon, p25 / p50 / p75, s.
    pub repeat_p25_s: Option<f64>,
    pub repeat_p50_s: Option<f64>,
    pub repeat_p75_s: Option<f64>,
    /// Median RSSI, dBm.
    pub rssi_p50_dbm: Option<f64>,
}

/// BLE figures over the log span (first to last event of any kind).
pub fn ble_stats(events: &[LogEvent]) -> BleStats {
    let span_s = match (events.first(), events.last()) {
        (Some(a), Some(b)) => (b.t_ns() - a.t_ns()) as f64 * 1e-9,
        _ => 0.0,
    };
    let mut last: BTreeMap<&str, i64> = BTreeMap::new();
    let mut gaps = Vec::new();
    let mut rssi = Vec::new();
    for e in events {
        let LogEvent::Ble(o) = e else { continue };
        if let Some(t) = last.insert(o.beacon_id.as_str(), o.t_ns) {
            gaps.push((o.t_ns - t) as f64 * 1e-9);
        }
        rssi.push(o.rssi_dbm);
    }
    let gaps = sorted(gaps);
    let rssi = sorted(rssi);
    BleStats {
        reports: rssi.len(),
        beacons: last.len(),
        reports_per_s: if span_s > 0.0 {
            rssi.len() as f64 / span_s
        } else {
            0.0
        },
        repeat_p25_s: quantile(&gaps, 0.25),
        repeat_p50_s: quantile(&gaps, 0.5),
        repeat_p75_s: quantile(&gaps, 0.75),
        rssi_p50_dbm: quantile(&rssi, 0.5),
    }
}

/// A beacon position for the RSSI slope: MCS metres (the truth's frame) and floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownBeacon {
    pub x_m: f64,
    pub y_m: f64,
    pub floor: i32,
}

/// The fit RSSI = a + slope * log10(d).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct RssiSlope {
    pub points: usize,
    /// dB per decade of distance (= -10 n).
    pub slope_db_per_decade: f64,
    /// RSSI at 1 m of the fit, dBm.
    pub intercept_dbm: f64,
    /// Standard deviation of the residuals, dB.
    pub residual_sigma_db: f64,
}

/// Fits RSSI against log10 of the horizontal distance between the truth
/// (linearly interpolated, only between truth points at most `max_gap_s`
/// apart) and the known position of the reporting beacon, for beacons on
/// the truth's floor and distances of at least `min_distance_m`.
pub fn rssi_slope(
    events: &[LogEvent],
    beacons: &BTreeMap<String, KnownBeacon>,
    max_gap_s: f64,
    min_distance_m: f64,
) -> Option<RssiSlope> {
    let truth: Vec<(i64, f64, f64, Option<i32>)> = events
        .iter()
        .filter_map(LogEvent::as_truth)
        .map(|t| (t.t_ns, t.x_m, t.y_m, t.floor))
        .collect();
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for e in events {
        let LogEvent::Ble(o) = e else { continue };
        let Some(b) = beacons.get(&o.beacon_id) else {
            continue;
        };
        let k = truth.partition_point(|t| t.0 <= o.t_ns);
        if k == 0 || k >= truth.len() {
            continue;
        }
        let (a, c) = (truth[k - 1], truth[k]);
        let gap = (c.0 - a.0) as f64 * 1e-9;
        if gap > max_gap_s || a.3 != c.3 || a.3.is_some_and(|f| f != b.floor) {
            continue;
        }
        let u = if c.0 > a.0 {
            (o.t_ns - a.0) as f64 / (c.0 - a.0) as f64
        } else {
            0.0
        };
        let (x, y) = (a.1 + u * (c.1 - a.1), a.2 + u * (c.2 - a.2));
        let d = (x - b.x_m).hypot(y - b.y_m);
        if d < min_distance_m {
            continue;
        }
        xs.push(d.log10());
        ys.push(o.rssi_dbm);
    }
    let n = xs.len();
    if n < 10 {
        return None;
    }
    let mx = xs.iter().sum::<f64>() / n as f64;
    let my = ys.iter().sum::<f64>() / n as f64;
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let icpt = my - slope * mx;
    let var = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (y - icpt - slope * x).powi(2))
        .sum::<f64>()
        / n as f64;
    Some(RssiSlope {
        points: n,
        slope_db_per_decade: slope,
        intercept_dbm: icpt,
        residual_sigma_db: var.sqrt(),
    })
}

/// All realism figures of one log.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Realism {
    pub duration_s: f64,
    pub gait: GaitStats,
    pub ble: BleStats,
    pub rssi: Option<RssiSlope>,
}

/// Computes every figure; `beacons` may be empty (no slope then).
pub fn realism(events: &[LogEvent], beacons: &BTreeMap<String, KnownBeacon>) -> Realism {
    let duration_s = match (events.first(), events.last()) {
        (Some(a), Some(b)) => (b.t_ns() - a.t_ns()) as f64 * 1e-9,
        _ => 0.0,
    };
    Realism {
        duration_s,
        gait: gait_stats(events),
        ble: ble_stats(events),
        rssi: rssi_slope(events, beacons, 15.0, 1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fpbp_core::events::SensorEvent;

    #[test]
    fn detector_counts_a_clean_sine() {
        // 2 Hz steps, pp 4 m/s^2, phone flat, 20 s at 50 Hz.
        let mut ev = Vec::new();
        for k in 0..1000 {
            let t = k as f64 / 50.0;
            let a = 2.0 * (std::f64::consts::TAU * 2.0 * t).sin();
            ev.push(LogEvent::Sensor(SensorEvent {
                t_ns: (t * 1e9) as i64,
                data: SensorData::Accelerometer([0.0, 0.0, 9.81 + a]),
            }));
        }
        let g = gait_stats(&ev);
        assert!((38..=41).contains(&g.steps), "{}", g.steps);
        assert!((g.step_freq_hz.unwrap() - 2.0).abs() < 0.05);
        // The smoothing takes a little off the peaks.
        let pp = g.pp_p50_mps2.unwrap();
        assert!((3.3..=4.1).contains(&pp), "{pp}");
    }

    #[test]
    fn quantiles() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&v, 0.5), Some(3.0));
        assert_eq!(quantile(&v, 0.25), Some(2.0));
        assert_eq!(quantile(&[], 0.5), None);
    }
}
