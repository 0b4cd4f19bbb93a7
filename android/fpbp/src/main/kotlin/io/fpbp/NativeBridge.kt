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
    /** Task code of the BLE (GML) task. */
    const val TASK_GML: Int = 0

    /** Task code of the fusion (PF + PPC) task. */
    const val TASK_FUSION: Int = 1

    /** Returned by [getPose] / [getBlePosition] before the first fix. */
    const val NO_POSE: Long = Long.MIN_VALUE

    /** Doubles written by [getPose]: x_m, y_m, floor, heading_rad, accuracy_m. */
    const val POSE_LEN: Int = 5

    init {
        System.loadLibrary("fpbp")
    }

    /**
     * Loads the site (site.json text; plan paths relative to [siteDir]),
     * parses [configJson] (empty = defaults) and starts [engine].
     * [init] is `[x_m, y_m, floor, heading_rad]` (heading NaN = unknown) or null.
     * [fingerprintsJson] is an `fpbp-fingerprints` database (docs/fingerprints.md)
     * for `robust-ekf`, or null.
     */
    @JvmStatic external fun start(
        siteJson: String,
        siteDir: String,
        configJson: String,
        engine: String,
        init: DoubleArray?,
        fingerprintsJson: String?,
    ): Long

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

    /** Runs the BLE (GML) task once at [tNs]. */
    @JvmStatic external fun runGml(handle: Long, tNs: Long)

    /** Runs the fusion task once at [tNs]. */
    @JvmStatic external fun runFusion(handle: Long, tNs: Long)

    /** The engine's period of [task] ([TASK_GML] or [TASK_FUSION]), ns; 0 if it has none. */
    @JvmStatic external fun taskPeriodNs(handle: Long, task: Int): Long

    /** Writes the latest pose into [out] (size >= [POSE_LEN]) and returns its time, or [NO_POSE]. */
    @JvmStatic external fun getPose(handle: Long, out: DoubleArray): Long

    /** Like [getPose] for the last BLE-only position (x_B). */
    @JvmStatic external fun getBlePosition(handle: Long, out: DoubleArray): Long

    /** The engine's input/output counters as JSON. */
    @JvmStatic external fun stats(handle: Long): String

    /** Engine names [start] accepts, comma-separated. */
    @JvmStatic external fun engineNames(): String

    /** Panics inside the native library on purpose (tests: the panic must surface as [FpbpNativeException]). */
    @JvmStatic external fun selfTestPanic()
}
