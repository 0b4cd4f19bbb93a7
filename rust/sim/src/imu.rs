//! The phone's motion and environment sensors along a trajectory:
//! accelerometer (gravity + a step-synchronous profile whose vertical
//! peak-to-peak follows the Weinberg model), gyroscope (the true orientation
//! change plus bias and noise), rotation vector (true orientation with a slow
//! yaw drift), magnetometer (earth field + local disturbances) and barometer
//! (floor height + weather drift). Device frame as Android's: x right, y up
//! the screen, z out of the screen; world frame ENU.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use fpbp_core::Vec2;
use fpbp_core::events::{SensorData, SensorEvent};
use nalgebra::{UnitQuaternion, Vector3};
use rand_pcg::Pcg64;

use crate::noise::{normal, std_normal, uniform};
use crate::profile::{Carry, ImuConfig, WalkConfig};
use crate::walk::{Trajectory, body_yaw_series};

/// Standard gravity used by the simulator, m/s^2.
pub const GRAVITY_MPS2: f64 = 9.80665;
/// Time constant of the hand-tremor orientation process, s.
const TREMOR_TAU_S: f64 = 0.5;

/// What the sensor generator needs besides the trajectory.
pub struct ImuContext<'a> {
    pub imu: &'a ImuConfig,
    pub walk: &'a WalkConfig,
    /// ENU -> MCS rotation of the site, rad.
    pub map_from_enu_rad: f64,
    /// Height of the walked floor, m.
    pub floor_height_m: f64,
    /// Extent of the floor, m (for placing magnetic disturbances).
    pub floor_size_m: [f64; 2],
    /// Log start on the elapsedRealtime clock, ns.
    pub t0_ns: i64,
}

/// Converts a time in seconds from the log start to t_ns.
pub fn to_ns(t0_ns: i64, t_s: f64) -> i64 {
    t0_ns + (t_s * 1e9).round() as i64
}

/// Gait state at time t: step index (possibly fractional phase) and the step's figures.
struct Gait {
    /// Phase within the current step in [0, 1), or 0 when still.
    tau: f64,
    /// Steps completed before this moment (integer part of the stride phase).
    k: f64,
    /// Vertical peak-to-peak of the current step, 0 when still.
    pp: f64,
    /// Envelope of the arm swing: ramps up over a leg's first step and down
    /// over its last, 0 when still.
    env: f64,
}

/// 1 / |H(f)| of a first-order low-pass with cut-off `fc_hz` at the step
/// frequency 1 / `step_s` (1 when `fc_hz` is 0).
pub fn lowpass_boost_hz(fc_hz: f64, step_s: f64) -> f64 {
    if fc_hz > 0.0 && step_s > 0.0 {
        (1.0 + (1.0 / (step_s * fc_hz)).powi(2)).sqrt()
    } else {
        1.0
    }
}

fn lowpass_boost(traj: &Trajectory, step_s: f64) -> f64 {
    lowpass_boost_hz(traj.weinberg_lowpass_hz, step_s)
}

fn gait_at(traj: &Trajectory, t_s: f64) -> Gait {
    let p = traj.phase_at(t_s);
    match p.step {
        Some(i) => {
            let st = &traj.steps[i];
            let dur = st.t_end_s - st.t_start_s;
            let tau = ((t_s - st.t_start_s) / dur).clamp(0.0, 1.0);
            let into = st.leg_step as f64 + tau;
            let env = into.min(st.leg_steps as f64 - into).clamp(0.0, 1.0);
            Gait {
                tau,
                k: i as f64,
                pp: st.accel_pp_mps2 * lowpass_boost(traj, dur),
                env,
            }
        }
        None => {
            // Steps completed so far: the first step starting at or after t.
            let k = traj.steps.partition_point(|s| s.t_start_s < t_s);
            Gait {
                tau: 0.0,
                k: k as f64,
                pp: 0.0,
                env: 0.0,
            }
        }
    }
}

/// Arm angle of the swinging hand at t, rad: A * envelope * sin(stride phase).
fn swing_angle(traj: &Trajectory, amp_rad: f64, t_s: f64) -> f64 {
    let g = gait_at(traj, t_s);
    amp_rad * g.env * (PI * (g.k + g.tau)).sin()
}

/// Step of the central differences of the arm motion, s.
const ARM_DIFF_S: f64 = 0.002;

/// A magnetic disturbance: a Gaussian bump of field `b_ut` (ENU) around `at`.
struct MagSource {
    at: Vec2,
    b_ut: Vector3<f64>,
}

/// Generates every sensor event of the log, in time order.
pub fn sensors(traj: &Trajectory, ctx: &ImuContext, rng: &mut Pcg64) -> Vec<SensorEvent> {
    let c = ctx.imu;
    let dt = 1.0 / c.rate_hz;
    let n = (traj.duration_s / dt).floor() as usize + 1;
    // Sample times (jittered, kept increasing), plus one beyond for the gyro's forward difference.
    let mut times: Vec<f64> = Vec::with_capacity(n + 1);
    for k in 0..=n {
        let j = normal(rng, 0.0, c.timestamp_jitter_s).clamp(-0.3 * dt, 0.3 * dt);
        times.push((k as f64 * dt + j).max(0.0));
    }
    let yaw_body = body_yaw_series(traj, ctx.walk, &times);

    // Constants of this phone and this walk, drawn once.
    let yaw_offset = normal(rng, 0.0, c.yaw_offset_rad);
    let drift_rate = normal(rng, 0.0, c.yaw_drift_rate_rad_s);
    let acc_bias = Vector3::new(
        normal(rng, 0.0, c.accel_bias_mps2),
        normal(rng, 0.0, c.accel_bias_mps2),
        normal(rng, 0.0, c.accel_bias_mps2),
    );
    let gyr_bias = Vector3::new(
        normal(rng, 0.0, c.gyro_bias_rad_s),
        normal(rng, 0.0, c.gyro_bias_rad_s),
        normal(rng, 0.0, c.gyro_bias_rad_s),
    );
    let mag_bias = Vector3::new(
        normal(rng, 0.0, c.mag_bias_ut),
        normal(rng, 0.0, c.mag_bias_ut),
        normal(rng, 0.0, c.mag_bias_ut),
    );
    let area = ctx.floor_size_m[0] * ctx.floor_size_m[1];
    let n_src = (area / 100.0 * c.mag_disturbances_per_100m2).round() as usize;
    let sources: Vec<MagSource> = (0..n_src)
        .map(|_| MagSource {
            at: Vec2::new(
                uniform(rng, 0.0, ctx.floor_size_m[0]),
                uniform(rng, 0.0, ctx.floor_size_m[1]),
            ),
            b_ut: Vector3::new(
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
                uniform(rng, -1.0, 1.0),
            ) * c.mag_disturbance_ut,
        })
        .collect();
    // The walker's own Weinberg coefficient relative to the PDR's: the PDR
    // will measure every step `length_factor` times its true length.
    let length_factor = (1.0 + normal(rng, 0.0, c.walker_step_length_sd_rel)).clamp(0.6, 1.4);
    let pp_factor = length_factor.powi(4);
    let earth =
        Vector3::new(0.0, c.inclination_rad.cos(), -c.inclination_rad.sin()) * c.earth_field_ut;

    // True orientation and linear acceleration at every sample.
    let mut tremor = [0.0f64; 3];
    let mut orient: Vec<UnitQuaternion<f64>> = Vec::with_capacity(n + 1);
    let mut lin_acc: Vec<Vector3<f64>> = Vec::with_capacity(n + 1);
    let mut t_prev = times[0];
    for (k, &t) in times.iter().enumerate() {
        let h = (t - t_prev).max(0.0);
        t_prev = t;
        let a = (-h / TREMOR_TAU_S).exp();
        for v in tremor.iter_mut() {
            *v = a * *v + c.tremor_rad * (1.0 - a * a).sqrt() * std_normal(rng);
        }
        let mut g = gait_at(traj, t);
        g.pp *= pp_factor;
        let stride = PI * (g.k + g.tau); // half the step frequency: sin is 0 at every heel strike
        let yaw_enu = yaw_body[k] - ctx.map_from_enu_rad;
        let fwd = Vector3::new(yaw_enu.cos(), yaw_enu.sin(), 0.0);
        let left = Vector3::new(-yaw_enu.sin(), yaw_enu.cos(), 0.0);
        let up = Vector3::z();
        let walking = g.pp > 0.0;
        let a_vert = if walking {
            0.5 * g.pp * (TAU * g.tau).sin()
        } else {
            0.0
        };
        let a_surge = if walking {
            c.surge_ratio * 0.5 * g.pp * (2.0 * TAU * g.tau).sin()
        } else {
            0.0
        };
        let a_sway = if walking {
            c.sway_accel_mps2 * stride.sin()
        } else {
            0.0
        };
        let mut acc = up * a_vert + fwd * a_surge + left * a_sway;
        let (pitch, roll) = match ctx.walk.carry {
            Carry::InFront => (
                c.in_front_pitch_rad
                    + if walking {
                        c.pitch_bob_rad * (TAU * g.tau).sin()
                    } else {
                        0.0
                    }
                    + tremor[0],
                if walking {
                    c.roll_sway_rad * stride.sin()
                } else {
                    0.0
                } + tremor[1],
            ),
            Carry::Swinging => {
                // The phone hangs along an arm of length r swinging by theta(t)
                // about the shoulder; its acceleration from central differences
                // of its offset (forward r sin theta, up -r cos theta).
                let r = c.swing_arm_m;
                let th = |t: f64| swing_angle(traj, c.swing_amplitude_rad, t);
                let off = |t: f64| {
                    let a = th(t);
                    (r * a.sin(), -r * a.cos())
                };
                let h = ARM_DIFF_S;
                let (f0, u0) = off(t);
                let (fm, um) = off(t - h);
                let (fp, up_) = off(t + h);
                let a_fwd = (fp - 2.0 * f0 + fm) / (h * h);
                let a_up = (up_ - 2.0 * u0 + um) / (h * h);
                acc += fwd * a_fwd + up * a_up;
                (-FRAC_PI_2 + th(t) + tremor[0], tremor[1])
            }
        };
        let yaw_dev = yaw_enu + yaw_offset + tremor[2];
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_dev - FRAC_PI_2)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), roll);
        orient.push(q);
        lin_acc.push(acc);
    }

    let mut out = Vec::with_capacity(n * 4 + (traj.duration_s * c.baro_rate_hz) as usize + 1);
    let mut yaw_rw = 0.0;
    let mut t_prev = times[0];
    let gravity = Vector3::new(0.0, 0.0, GRAVITY_MPS2);
    for k in 0..n {
        let t = times[k];
        if t > traj.duration_s {
            break;
        }
        let t_ns = to_ns(ctx.t0_ns, t);
        let q = orient[k];
        let qinv = q.inverse();
        let noise3 = |rng: &mut Pcg64, s: f64| {
            Vector3::new(
                normal(rng, 0.0, s),
                normal(rng, 0.0, s),
                normal(rng, 0.0, s),
            )
        };
        let acc = qinv * (lin_acc[k] + gravity) + acc_bias + noise3(rng, c.accel_noise_mps2);
        let h = times[k + 1] - t;
        let omega = if h > 0.0 {
            (qinv * orient[k + 1]).scaled_axis() / h
        } else {
            Vector3::zeros()
        };
        let gyr = omega + gyr_bias + noise3(rng, c.gyro_noise_rad_s);
        let pos = traj.position_at(t);
        let mut b = earth;
        for s in &sources {
            let d2 = (pos - s.at).norm_squared();
            b += s.b_ut * (-d2 / (2.0 * c.mag_disturbance_radius_m.powi(2))).exp();
        }
        let mag = qinv * b + mag_bias + noise3(rng, c.mag_noise_ut);
        yaw_rw += c.yaw_random_walk_rad_sqrt_s * (t - t_prev).max(0.0).sqrt() * std_normal(rng);
        t_prev = t;
        let drift = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), drift_rate * t + yaw_rw);
        let jitter = UnitQuaternion::from_scaled_axis(noise3(rng, c.rotvec_noise_rad));
        let rv = drift * q * jitter;
        let mut rv4 = [rv.i, rv.j, rv.k, rv.w];
        if rv4[3] < 0.0 {
            rv4.iter_mut().for_each(|v| *v = -*v);
        }
        let v3 = |v: Vector3<f64>| [v.x, v.y, v.z];
        out.push(SensorEvent {
            t_ns,
            data: SensorData::Accelerometer(v3(acc)),
        });
        out.push(SensorEvent {
            t_ns,
            data: SensorData::Gyroscope(v3(gyr)),
        });
        out.push(SensorEvent {
            t_ns,
            data: SensorData::Magnetometer(v3(mag)),
        });
        out.push(SensorEvent {
            t_ns,
            data: SensorData::RotationVector(rv4),
        });
    }

    // Barometer.
    let bdt = 1.0 / c.baro_rate_hz;
    let alt = ctx.floor_height_m + ctx.walk.phone_height_m;
    let mut p0 = c.baro_p0_hpa;
    let mut k = 0usize;
    loop {
        let t = k as f64 * bdt + bdt * 0.5;
        if t > traj.duration_s {
            break;
        }
        if k > 0 {
            p0 += c.baro_drift_hpa_sqrt_s * bdt.sqrt() * std_normal(rng);
        }
        let p = p0 * (1.0 - alt / 44_330.77).powf(5.255_877) + normal(rng, 0.0, c.baro_noise_hpa);
        out.push(SensorEvent {
            t_ns: to_ns(ctx.t0_ns, t),
            data: SensorData::Pressure(p),
        });
        k += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testmap::two_rooms;
    use crate::walk::walk;
    use rand::SeedableRng;

    fn run(carry: Carry, seed: u64) -> (Trajectory, Vec<SensorEvent>, ImuConfig) {
        run_with(carry, seed, ImuConfig::default())
    }

    fn run_with(
        carry: Carry,
        seed: u64,
        icfg: ImuConfig,
    ) -> (Trajectory, Vec<SensorEvent>, ImuConfig) {
        let map = two_rooms();
        let mut rng = Pcg64::seed_from_u64(seed);
        let wcfg = WalkConfig {
            min_goal_distance_m: 2.0,
            carry,
            ..WalkConfig::default()
        };
        let tr = walk(&map, &wcfg, &icfg, 60.0, &mut rng).unwrap();
        let ctx = ImuContext {
            imu: &icfg,
            walk: &wcfg,
            map_from_enu_rad: 0.3,
            floor_height_m: 0.0,
            floor_size_m: [10.0, 6.0],
            t0_ns: 0,
        };
        let ev = sensors(&tr, &ctx, &mut rng);
        (tr, ev, icfg)
    }

    #[test]
    fn still_phone_reads_gravity_and_pressure() {
        let (_, ev, _) = run(Carry::InFront, 1);
        // First second: standing still.
        let accs: Vec<[f64; 3]> = ev
            .iter()
            .filter(|e| e.t_ns < 1_000_000_000)
            .filter_map(|e| match e.data {
                SensorData::Accelerometer(a) => Some(a),
                _ => None,
            })
            .collect();
        assert!(accs.len() >= 45);
        let mean: f64 = accs
            .iter()
            .map(|a| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt())
            .sum::<f64>()
            / accs.len() as f64;
        assert!((mean - GRAVITY_MPS2).abs() < 0.15, "{mean}");
        let p = ev.iter().find_map(|e| match e.data {
            SensorData::Pressure(p) => Some(p),
            _ => None,
        });
        let p = p.unwrap();
        assert!(
            (p - 1013.25 * (1.0 - 1.2 / 44_330.77f64).powf(5.255_877)).abs() < 0.2,
            "{p}"
        );
    }

    #[test]
    fn gyro_integrates_to_the_orientation_change() {
        // Without bias, noise and drift, integrating the gyro over the whole log
        // must give the rotation vector's orientation change.
        for carry in [Carry::InFront, Carry::Swinging] {
            let icfg = ImuConfig {
                gyro_bias_rad_s: 0.0,
                gyro_noise_rad_s: 0.0,
                yaw_drift_rate_rad_s: 0.0,
                yaw_random_walk_rad_sqrt_s: 0.0,
                rotvec_noise_rad: 0.0,
                ..ImuConfig::default()
            };
            let (_, ev, _) = run_with(carry, 2, icfg);
            gyro_matches_rotvec(&ev, 0.02);
        }
        // With the default errors they still agree roughly.
        let (_, ev, _) = run(Carry::InFront, 2);
        gyro_matches_rotvec(&ev, 0.8);
    }

    fn gyro_matches_rotvec(ev: &[SensorEvent], tol_rad: f64) {
        let mut q = UnitQuaternion::identity();
        let mut first_rv = None;
        let mut last_rv = None;
        let mut last_t = None;
        let mut last_w = Vector3::zeros();
        for e in ev {
            match e.data {
                SensorData::Gyroscope(w) => {
                    if let Some(t0) = last_t {
                        let h = (e.t_ns - t0) as f64 * 1e-9;
                        q *= UnitQuaternion::from_scaled_axis(last_w * h);
                    }
                    last_t = Some(e.t_ns);
                    last_w = Vector3::new(w[0], w[1], w[2]);
                }
                SensorData::RotationVector(r) => {
                    let rq = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        r[3], r[0], r[1], r[2],
                    ));
                    if first_rv.is_none() {
                        first_rv = Some(rq);
                    }
                    last_rv = Some(rq);
                }
                _ => {}
            }
        }
        let (a, b) = (first_rv.unwrap(), last_rv.unwrap());
        // Orientation change in the device frame from the rotation vector vs the gyro.
        let from_rv = a.inverse() * b;
        let err = (from_rv.inverse() * q).angle();
        assert!(
            err < tol_rad,
            "gyro vs rotation vector disagree by {err} rad"
        );
    }

    #[test]
    fn vertical_peak_to_peak_follows_weinberg() {
        for carry in [Carry::InFront] {
            // A walker whose Weinberg coefficient is the PDR's own.
            let icfg = ImuConfig {
                walker_step_length_sd_rel: 0.0,
                ..ImuConfig::default()
            };
            let (tr, ev, cfg) = run_with(carry, 4, icfg);
            // Vertical acceleration = accel rotated to the world by the rotation vector.
            let mut rv = UnitQuaternion::identity();
            let mut vert: Vec<(f64, f64)> = Vec::new();
            for e in &ev {
                match e.data {
                    SensorData::RotationVector(r) => {
                        rv = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                            r[3], r[0], r[1], r[2],
                        ))
                    }
                    SensorData::Accelerometer(a) => {
                        let w = rv * Vector3::new(a[0], a[1], a[2]);
                        vert.push((e.t_ns as f64 * 1e-9, w.z - GRAVITY_MPS2));
                    }
                    _ => {}
                }
            }
            let mut errs = Vec::new();
            for s in tr.steps_in_log().filter(|s| s.length_m > 0.45) {
                let w: Vec<f64> = vert
                    .iter()
                    .filter(|(t, _)| *t >= s.t_start_s && *t < s.t_end_s)
                    .map(|&(_, v)| v)
                    .collect();
                let pp = w.iter().cloned().fold(f64::MIN, f64::max)
                    - w.iter().cloned().fold(f64::MAX, f64::min);
                let boost = lowpass_boost_hz(cfg.weinberg_lowpass_hz, s.t_end_s - s.t_start_s);
                let len = cfg.weinberg_beta * (pp / boost).powf(0.25);
                errs.push((len - s.length_m) / s.length_m);
            }
            errs.sort_by(f64::total_cmp);
            let med = errs[errs.len() / 2];
            assert!(
                med.abs() < 0.06,
                "median relative Weinberg length error {med}"
            );
        }
    }
}
