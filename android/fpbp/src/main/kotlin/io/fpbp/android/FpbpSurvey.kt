package io.fpbp.android

import android.content.Context
import android.os.Handler
import android.os.HandlerThread
import android.os.Looper
import android.os.SystemClock
import io.fpbp.BeaconFilter
import io.fpbp.Clock
import io.fpbp.Problem
import io.fpbp.Radio
import io.fpbp.Status
import io.fpbp.StatusTracker
import io.fpbp.SurveyCounts
import io.fpbp.SurveyLogWriter
import io.fpbp.SurveyMark
import java.io.File
import java.util.Collections
import java.util.concurrent.ArrayBlockingQueue
import java.util.concurrent.FutureTask
import java.util.concurrent.RejectedExecutionException
import java.util.concurrent.ThreadPoolExecutor
import java.util.concurrent.TimeUnit

/**
 * Survey mode: records what a site's radio map is learned from, without an
 * engine. The library's own sources (BLE scan, WiFi scans, the motion
 * sensors and the barometer) feed a [SurveyLogWriter] instead of an
 * engine, and the walker's waypoint marks ([mark]: a tap on the plan where
 * the walker stands) become TRUTH rows. The file is a native log v2 that
 * `fpbp calibrate --site S --logs FILE... --wifi --radio-map RM` takes as it
 * is (docs/survey.md: how to walk a survey).
 *
 * ```
 * val survey = FpbpSurvey(context, FpbpSurvey.Options(beaconIds = FpbpPositioning.beaconIds(siteJson)))
 * survey.start(File(dir, "survey-1.log"), mapOf("site" to "mall"))   // after the radio permissions
 * planView.onTap = { x, y -> survey.mark(x, y, floor) }
 * ...
 * val file = survey.stop()    // flushed and closed; share it
 * ```
 *
 * The events go through one writer thread with a bounded queue (full: the
 * event is dropped and counted), so neither the sensor thread nor the
 * scan callbacks wait for storage, and the file is written as it comes
 * (nothing but the counts and the marks stays in memory). The sources run
 * in foreground mode (the survey screen is on). [start], [mark], [stop] and
 * [close] may be called from any thread.
 *
 * @param clock the clock of `SensorEvent.timestamp` and BLE scan results
 *   (elapsedRealtime); marks and WiFi scans are stamped with it.
 */
class FpbpSurvey @JvmOverloads constructor(
    context: Context,
    private val options: Options = Options(),
    val clock: Clock = Clock { SystemClock.elapsedRealtimeNanos() },
) : AutoCloseable {
    /**
     * @property radios radios to record (their permissions are checked at [start]).
     * @property beaconIds BLE hardware filters: the site's beacon ids (`FpbpPositioning.beaconIds`);
     *   empty records every advertisement (a site whose beacons are not listed yet).
     * @property sensors record the sensors the engine uses ([SensorSource.TYPES]) at 50 Hz.
     * @property wifiScanPeriodMs how often a WiFi scan is asked for, ms; default 4000 (Android's
     *   throttle allows 4 per 2 min unless "WiFi scan throttling" is off in the developer options).
     * @property queueCapacity most events waiting for the writer thread (1 to 1 000 000).
     */
    data class Options(
        val radios: Set<Radio> = setOf(Radio.BLE, Radio.WIFI),
        val beaconIds: List<String> = emptyList(),
        val sensors: Boolean = true,
        val wifiScanPeriodMs: Long = WIFI_SCAN_PERIOD_MS,
        val queueCapacity: Int = QUEUE_CAPACITY,
    ) {
        init {
            require(wifiScanPeriodMs in 1_000L..600_000L) { "wifiScanPeriodMs $wifiScanPeriodMs is not in 1000..600000" }
            require(queueCapacity in 1..1_000_000) { "queueCapacity $queueCapacity is not in 1..1000000" }
        }
    }

    companion object {
        /** Default [Options.wifiScanPeriodMs]: a phone without the throttle completes a scan in 2-4 s. */
        const val WIFI_SCAN_PERIOD_MS: Long = 4_000

        /** Default [Options.queueCapacity]: about 3 min of 50 Hz x 6 sensors plus BLE. */
        const val QUEUE_CAPACITY: Int = 65_536
    }

    private val app = context.applicationContext
    private val control = HandlerThread("fpbp-survey").also { it.start() }
    private val handler = Handler(control.looper)
    private val tracker = StatusTracker(clock)
    private val track: MutableList<SurveyMark> = Collections.synchronizedList(ArrayList())

    @Volatile private var writer: SurveyLogWriter? = null
    @Volatile private var io: ThreadPoolExecutor? = null
    @Volatile private var file: File? = null
    private var ble: BleSource? = null
    private var wifi: WifiSource? = null
    private var sensors: SensorSource? = null
    @Volatile private var closed = false

    /** Whether a survey is being recorded. */
    val isRecording: Boolean get() = writer != null

    /** The file being recorded, or the last one recorded. */
    val currentFile: File? get() = file

    /**
     * Problems of the sources (missing permissions, Bluetooth or WiFi off,
     * missing sensors). The state is WAITING_FOR_FIX while recording (a
     * survey has no pose) and STOPPED otherwise.
     */
    val status: Status get() = tracker.status

    /**
     * Starts recording into [out] (created or truncated) with [meta] as
     * `#meta` lines, and `device` = the phone model ([DeviceModel.canonical],
     * the name the positioning gives the engine) unless [meta] names one
     * (`fpbp calibrate` learns each surveyed model's offsets from it).
     */
    @JvmOverloads
    fun start(out: File, meta: Map<String, String> = emptyMap()) = onControlSync {
        check(!closed) { "FpbpSurvey is closed" }
        check(writer == null) { "a survey is already being recorded into $file" }
        val model = DeviceModel.canonical()
        val withDevice = if ("device" in meta || model == null) meta else meta + ("device" to model)
        val w = SurveyLogWriter(out.bufferedWriter(bufferSize = 64 * 1024), withDevice)
        val exec = ThreadPoolExecutor(
            1, 1, 0L, TimeUnit.MILLISECONDS, ArrayBlockingQueue(options.queueCapacity),
        ) { r -> Thread(r, "fpbp-survey-io").apply { isDaemon = true } }
        track.clear()
        file = out
        lastWriter = w
        writer = w
        io = exec
        tracker.started()
        startSources()
    }

    /**
     * Marks where the walker stands now: ([xM], [yM]) in the site's map
     * metres on [floor]. Returns the mark (its time is [clock] now). Throws
     * [IllegalStateException] when not recording, [IllegalArgumentException]
     * for a non-finite position.
     */
    fun mark(xM: Double, yM: Double, floor: Int): SurveyMark {
        require(xM.isFinite() && yM.isFinite()) { "survey mark: position ($xM, $yM) is not finite" }
        val w = writer ?: throw IllegalStateException("no survey is being recorded")
        val m = SurveyMark(clock.nowNs(), xM, yM, floor)
        track.add(m)
        // a mark is never dropped: with the queue full it is written here
        if (!submit(countDrop = false) { w.mark(m) } && io != null) w.mark(m)
        return m
    }

    /** The marks of the current (or last) survey, in order: the walked track. */
    fun marks(): List<SurveyMark> = synchronized(track) { ArrayList(track) }

    /** What the current (or last) file holds so far (a few events may still wait in the queue). */
    fun counts(): SurveyCounts = (writer ?: lastWriter)?.counts() ?: SurveyCounts()

    /** Why writing stopped (an I/O error such as a full disk), or null. */
    val failure: String? get() = (writer ?: lastWriter)?.failure

    @Volatile private var lastWriter: SurveyLogWriter? = null

    /** Re-checks the permissions (after the app's dialog) and starts the radios that waited for them. */
    fun refreshPermissions() = onControl {
        if (writer != null) startSources()
    }

    /**
     * Stops the sources, writes every queued event, flushes and closes the
     * file; returns it (null when nothing was being recorded).
     */
    fun stop(): File? {
        if (closed) return null
        val w = onControlSync {
            stopSources()
            tracker.stopped()
            writer.also { writer = null }
        } ?: return null
        val exec = io
        io = null
        exec?.shutdown()
        exec?.awaitTermination(30, TimeUnit.SECONDS)
        w.close()
        return file
    }

    /** [stop], then ends the survey's thread; the object cannot record again. */
    override fun close() {
        if (closed) return
        stop()
        closed = true
        control.quitSafely()
    }

    /**
     * Queues [block] for the writer thread; false when it was not queued (a
     * full queue: counted as dropped, or a survey that just stopped).
     */
    private inline fun submit(countDrop: Boolean = true, crossinline block: () -> Unit): Boolean {
        val exec = io ?: return false
        if (exec.queue.remainingCapacity() == 0) {
            // full (the disk stalls): drop without the cost of a rejection exception per sample
            if (countDrop) writer?.dropped()
            return false
        }
        return try {
            exec.execute { block() }
            true
        } catch (_: RejectedExecutionException) {
            if (countDrop && !exec.isShutdown) writer?.dropped()
            false
        }
    }

    private fun startSources() {
        val fg = true
        if (options.sensors && sensors == null) {
            val s = SensorSource(app) { type, t, v -> writer?.let { w -> submit { w.sensor(type, t, v) } } }
            sensors = s
            tracker.sensorsMissing(s.start(fg))
        }
        val missing = FpbpPositioning.missingPermissions(app, options.radios)
        tracker.permissionsMissing(missing)
        if (Radio.BLE in options.radios && ble == null && FpbpPositioning.missingPermissions(app, setOf(Radio.BLE)).isEmpty()) {
            ble = BleSource(app, handler, clock, BeaconFilter.forBeacons(options.beaconIds), tracker, {}) { t, id, rssi, tx ->
                writer?.let { w -> submit { w.ble(t, id, rssi, tx) } }
            }.also { it.start(fg) }
        }
        if (Radio.WIFI in options.radios && wifi == null && FpbpPositioning.missingPermissions(app, setOf(Radio.WIFI)).isEmpty()) {
            wifi = WifiSource(app, handler, clock, tracker, {}, options.wifiScanPeriodMs, limited = false) { t, b, r, f, s ->
                writer?.let { w -> submit { w.wifi(t, b, r, f, s) } }
            }.also { it.start(fg) }
        }
    }

    private fun stopSources() {
        ble?.stop()
        ble = null
        wifi?.stop()
        wifi = null
        sensors?.stop()
        sensors = null
    }

    private fun onControl(block: () -> Unit) {
        if (Looper.myLooper() == control.looper) block() else handler.post(block)
    }

    private fun <T> onControlSync(block: () -> T): T {
        if (Looper.myLooper() == control.looper) return block()
        val task = FutureTask(block)
        check(handler.post(task)) { "FpbpSurvey is closed" }
        return try {
            task.get(30, TimeUnit.SECONDS)
        } catch (e: java.util.concurrent.ExecutionException) {
            throw e.cause ?: e
        }
    }

    /** The problems in one line ("ok" when none). */
    fun describeProblems(): String {
        val s = status
        if (s.problems.isEmpty()) return "ok"
        return s.problems.sorted().joinToString(", ") { p ->
            when (p) {
                Problem.PERMISSION_MISSING -> "missing permission " + s.missingPermissions.joinToString(" ") { it.substringAfterLast('.') }
                Problem.SENSOR_MISSING -> "missing sensor types ${s.missingSensors}"
                Problem.SCAN_FAILED -> "BLE scan failed (error ${s.scanErrorCode})"
                else -> p.name.lowercase().replace('_', ' ')
            }
        }
    }
}
