package io.fpbp

import java.io.Closeable
import java.io.IOException
import java.io.Writer
import kotlin.math.hypot

/** A waypoint mark of a survey: where the walker was at [tNs] (MCS metres of the site, floor id). */
data class SurveyMark(val tNs: Long, val xM: Double, val yM: Double, val floor: Int)

/**
 * What a survey file holds so far.
 *
 * @property marks waypoint marks (TRUTH rows).
 * @property bleAdverts BLE advertisements (BLE rows).
 * @property wifiScans WiFi scans (WIFI rows, empty ones included).
 * @property wifiResults WiFi results in those scans.
 * @property sensorSamples sensor samples (ACC, GYR, MAG, ROT, GRV, PRS rows).
 * @property samplesByKind sensor samples per native kind (`ACC`, `GYR`, `MAG`, `ROT`, `GRV`, `PRS`).
 * @property skipped samples and WiFi results not written (see [NativeLogWriter.skipped]).
 * @property dropped events lost before the writer (the recorder's queue was full).
 * @property trackM length of the walked track: the straight lines between consecutive marks on one floor, metres.
 * @property longGaps consecutive marks more than [SurveyLogWriter.MAX_MARK_GAP_NS] apart: the readings
 *   between them get no position in `fpbp calibrate --radio-map` (`radio_map.max_truth_gap_s`).
 */
data class SurveyCounts(
    val marks: Long = 0,
    val bleAdverts: Long = 0,
    val wifiScans: Long = 0,
    val wifiResults: Long = 0,
    val sensorSamples: Long = 0,
    val samplesByKind: Map<String, Long> = emptyMap(),
    val skipped: Long = 0,
    val dropped: Long = 0,
    val trackM: Double = 0.0,
    val longGaps: Long = 0,
) {
    /** One line for a survey screen. */
    fun describe(): String =
        "marks $marks (%.0f m walked%s), BLE $bleAdverts, WiFi scans $wifiScans ($wifiResults results), samples $sensorSamples".format(
            java.util.Locale.US,
            trackM,
            if (longGaps > 0) ", $longGaps gaps > ${SurveyLogWriter.MAX_MARK_GAP_NS / 1_000_000_000} s" else "",
        ) + (if (skipped + dropped > 0) ", skipped $skipped, dropped $dropped" else "")
}

/**
 * Writes a survey as a native log v2 (docs/logs.md "Native log"): the radio
 * and motion inputs as the engine would take them, and the walker's
 * waypoint marks as TRUTH rows, which `fpbp calibrate --wifi --radio-map`
 * reads as the survey's ground truth (the position between two marks is
 * the straight line at constant speed). Plain JVM; thread-safe (every call
 * is serialised); the lines go to [out] as they come (buffer it), nothing
 * is kept but the counts and the marks. An I/O error stops the writing
 * ([failure] says why) instead of throwing on the caller's sensor or scan
 * thread; calls after [close] are ignored.
 */
class SurveyLogWriter @JvmOverloads constructor(out: Writer, meta: Map<String, String> = emptyMap()) : Closeable {
    companion object {
        /** Marks further apart than this leave the readings between them unplaced (`radio_map.max_truth_gap_s` 20 s). */
        const val MAX_MARK_GAP_NS: Long = 20_000_000_000L

        /** Marks kept in memory for [marks] (a day's survey has a few thousand); later ones are written, not kept. */
        const val MAX_MARKS_KEPT: Int = 100_000
    }

    private val log = NativeLogWriter(out, meta + ("recorder" to "fpbp-survey"), 2)
    private var closed = false
    private var marks = 0L
    private var ble = 0L
    private var scans = 0L
    private var results = 0L
    private val byKind = sortedMapOf<String, Long>()
    private var dropped = 0L
    private var trackM = 0.0
    private var longGaps = 0L
    private val kept = ArrayList<SurveyMark>()
    private var last: SurveyMark? = null

    /** Why writing stopped (an I/O error), or null. */
    @get:Synchronized
    var failure: String? = null
        private set

    /** One sensor sample (`Sensor.TYPE_*`, values as `SensorEvent.values`). */
    @Synchronized
    fun sensor(type: Int, tNs: Long, values: DoubleArray) = io {
        val before = log.skipped
        log.sensor(tNs, type, values)
        if (log.skipped == before) NativeLog.kindOf(type)?.let { byKind[it] = (byKind[it] ?: 0L) + 1 }
    }

    /** One BLE advertisement. */
    @Synchronized
    fun ble(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) = io {
        val before = log.skipped
        log.ble(tNs, beaconId, rssiDbm, txPowerDbm)
        if (log.skipped == before) ble++
    }

    /** One WiFi scan (see [NativeLogWriter.wifi]). */
    @Synchronized
    fun wifi(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) = io {
        val n = log.wifi(tNs, bssids, rssiDbm, freqMhz, seenTNs)
        if (n >= 0) {
            scans++
            results += n
        }
    }

    /**
     * A waypoint mark: the walker is at ([SurveyMark.xM], [SurveyMark.yM])
     * on [SurveyMark.floor] at [SurveyMark.tNs]. Throws
     * [IllegalArgumentException] for a non-finite coordinate (a caller's bug).
     */
    @Synchronized
    fun mark(m: SurveyMark) {
        require(m.xM.isFinite() && m.yM.isFinite()) { "survey mark: position (${m.xM}, ${m.yM}) is not finite" }
        io {
            log.truth(m.tNs, m.xM, m.yM, m.floor)
            marks++
            last?.let { p ->
                if (p.floor == m.floor) trackM += hypot(m.xM - p.xM, m.yM - p.yM)
                if (m.tNs - p.tNs > MAX_MARK_GAP_NS) longGaps++
            }
            last = m
            if (kept.size < MAX_MARKS_KEPT) kept.add(m)
        }
    }

    /** Events lost before they reached the writer (counted in [counts]). */
    @Synchronized
    fun dropped(n: Long = 1) {
        dropped += n
    }

    /** The counts of what was written. */
    @Synchronized
    fun counts(): SurveyCounts = SurveyCounts(
        marks = marks,
        bleAdverts = ble,
        wifiScans = scans,
        wifiResults = results,
        sensorSamples = byKind.values.sum(),
        samplesByKind = byKind.toMap(),
        skipped = log.skipped,
        dropped = dropped,
        trackM = trackM,
        longGaps = longGaps,
    )

    /** The marks written so far, in order (at most [MAX_MARKS_KEPT]). */
    @Synchronized
    fun marks(): List<SurveyMark> = ArrayList(kept)

    /** Writes the buffered lines through. */
    @Synchronized
    fun flush() = io { log.flush() }

    /** Flushes and closes the output; later calls are ignored. */
    @Synchronized
    override fun close() {
        if (closed) return
        closed = true
        try {
            log.close()
        } catch (e: IOException) {
            if (failure == null) failure = "closing the survey file: ${e.message}"
        }
    }

    private inline fun io(block: () -> Unit) {
        if (closed) return
        try {
            block()
        } catch (e: IOException) {
            failure = "writing the survey file: ${e.message}"
            closed = true
            try {
                log.close()
            } catch (_: IOException) {
            }
        }
    }
}
