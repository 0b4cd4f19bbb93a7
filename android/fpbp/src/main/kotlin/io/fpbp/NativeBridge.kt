package io.fpbp

/**
 * The JNI functions of libfpbp (rust/jni). Low level: apps use [FpbpEngine].
 *
 * Handles are `Long` ids, never reused; a stale or stopped handle throws
 * [IllegalStateException]. Bad input to `start` throws
 * [IllegalArgumentException]; internal errors throw [FpbpNativeException].
 * Recording calls (`onSensor`, `onBleScan`, `onGnss`) never throw for a bad
 * sample: it is counted in [stats]. Every function may be called from any thread.
 */
object NativeBridge {
    /** Task code of the radio task (BLE and WiFi; GML in FP-BP). */
    const val TASK_RADIO: Int = 0

    /** Task code of the fusion (PF + PPC) task. */
    const val TASK_FUSION: Int = 1

    /** Doubles written by [getPose] (layout: the `POSE_*` indices; rust/jni `session::pose_index`). */
    const val POSE_LEN: Int = 10
    const val POSE_X_M: Int = 0
    const val POSE_Y_M: Int = 1
    const val POSE_FLOOR: Int = 2
    const val POSE_HEADING_RAD: Int = 3
    const val POSE_ACCURACY_M: Int = 4
    const val POSE_FLOOR_PROB: Int = 5

    /** `PoseSource::code()`: 0 radio, 1 dead reckoning, 2 fused. */
    const val POSE_SOURCE: Int = 6

    /** WGS-84 through the site's georef; NaN when the site has none. */
    const val POSE_LAT_DEG: Int = 7
    const val POSE_LON_DEG: Int = 8

    /** Heading as a bearing from true north, degrees clockwise in [0, 360). */
    const val POSE_BEARING_DEG: Int = 9

    /** Most results [onWifiScan] takes in one scan (rust/jni `MAX_WIFI_RESULTS`). */
    const val MAX_WIFI_RESULTS: Int = 512

    init {
        System.loadLibrary("fpbp")
        val native = poseLen()
        if (native != POSE_LEN) {
            throw FpbpNativeException(
                "libfpbp writes poses of $native doubles, this library expects $POSE_LEN: " +
                    "the native library and the Kotlin library come from different builds",
            )
        }
    }

    /**
     * Loads the site (site.json text; plan paths relative to [siteDir]),
     * parses [configJson] (empty = defaults) and starts [engine].
     * [init] is `[x_m, y_m, floor, heading_rad]` (heading NaN = unknown) or null.
     * [fingerprintsJson] is engine data told apart by its `format` field: an
     * `fpbp-fingerprints` database (docs/fingerprints.md) for `robust-ekf`, or
     * an `fpbp-radio-map` (docs/formats.md, `fpbp calibrate --radio-map`) for
     * `tcpf`; or null.
     */
    @JvmStatic external fun start(
        siteJson: String,
        siteDir: String,
        configJson: String,
        engine: String,
        init: DoubleArray?,
        fingerprintsJson: String?,
    ): Long

    /**
     * Starts [engine] from a site bundle (`fpbp bundle`, docs/formats.md
     * "Site bundle") in the direct buffer [bundle] (its whole capacity; pass
     * a `slice()`): the site, its plans and the radio map (for `tcpf` and
     * `scan-knn`) are read from it in place. [configJson] and [init] as in
     * [start]. Throws [IllegalArgumentException] for a heap buffer or a bad
     * bundle, naming the field or entry at fault.
     */
    @JvmStatic external fun startBundle(
        bundle: java.nio.ByteBuffer,
        configJson: String,
        engine: String,
        init: DoubleArray?,
    ): Long

    /** The text of site.json in the direct buffer [bundle], after checking the whole bundle. */
    @JvmStatic external fun bundleSiteJson(bundle: java.nio.ByteBuffer): String

    /** Forgets [handle]; throws [IllegalStateException] if it is not live. */
    @JvmStatic external fun stop(handle: Long)

    /** One sample of Android sensor type [sensorType] (`Sensor.TYPE_*`), time [tNs] (elapsedRealtime ns). */
    @JvmStatic external fun onSensor(handle: Long, sensorType: Int, tNs: Long, values: DoubleArray?)

    /** One BLE advertisement; [txPowerDbm] NaN when the frame has none. */
    @JvmStatic external fun onBleScan(handle: Long, tNs: Long, beaconId: String?, rssiDbm: Double, txPowerDbm: Double)

    /** One GNSS fix; optional values NaN when absent. */
    @JvmStatic external fun onGnss(
        handle: Long,
        tNs: Long,
        latDeg: Double,
        lonDeg: Double,
        altM: Double,
        accuracyM: Double,
        speedMps: Double,
        bearingDeg: Double,
    )

    /** Runs the radio task (BLE and WiFi; GML in FP-BP) once at [tNs]. */
    @JvmStatic external fun runRadio(handle: Long, tNs: Long)

    /** Runs the fusion task once at [tNs]. */
    @JvmStatic external fun runFusion(handle: Long, tNs: Long)

    /** The engine's period of [task] ([TASK_RADIO] or [TASK_FUSION]), ns; 0 if it has none. */
    @JvmStatic external fun taskPeriodNs(handle: Long, task: Int): Long

    /**
     * Writes the latest pose into [out] (size >= [POSE_LEN]) and its time (ns)
     * into [outTimeNs]`[0]`; false before the first fix (both untouched).
     * Never waits for a running task (it reads the pose published after the
     * engine's last call).
     */
    @JvmStatic external fun getPose(handle: Long, out: DoubleArray, outTimeNs: LongArray): Boolean

    /** Like [getPose] for the last BLE-only position (x_B). */
    @JvmStatic external fun getBlePosition(handle: Long, out: DoubleArray, outTimeNs: LongArray): Boolean

    /** The engine's input/output counters as JSON (never waits for a running task). */
    @JvmStatic external fun stats(handle: Long): String

    /**
     * Moves the engine to [position] = `[x_m, y_m, floor, heading_rad]`
     * (heading NaN = keep) at [tNs], without a restart. Throws
     * [IllegalArgumentException] for a bad array or a floor the site lacks,
     * [UnsupportedOperationException] when the engine cannot take a position.
     */
    @JvmStatic external fun setPosition(handle: Long, tNs: Long, position: DoubleArray?)

    /**
     * One WiFi scan: parallel arrays of the same length (at most
     * [MAX_WIFI_RESULTS]); [seenTNs] are the results' last-seen times (ns,
     * `ScanResult.timestamp` x 1000). Bad entries and malformed scans are
     * counted in [stats], never thrown.
     */
    @JvmStatic external fun onWifiScan(
        handle: Long,
        tNs: Long,
        bssids: Array<String?>?,
        rssiDbm: DoubleArray?,
        freqMhz: IntArray?,
        seenTNs: LongArray?,
    )

    /** [POSE_LEN] of the loaded native library (checked at load). */
    @JvmStatic external fun poseLen(): Int

    /** Engine names [start] accepts, comma-separated. */
    @JvmStatic external fun engineNames(): String
}
