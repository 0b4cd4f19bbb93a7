//! JNI surface of fpbp: `libfpbp.so`, loaded by the Kotlin object
//! `io.fpbp.NativeBridge` (android/fpbp). Thin: every function converts its
//! arguments, forwards to `fpbp_core` through a [`session::Session`] and
//! converts the result back.
//!
//! Contract (also in android/README.md):
//! - Handles are `Long` ids (> 0, never reused) into a registry
//!   ([`registry::Registry`]); a stale or stopped handle throws
//!   `IllegalStateException`, it never touches freed memory.
//! - Every entry point runs inside [`entry`], which catches panics; errors
//!   become `IllegalArgumentException` (bad input/config/site/engine name),
//!   `IllegalStateException` (stale handle) or `io.fpbp.FpbpNativeException`
//!   (internal error, panic).
//! - Recording calls (`onSensor`, `onBleScan`, `onGnss`) never throw for a
//!   bad sample: it is counted (`stats`). They throw only for a stale handle.
//! - Thread safety: any thread may call any function at any time. Calls on
//!   one handle are serialised by that handle's mutex (one lock, no nesting).
#![deny(clippy::unwrap_used)]
#![allow(non_snake_case)] // JNI symbol names

pub mod error;
pub mod logging;
pub mod registry;
pub mod session;
pub mod site_loader;

use std::path::Path;
use std::sync::LazyLock;

use jni::objects::{JClass, JDoubleArray, JString};
use jni::sys::{jdouble, jint, jlong};
use jni::{Env, EnvUnowned};

use error::{BridgeError, ThrowJava};
use registry::Registry;
use session::{POSE_LEN, Session};

/// `getPose`'s return value when the engine has no fix yet.
pub const NO_POSE: jlong = jlong::MIN;

/// Most values a sensor sample may carry (Android sends at most 5 for ours).
const MAX_SENSOR_VALUES: usize = 8;

static SESSIONS: LazyLock<Registry<Session>> = LazyLock::new(Registry::default);

/// Runs one entry point: logger set-up, panic catching, error -> exception.
fn entry<'local, T: Default>(
    env: &mut EnvUnowned<'local>,
    method: &'static str,
    f: impl FnOnce(&mut Env<'local>) -> Result<T, BridgeError>,
) -> T {
    logging::init();
    env.with_env(f).resolve_with::<ThrowJava, _>(|| method)
}

fn string_arg(env: &Env<'_>, s: &JString<'_>, name: &str) -> Result<String, BridgeError> {
    if s.is_null() {
        return Err(BridgeError::IllegalArgument(format!("{name} is null")));
    }
    Ok(s.try_to_string(env)?)
}

fn optional_string(env: &Env<'_>, s: &JString<'_>) -> Result<Option<String>, BridgeError> {
    if s.is_null() {
        Ok(None)
    } else {
        Ok(Some(s.try_to_string(env)?))
    }
}

fn double_array(env: &Env<'_>, a: &JDoubleArray<'_>) -> Result<Option<Vec<f64>>, BridgeError> {
    if a.is_null() {
        return Ok(None);
    }
    let n = a.len(env)?;
    let mut v = vec![0.0; n];
    a.get_region(env, 0, &mut v)?;
    Ok(Some(v))
}

fn write_pose(
    env: &Env<'_>,
    out: &JDoubleArray<'_>,
    pose: Option<fpbp_core::engine::Pose>,
) -> Result<jlong, BridgeError> {
    if out.is_null() {
        return Err(BridgeError::IllegalArgument("out array is null".into()));
    }
    let n = out.len(env)?;
    if n < POSE_LEN {
        return Err(BridgeError::IllegalArgument(format!(
            "out array has {n} elements, needs {POSE_LEN} (x, y, floor, heading, accuracy)"
        )));
    }
    let Some(pose) = pose else { return Ok(NO_POSE) };
    out.set_region(env, 0, &session::pose_to_array(&pose))?;
    Ok(pose.t_ns)
}

/// `start(siteJson, siteDir, configJson, engine, init: DoubleArray?,
/// fingerprintsJson: String?) -> handle`. `init` is `[x_m, y_m, floor,
/// heading_rad]` (heading NaN = unknown) or null; `fingerprintsJson` an
/// `fpbp-fingerprints` database for `robust-ekf` or null.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_start<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    site_json: JString<'l>,
    site_dir: JString<'l>,
    config_json: JString<'l>,
    engine: JString<'l>,
    init: JDoubleArray<'l>,
    fingerprints_json: JString<'l>,
) -> jlong {
    entry(&mut env, "start", |env| {
        let site_json = string_arg(env, &site_json, "siteJson")?;
        let site_dir = string_arg(env, &site_dir, "siteDir")?;
        let config_json = optional_string(env, &config_json)?.unwrap_or_default();
        let engine = string_arg(env, &engine, "engine")?;
        let init = double_array(env, &init)?
            .map(|v| session::init_from_array(&v))
            .transpose()?;
        let fingerprints = optional_string(env, &fingerprints_json)?;
        let session = Session::start(
            &site_json,
            Path::new(&site_dir),
            &config_json,
            &engine,
            init,
            fingerprints.as_deref(),
        )?;
        let handle = SESSIONS.insert(session)?;
        log::info!("started engine `{engine}` as handle {handle}");
        Ok(handle)
    })
}

/// `stop(handle)`: forgets the handle; the engine is freed when the last
/// in-flight call on it returns. Throws IllegalStateException if not live.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_stop<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
) {
    entry(&mut env, "stop", |_| SESSIONS.remove(handle))
}

/// `onSensor(handle, sensorType, tNs, values)`: Android `Sensor.TYPE_*`.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_onSensor<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    sensor_type: jint,
    t_ns: jlong,
    values: JDoubleArray<'l>,
) {
    entry(&mut env, "onSensor", |env| {
        let mut buf = [0.0f64; MAX_SENSOR_VALUES];
        let n = if values.is_null() {
            None
        } else {
            let n = values.len(env)?.min(MAX_SENSOR_VALUES);
            values.get_region(env, 0, &mut buf[..n])?;
            Some(n)
        };
        SESSIONS.with(handle, |s| {
            s.on_sensor(sensor_type, t_ns, n.map(|n| &buf[..n]));
            Ok(())
        })
    })
}

/// `onBleScan(handle, tNs, beaconId, rssiDbm, txPowerDbm)` (tx power NaN = absent).
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_onBleScan<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    t_ns: jlong,
    beacon_id: JString<'l>,
    rssi_dbm: jdouble,
    tx_power_dbm: jdouble,
) {
    entry(&mut env, "onBleScan", |env| {
        let id = optional_string(env, &beacon_id)?;
        SESSIONS.with(handle, |s| {
            s.on_ble(t_ns, id, rssi_dbm, tx_power_dbm);
            Ok(())
        })
    })
}

/// `onGnss(handle, tNs, latDeg, lonDeg, altM, accuracyM, speedMps, bearingDeg)` (NaN = absent).
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub extern "system" fn Java_io_fpbp_NativeBridge_onGnss<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    t_ns: jlong,
    lat_deg: jdouble,
    lon_deg: jdouble,
    alt_m: jdouble,
    accuracy_m: jdouble,
    speed_mps: jdouble,
    bearing_deg: jdouble,
) {
    entry(&mut env, "onGnss", |_| {
        SESSIONS.with(handle, |s| {
            s.on_gnss(
                t_ns,
                lat_deg,
                lon_deg,
                [alt_m, accuracy_m, speed_mps, bearing_deg],
            );
            Ok(())
        })
    })
}

/// `runGml(handle, tNs)`: one run of the BLE task (`Task::Ble`).
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_runGml<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    t_ns: jlong,
) {
    entry(&mut env, "runGml", |_| {
        SESSIONS.with(handle, |s| {
            s.run_task(fpbp_core::engine::Task::Ble, t_ns);
            Ok(())
        })
    })
}

/// `runFusion(handle, tNs)`: one run of the fusion task (`Task::Fusion`).
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_runFusion<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    t_ns: jlong,
) {
    entry(&mut env, "runFusion", |_| {
        SESSIONS.with(handle, |s| {
            s.run_task(fpbp_core::engine::Task::Fusion, t_ns);
            Ok(())
        })
    })
}

/// `taskPeriodNs(handle, task) -> Long`: the engine's period of task
/// `TASK_GML` (0) or `TASK_FUSION` (1), ns; 0 when it has no such task.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_taskPeriodNs<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    task: jint,
) -> jlong {
    entry(&mut env, "taskPeriodNs", |_| {
        let task = session::task_from_code(task)?;
        SESSIONS.with(handle, |s| Ok(s.task_period_ns(task)))
    })
}

/// `getPose(handle, out) -> tNs`: writes `[x, y, floor, heading, accuracy]`
/// into `out` (length >= 5) and returns the pose's time, or `NO_POSE`
/// (Long.MIN_VALUE) before the first fix (then `out` is untouched).
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_getPose<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    out: JDoubleArray<'l>,
) -> jlong {
    entry(&mut env, "getPose", |env| {
        let pose = SESSIONS.with(handle, |s| Ok(s.pose()))?;
        write_pose(env, &out, pose)
    })
}

/// `getBlePosition(handle, out) -> tNs`: like `getPose` for the last
/// BLE-only position x_B (engines without one always return `NO_POSE`).
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_getBlePosition<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
    out: JDoubleArray<'l>,
) -> jlong {
    entry(&mut env, "getBlePosition", |env| {
        let pose = SESSIONS.with(handle, |s| Ok(s.ble_position()))?;
        write_pose(env, &out, pose)
    })
}

/// `stats(handle) -> String`: the engine's counters as JSON.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_stats<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
    handle: jlong,
) -> JString<'l> {
    entry(&mut env, "stats", |env| {
        let json = SESSIONS.with(handle, |s| Ok(s.stats_json()))?;
        Ok(JString::from_str(env, json)?)
    })
}

/// `engineNames() -> String`: the names `start` accepts, comma-separated.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_engineNames<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
) -> JString<'l> {
    entry(&mut env, "engineNames", |env| {
        Ok(JString::from_str(
            env,
            fpbp_core::engine::ENGINE_NAMES.join(","),
        )?)
    })
}

/// `selfTestPanic()`: panics inside the native library on purpose, so tests
/// can check that a panic becomes `io.fpbp.FpbpNativeException` and that the
/// library keeps working afterwards.
#[unsafe(no_mangle)]
pub extern "system" fn Java_io_fpbp_NativeBridge_selfTestPanic<'l>(
    mut env: EnvUnowned<'l>,
    _class: JClass<'l>,
) {
    entry(&mut env, "selfTestPanic", |_| -> Result<(), BridgeError> {
        panic!("self-test panic")
    })
}
