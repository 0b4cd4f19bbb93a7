//! JNI surface of fpbp: `libfpbp.so`, loaded by the Kotlin object
//! `io.fpbp.NativeBridge` (android/fpbp). Thin: every function converts its
//! arguments, forwards to `fpbp_core` through a [`session::Session`] and
//! converts the result back.
//!
//! Contract (also in docs/android.md):
//! - Handles are `Long` ids (> 0, never reused) into a registry
//!   ([`registry::Registry`]); a stale or stopped handle throws
//!   `IllegalStateException`, it never touches freed memory.
//! - Every entry point is written with the one macro `jni_fns!`, which
//!   gives it its JNI symbol and parameters and runs its body inside
//!   [`entry`]: panics are caught (the logger set-up included) and errors
//!   become the exceptions of the one table in [`error`]:
//!   `IllegalArgumentException` (bad input/config/site/engine name),
//!   `IllegalStateException` (stale handle), `UnsupportedOperationException`
//!   (the engine refuses, e.g. `setPosition`) or
//!   `io.fpbp.FpbpNativeException` (internal error, panic). Messages clip
//!   any echoed input to 200 chars.
//! - Recording calls (`onSensor`, `onBleScan`, `onGnss`, `onWifiScan`) never
//!   throw for a bad sample: it is counted (`stats`). They throw only for a
//!   stale handle.
//! - Thread safety: any thread may call any function at any time. Calls
//!   that feed or run the engine are serialised by that handle's engine
//!   mutex; `getPose`, `getBlePosition`, `stats` and `taskPeriodNs` read the
//!   snapshot published after each such call ([`live::Live`]) and never wait
//!   for a running task.
#![deny(clippy::unwrap_used)]
#![allow(non_snake_case)] // JNI symbol names

pub mod error;
pub mod live;
pub mod logging;
pub mod registry;
#[cfg(any(test, feature = "self-test"))]
pub mod selftest;
pub mod session;
pub mod site_loader;

use std::path::Path;
use std::sync::LazyLock;

use jni::objects::{
    JByteBuffer, JClass, JDoubleArray, JIntArray, JLongArray, JObjectArray, JString,
};
use jni::sys::{jboolean, jdouble, jint, jlong};
use jni::{Env, EnvUnowned};

use error::{BridgeError, ThrowJava};
use fpbp_core::engine::Task;
use live::Live;
use registry::Registry;
use session::{MAX_BSSID_BYTES, MAX_WIFI_RESULTS, POSE_LEN, Session, WifiEntries};

/// Most values a sensor sample may carry (Android sends at most 5 for ours).
const MAX_SENSOR_VALUES: usize = 8;

static SESSIONS: LazyLock<Registry<Live>> = LazyLock::new(Registry::default);

/// Runs one entry point: logger set-up and the call inside the panic guard,
/// error -> exception.
fn entry<'local, T: Default>(
    env: &mut EnvUnowned<'local>,
    method: &'static str,
    f: impl FnOnce(&mut Env<'local>) -> Result<T, BridgeError>,
) -> T {
    env.with_env(|env| {
        logging::init();
        f(env)
    })
    .resolve_with::<ThrowJava, _>(|| method)
}

/// Runs `f` on the session of `handle` under its engine lock, then publishes.
fn with_session<R>(
    handle: jlong,
    f: impl FnOnce(&mut Session) -> Result<R, BridgeError>,
) -> Result<R, BridgeError> {
    SESSIONS.get(handle)?.call(handle, f)
}

/// The published snapshot of `handle` (never waits for the engine).
fn snapshot(handle: jlong) -> Result<session::Snapshot, BridgeError> {
    SESSIONS.get(handle)?.snapshot(handle)
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

fn primitive_len<T: jni::objects::TypeArray>(
    env: &Env<'_>,
    a: &jni::objects::JPrimitiveArray<'_, T>,
) -> Result<Option<usize>, BridgeError> {
    if a.is_null() {
        return Ok(None);
    }
    Ok(Some(a.len(env)?))
}

/// Writes `pose` into `out` (length >= POSE_LEN) and its time into
/// `out_time[0]`; returns whether there was a pose (else both are untouched).
fn write_pose(
    env: &Env<'_>,
    out: &JDoubleArray<'_>,
    out_time: &JLongArray<'_>,
    pose: Option<fpbp_core::engine::Pose>,
    frame: &session::MapFrame,
) -> Result<jboolean, BridgeError> {
    if out.is_null() || out_time.is_null() {
        return Err(BridgeError::IllegalArgument(
            "out or outTimeNs array is null".into(),
        ));
    }
    let n = out.len(env)?;
    if n < POSE_LEN {
        return Err(BridgeError::IllegalArgument(format!(
            "out array has {n} elements, needs {POSE_LEN} (NativeBridge.POSE_LEN)"
        )));
    }
    if out_time.len(env)? < 1 {
        return Err(BridgeError::IllegalArgument(
            "outTimeNs array is empty, needs 1 element".into(),
        ));
    }
    let Some(pose) = pose else { return Ok(false) };
    out.set_region(env, 0, &session::pose_to_array(&pose, frame))?;
    out_time.set_region(env, 0, &[pose.t_ns])?;
    Ok(true)
}

/// The bytes of a direct `java.nio.ByteBuffer` (capacity, from address 0;
/// Kotlin passes `slice()` so position and limit are the slice's).
///
/// The slice lives for the call: the buffer is a local reference the
/// caller keeps alive, and a direct buffer's memory does not move. (A
/// memory-mapped file truncated by another process during the call would
/// fault: the library maps read-only files it owns.)
fn direct_bytes<'b>(env: &Env<'_>, buf: &'b JByteBuffer<'_>) -> Result<&'b [u8], BridgeError> {
    if buf.is_null() {
        return Err(BridgeError::IllegalArgument("bundle is null".into()));
    }
    let not_direct = |_| {
        BridgeError::IllegalArgument(
            "bundle must be a direct ByteBuffer (FileChannel.map or ByteBuffer.allocateDirect)"
                .into(),
        )
    };
    let len = env.get_direct_buffer_capacity(buf).map_err(not_direct)?;
    if len == 0 {
        return Ok(&[]);
    }
    let ptr = env.get_direct_buffer_address(buf).map_err(not_direct)?;
    // SAFETY: `ptr` is the non-null start of the direct buffer's `len`
    // bytes, valid while `buf` (a live local reference) is; only read.
    #[allow(unsafe_code)]
    Ok(unsafe { std::slice::from_raw_parts(ptr.cast_const(), len) })
}

/// Whether `name` goes into a JNI symbol as is: ASCII letters and digits
/// only (`_` and non-ASCII would need JNI's `_1` / `_0xxxx` escapes).
const fn is_plain_jni_name(name: &str) -> bool {
    let b = name.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if !b[i].is_ascii_alphanumeric() {
            return false;
        }
        i += 1;
    }
    true
}

/// Defines the JNI entry points of the Kotlin object `io.fpbp.$class`, each
/// as `fn name(env, arg: Type, ...) -> Ret { body }`. Per entry point it
/// writes the common opening once for all: the exported symbol
/// `Java_io_fpbp_<class>_<name>` (checked at compile time to need no JNI
/// escapes), the `(JNIEnv*, jclass)` parameters, and the call of the
/// body inside [`entry`] with `"name"` as the method in messages (logger
/// set-up and body under the panic guard, `BridgeError` -> the exception of
/// the error table, error.rs). `env` (or `_`) binds the `&mut Env` of the
/// call. The body returns `Result<Ret, BridgeError>`; on an error or panic
/// the Java side gets the exception and the native method `Ret::default()`.
///
/// Handles are looked up inside the body ([`with_session`], [`snapshot`],
/// `SESSIONS`), at the point each entry point needs it: some check their
/// arguments first, so which exception wins stays as documented.
macro_rules! jni_fns {
    (
        class $class:ident;
        $(
            $(#[$attr:meta])*
            fn $name:ident($env:pat $(, $arg:ident: $ty:ty)* $(,)?) $(-> $ret:ty)? $body:block
        )*
    ) => {
        const _: () = assert!(is_plain_jni_name(stringify!($class)));
        $(
        const _: () = assert!(is_plain_jni_name(stringify!($name)));
        $(#[$attr])*
        #[unsafe(export_name = concat!("Java_io_fpbp_", stringify!($class), "_", stringify!($name)))]
        #[allow(clippy::too_many_arguments)] // the Java signature decides
        pub extern "system" fn $name<'l>(
            mut env: EnvUnowned<'l>,
            _class: JClass<'l>,
            $($arg: $ty),*
        ) $(-> $ret)? {
            entry(&mut env, stringify!($name), |$env| $body)
        }
        )*
    };
}

jni_fns! {
    class NativeBridge;

    /// `start(siteJson, siteDir, configJson, engine, init: DoubleArray?,
    /// fingerprintsJson: String?) -> handle`. `init` is `[x_m, y_m, floor,
    /// heading_rad]` (heading NaN = unknown) or null; `fingerprintsJson` engine
    /// data or null, told apart by its `format`: an `fpbp-fingerprints` database
    /// for `robust-ekf` or an `fpbp-radio-map` for `tcpf`.
    fn start(
        env,
        site_json: JString<'l>,
        site_dir: JString<'l>,
        config_json: JString<'l>,
        engine: JString<'l>,
        init: JDoubleArray<'l>,
        fingerprints_json: JString<'l>,
    ) -> jlong {
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
        let handle = SESSIONS.insert(Live::new(session))?;
        log::info!("started engine `{engine}` as handle {handle}");
        Ok(handle)
    }

    /// `startBundle(bundle: ByteBuffer, configJson, engine, init) -> handle`:
    /// starts `engine` from a site bundle (`fpbp bundle`, docs/formats.md
    /// "Site bundle") in a direct buffer: site, plans and radio map are read
    /// from it in place, no String of the map crosses JNI.
    fn startBundle(
        env,
        bundle: JByteBuffer<'l>,
        config_json: JString<'l>,
        engine: JString<'l>,
        init: JDoubleArray<'l>,
    ) -> jlong {
        let config_json = optional_string(env, &config_json)?.unwrap_or_default();
        let engine = string_arg(env, &engine, "engine")?;
        let init = double_array(env, &init)?
            .map(|v| session::init_from_array(&v))
            .transpose()?;
        let bytes = direct_bytes(env, &bundle)?;
        let session = Session::start_bundle(bytes, &config_json, &engine, init)?;
        let handle = SESSIONS.insert(Live::new(session))?;
        log::info!(
            "started engine `{engine}` from a {}-byte bundle as handle {handle}",
            bytes.len()
        );
        Ok(handle)
    }

    /// `bundleSiteJson(bundle: ByteBuffer) -> String`: the text of a bundle's
    /// site.json, after checking the whole bundle (manifest, sizes, hashes).
    fn bundleSiteJson(env, bundle: JByteBuffer<'l>) -> JString<'l> {
        let json = Session::bundle_site_json(direct_bytes(env, &bundle)?)?;
        Ok(JString::from_str(env, json)?)
    }

    /// `stop(handle)`: forgets the handle; the engine is freed when the last
    /// in-flight call on it returns. Throws IllegalStateException if not live.
    fn stop(_, handle: jlong) {
        SESSIONS.remove(handle)
    }

    /// `onSensor(handle, sensorType, tNs, values)`: Android `Sensor.TYPE_*`.
    fn onSensor(env, handle: jlong, sensor_type: jint, t_ns: jlong, values: JDoubleArray<'l>) {
        let mut buf = [0.0f64; MAX_SENSOR_VALUES];
        let n = if values.is_null() {
            None
        } else {
            let n = values.len(env)?.min(MAX_SENSOR_VALUES);
            values.get_region(env, 0, &mut buf[..n])?;
            Some(n)
        };
        with_session(handle, |s| {
            s.on_sensor(sensor_type, t_ns, n.map(|n| &buf[..n]));
            Ok(())
        })
    }

    /// `onBleScan(handle, tNs, beaconId, rssiDbm, txPowerDbm)` (tx power NaN = absent).
    fn onBleScan(
        env,
        handle: jlong,
        t_ns: jlong,
        beacon_id: JString<'l>,
        rssi_dbm: jdouble,
        tx_power_dbm: jdouble,
    ) {
        let id = optional_string(env, &beacon_id)?;
        with_session(handle, |s| {
            s.on_ble(t_ns, id, rssi_dbm, tx_power_dbm);
            Ok(())
        })
    }

    /// `onGnss(handle, tNs, latDeg, lonDeg, altM, accuracyM, speedMps, bearingDeg)` (NaN = absent).
    fn onGnss(
        _,
        handle: jlong,
        t_ns: jlong,
        lat_deg: jdouble,
        lon_deg: jdouble,
        alt_m: jdouble,
        accuracy_m: jdouble,
        speed_mps: jdouble,
        bearing_deg: jdouble,
    ) {
        with_session(handle, |s| {
            s.on_gnss(t_ns, lat_deg, lon_deg, [alt_m, accuracy_m, speed_mps, bearing_deg]);
            Ok(())
        })
    }

    /// `runRadio(handle, tNs)`: one run of the radio task (`Task::Radio`: BLE and WiFi).
    fn runRadio(_, handle: jlong, t_ns: jlong) {
        with_session(handle, |s| {
            s.run_task(Task::Radio, t_ns);
            Ok(())
        })
    }

    /// `runFusion(handle, tNs)`: one run of the fusion task (`Task::Fusion`).
    fn runFusion(_, handle: jlong, t_ns: jlong) {
        with_session(handle, |s| {
            s.run_task(Task::Fusion, t_ns);
            Ok(())
        })
    }

    /// `taskPeriodNs(handle, task) -> Long`: the engine's period of task
    /// `TASK_RADIO` (0) or `TASK_FUSION` (1), ns; 0 when it has no such task.
    fn taskPeriodNs(_, handle: jlong, task: jint) -> jlong {
        let task = session::task_from_code(task)?;
        let periods = snapshot(handle)?.periods_ns;
        Ok(match task {
            Task::Radio => periods[0],
            Task::Fusion => periods[1],
        })
    }

    /// `getPose(handle, out, outTimeNs) -> Boolean`: writes the latest pose into
    /// `out` (length >= `POSE_LEN`, layout `session::pose_index`) and its time
    /// into `outTimeNs[0]`; false before the first fix (both untouched). Reads
    /// the published snapshot: never waits for a running task.
    fn getPose(env, handle: jlong, out: JDoubleArray<'l>, out_time: JLongArray<'l>) -> jboolean {
        let snap = snapshot(handle)?;
        write_pose(env, &out, &out_time, snap.pose, &snap.frame)
    }

    /// `getBlePosition(handle, out, outTimeNs) -> Boolean`: like `getPose` for
    /// the last BLE-only position x_B (engines without one always return false).
    fn getBlePosition(
        env,
        handle: jlong,
        out: JDoubleArray<'l>,
        out_time: JLongArray<'l>,
    ) -> jboolean {
        let snap = snapshot(handle)?;
        write_pose(env, &out, &out_time, snap.ble_position, &snap.frame)
    }

    /// `stats(handle) -> String`: the engine's and the bridge's counters as JSON
    /// (from the published snapshot: never waits for a running task).
    fn stats(env, handle: jlong) -> JString<'l> {
        let json = snapshot(handle)?.stats_json();
        Ok(JString::from_str(env, json)?)
    }

    /// `setPosition(handle, tNs, position)`: moves the engine to `position` =
    /// `[x_m, y_m, floor, heading_rad]` (heading NaN = keep) now, without a
    /// restart. IllegalArgumentException for a bad array or a point off the
    /// site's floors, UnsupportedOperationException when the engine has no way
    /// to take a position.
    fn setPosition(env, handle: jlong, t_ns: jlong, position: JDoubleArray<'l>) {
        let Some(v) = primitive_len(env, &position)? else {
            return Err(BridgeError::IllegalArgument("position is null".into()));
        };
        if v != 4 {
            return Err(BridgeError::IllegalArgument(format!(
                "position: expected [x_m, y_m, floor, heading_rad], got {v} values"
            )));
        }
        let mut buf = [0.0; 4];
        position.get_region(env, 0, &mut buf)?;
        let at = session::init_from_array(&buf)?;
        with_session(handle, |s| s.set_position(t_ns, at))
    }

    /// `onWifiScan(handle, tNs, bssids, rssiDbm, freqMhz, seenTNs)`: one WiFi
    /// scan (`WifiManager.getScanResults()` after `SCAN_RESULTS_AVAILABLE_ACTION`).
    /// The four arrays must have the same length, at most `MAX_WIFI_RESULTS`;
    /// otherwise the scan is counted as rejected. Bad entries (BSSID not six hex
    /// pairs, non-finite RSSI, frequency <= 0, last seen after `tNs`) are counted
    /// and dropped. Never throws for bad data, only for a stale handle.
    fn onWifiScan(
        env,
        handle: jlong,
        t_ns: jlong,
        bssids: JObjectArray<'l, JString<'l>>,
        rssi_dbm: JDoubleArray<'l>,
        freq_mhz: JIntArray<'l>,
        seen_t_ns: JLongArray<'l>,
    ) {
        let live = SESSIONS.get(handle)?;
        let n = if bssids.is_null() {
            None
        } else {
            Some(bssids.len(env)?)
        };
        let lens = [
            n,
            primitive_len(env, &rssi_dbm)?,
            primitive_len(env, &freq_mhz)?,
            primitive_len(env, &seen_t_ns)?,
        ];
        let why = match lens {
            [Some(n), ..] if lens.iter().any(|l| *l != Some(n)) => {
                Some("WiFi arrays differ in length")
            }
            [Some(n), ..] if n > MAX_WIFI_RESULTS => {
                Some("WiFi scan has more than MAX_WIFI_RESULTS results")
            }
            [Some(_), ..] => None,
            _ => Some("WiFi scan with a null array"),
        };
        let Some(n) = lens[0].filter(|_| why.is_none()) else {
            let why = why.unwrap_or("WiFi scan with a null array");
            return live.call(handle, |s| {
                s.reject_wifi_scan(why);
                Ok(())
            });
        };
        let mut rssi = vec![0.0; n];
        let mut freq = vec![0; n];
        let mut seen = vec![0; n];
        rssi_dbm.get_region(env, 0, &mut rssi)?;
        freq_mhz.get_region(env, 0, &mut freq)?;
        seen_t_ns.get_region(env, 0, &mut seen)?;
        let mut ids = Vec::with_capacity(n);
        for i in 0..n {
            let s = bssids.get_element(env, i)?;
            let id = if s.is_null() {
                None
            } else {
                let chars = s.mutf8_chars(env)?;
                let bytes = chars.to_bytes();
                (bytes.len() <= MAX_BSSID_BYTES)
                    .then(|| String::from_utf8_lossy(bytes).into_owned())
            };
            env.delete_local_ref(s);
            ids.push(id);
        }
        let entries = WifiEntries {
            bssids: &ids,
            rssi_dbm: &rssi,
            freq_mhz: &freq,
            seen_t_ns: &seen,
        };
        live.call(handle, |s| {
            s.on_wifi(t_ns, &entries);
            Ok(())
        })
    }

    /// `poseLen() -> Int`: `POSE_LEN` of this library (the Kotlin side checks it
    /// against its own at load, so a stale libfpbp.so fails loudly).
    fn poseLen(_) -> jint {
        Ok(POSE_LEN as jint)
    }

    /// `engineNames() -> String`: the names `start` accepts, comma-separated.
    fn engineNames(env) -> JString<'l> {
        Ok(JString::from_str(env, fpbp_core::engines::ENGINE_NAMES.join(","))?)
    }
}

// Test hooks, bound to the Kotlin test object `io.fpbp.NativeSelfTest`
// (host-tests/jvm). Only with the `self-test` feature: the Android library
// (android/fpbp's cargoNdk task) is built without it and exports none of them.
#[cfg(feature = "self-test")]
jni_fns! {
    class NativeSelfTest;

    /// `selfTestPanic()`: panics inside the native library on purpose, so tests
    /// can check that a panic becomes `io.fpbp.FpbpNativeException` and that the
    /// library keeps working afterwards.
    fn selfTestPanic(_) {
        panic!("self-test panic")
    }

    /// `selfTestStartBlocking() -> handle`: a test double (not an engine name)
    /// whose every task run waits at the process's self-test gate
    /// (`selfTestGate`), so host tests can show that reads do not wait for a
    /// running task. Starts with a pose at t = 1.
    fn selfTestStartBlocking(_) -> jlong {
        let engine = selftest::BlockingEngine::new(std::sync::Arc::clone(&selftest::GATE));
        SESSIONS.insert(Live::new(Session::from_engine(Box::new(engine))))
    }

    /// `selfTestGate(open)`: opens or closes the self-test gate.
    fn selfTestGate(_, open: jboolean) {
        selftest::GATE.set_open(open);
        Ok(())
    }

    /// `selfTestBlockedTasks() -> Int`: task runs waiting at the self-test gate.
    fn selfTestBlockedTasks(_) -> jint {
        Ok(jint::try_from(selftest::GATE.blocked()).unwrap_or(jint::MAX))
    }
}
