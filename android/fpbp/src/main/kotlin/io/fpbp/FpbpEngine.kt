package io.fpbp

import java.util.concurrent.atomic.AtomicBoolean

/** Defaults of the library, each in one place. */
object FpbpDefaults {
    /**
     * The engine [FpbpEngine.start] and the Android [io.fpbp.android.FpbpPositioning]
     * run when the app names none (the sample app uses it too).
     */
    const val ENGINE: String = "tcpf"
}

/**
 * A running positioning engine (one native handle).
 *
 * Feed it with [onSensor], [onBleScan], [onWifiScan] (and [onGnss]) from any
 * thread, run its two tasks with [TaskScheduler] (real time) or
 * [LogClockDriver] (replay), read [pose] from any thread: it never waits for
 * a running task. [close] is idempotent; any other call after it throws
 * [IllegalStateException].
 */
class FpbpEngine private constructor(
    /** The native handle (for [NativeBridge] calls). */
    val handle: Long,
    /** The engine's name. */
    val engineName: String,
) : AutoCloseable {
    private val closed = AtomicBoolean(false)

    companion object {
        /**
         * Starts engine [engine] on the site described by [siteJson], whose plan
         * paths are relative to [siteDir]. [configJson] is an engine config
         * (empty = defaults). [fingerprintsJson] is survey data told apart by
         * its `format`: a walked-survey fingerprint database for `robust-ekf`
         * (`fpbp fingerprint build`; null = the engine builds one from the
         * path-loss model), or a radio map for `tcpf` (`fpbp calibrate
         * --radio-map`; its reference scans anchor the start and the floor;
         * null = the site's path-loss models). Throws [IllegalArgumentException]
         * naming the bad field, file or name.
         */
        @JvmStatic
        @JvmOverloads
        fun start(
            siteJson: String,
            siteDir: String,
            engine: String = FpbpDefaults.ENGINE,
            configJson: String = "",
            init: InitialPosition? = null,
            fingerprintsJson: String? = null,
        ): FpbpEngine {
            val h = NativeBridge.start(siteJson, siteDir, configJson, engine, init?.toNative(), fingerprintsJson)
            return FpbpEngine(h, engine)
        }

        /**
         * Starts engine [engine] from a site bundle (`fpbp bundle`): site,
         * plans and radio map in one file read in place by the native
         * library ([SiteBundle.fromFile] maps it). [configJson] and [init] as
         * in [start]. Throws [IllegalArgumentException] naming the bundle's
         * field or entry at fault (a damaged file fails its SHA-256 check).
         */
        @JvmStatic
        @JvmOverloads
        fun startBundle(
            bundle: SiteBundle,
            engine: String = FpbpDefaults.ENGINE,
            configJson: String = "",
            init: InitialPosition? = null,
        ): FpbpEngine {
            val h = NativeBridge.startBundle(bundle.buffer, configJson, engine, init?.toNative())
            return FpbpEngine(h, engine)
        }

        /** Names [start] accepts. */
        @JvmStatic
        fun engineNames(): List<String> = NativeBridge.engineNames().split(',').filter { it.isNotEmpty() }
    }

    /** Whether [close] was called. */
    val isClosed: Boolean get() = closed.get()

    /** One sensor sample (Android `Sensor.TYPE_*`, `SensorEvent.values`). */
    fun onSensor(sensorType: Int, tNs: Long, values: DoubleArray) =
        NativeBridge.onSensor(handle, sensorType, tNs, values)

    /** One sensor sample from `SensorEvent.values` (floats widen exactly). */
    fun onSensor(sensorType: Int, tNs: Long, values: FloatArray) =
        NativeBridge.onSensor(handle, sensorType, tNs, DoubleArray(values.size) { values[it].toDouble() })

    /** One BLE advertisement; [txPowerDbm] null when the frame has none. */
    fun onBleScan(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double? = null) =
        NativeBridge.onBleScan(handle, tNs, beaconId, rssiDbm, txPowerDbm ?: Double.NaN)

    /** One GNSS fix; optional values null when absent. */
    fun onGnss(
        tNs: Long,
        latDeg: Double,
        lonDeg: Double,
        altM: Double? = null,
        accuracyM: Double? = null,
        speedMps: Double? = null,
        bearingDeg: Double? = null,
    ) = NativeBridge.onGnss(
        handle, tNs, latDeg, lonDeg,
        altM ?: Double.NaN, accuracyM ?: Double.NaN, speedMps ?: Double.NaN, bearingDeg ?: Double.NaN,
    )

    /** Runs the BLE (GML) task once at [tNs] (what [RadioTask] calls). */
    fun runRadio(tNs: Long) = NativeBridge.runRadio(handle, tNs)

    /** Runs the fusion task once at [tNs] (what [FusionTask] calls). */
    fun runFusion(tNs: Long) = NativeBridge.runFusion(handle, tNs)

    /** Period of the BLE (GML) task, ns; 0 when the engine has none. */
    val radioPeriodNs: Long get() = NativeBridge.taskPeriodNs(handle, NativeBridge.TASK_RADIO)

    /** Period of the fusion task, ns; 0 when the engine has none. */
    val fusionPeriodNs: Long get() = NativeBridge.taskPeriodNs(handle, NativeBridge.TASK_FUSION)

    /** One WiFi scan; see [NativeBridge.onWifiScan]. Bad entries are counted, not thrown. */
    fun onWifiScan(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) =
        NativeBridge.onWifiScan(handle, tNs, bssids, rssiDbm, freqMhz, seenTNs)

    /**
     * Moves the engine to [at] at [tNs] without a restart (a tap, a QR code).
     * Throws [IllegalArgumentException] for a point off the site's floors and
     * [UnsupportedOperationException] when the engine cannot take a position.
     */
    fun setPosition(tNs: Long, at: InitialPosition) = NativeBridge.setPosition(handle, tNs, at.toNative())

    /** The latest pose, null before the first fix. Never waits for a running task. */
    fun pose(): Pose? {
        val out = DoubleArray(NativeBridge.POSE_LEN)
        val t = LongArray(1)
        return if (NativeBridge.getPose(handle, out, t)) Pose.fromNative(t[0], out) else null
    }

    /** The last BLE-only position (x_B), null when the engine has none. */
    fun blePosition(): Pose? {
        val out = DoubleArray(NativeBridge.POSE_LEN)
        val t = LongArray(1)
        return if (NativeBridge.getBlePosition(handle, out, t)) Pose.fromNative(t[0], out) else null
    }

    /** Input/output counters as JSON (rejected samples are counted here). */
    fun statsJson(): String = NativeBridge.stats(handle)

    /** The same counters and the engine's online estimates (phone RSSI offset, step scale), typed. */
    fun stats(): EngineStats = EngineStats.parse(statsJson())

    /** Stops the engine. Safe to call more than once and from several threads. */
    override fun close() {
        if (closed.compareAndSet(false, true)) {
            NativeBridge.stop(handle)
        }
    }
}
