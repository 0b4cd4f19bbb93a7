package io.fpbp

import java.io.BufferedReader
import java.io.Closeable
import java.io.Writer
import kotlin.math.sqrt

/**
 * fpbp native log v2 (docs/logs.md "Native log", rust/logs/src/native.rs):
 * text, one event per line, `t_ns` first:
 *
 * ```
 * #fpbp-log 2
 * #meta device=Pixel 7
 * 1000000 ACC 0.1 0.2 9.81
 * 1000000 BLE ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:2 -71 -59
 * 1500000 WIFI 2 a8:0c:ca:03:9d:d7 -49 2422 1400000 a8:0c:ca:83:9d:d7 -59 5785 1500000
 * 2000000 TRUTH 12.5 3.25 0
 * ```
 *
 * Kinds: ACC/GYR/MAG x y z, ROT/GRV x y z w, PRS hpa, BLE id rssi tx|-,
 * GNSS lat lon alt|- acc|- speed|- bearing|-, TRUTH x y floor|-, and (v2)
 * WIFI n then n x (bssid rssi freq_mhz seen_t_ns). v1 is v2 without WIFI
 * lines; both are read. Numbers are written with [Double.toString]
 * (shortest round-trip, which the Rust reader parses back to the same
 * double), so a recorded log replays the exact values the live engine
 * received.
 */
object NativeLog {
    const val MAGIC = "#fpbp-log"

    /** The version written by default (v2: v1 + WIFI lines). */
    const val VERSION = 2

    /** Most results one WIFI line may carry (rust/logs `MAX_RESULTS_PER_SCAN`). */
    const val MAX_WIFI_RESULTS_PER_SCAN = 4096

    /** Whether [s] is a canonical BSSID (lower-case `aa:bb:cc:dd:ee:ff`), as the Rust writer requires. */
    @JvmStatic
    fun isBssid(s: String): Boolean =
        s.length == 17 && s.indices.all { i -> if (i % 3 == 2) s[i] == ':' else s[i] in '0'..'9' || s[i] in 'a'..'f' }

    /** Native kind of an Android sensor type, or null when fpbp does not use it. */
    @JvmStatic
    fun kindOf(sensorType: Int): String? = when (sensorType) {
        1 -> "ACC"
        4 -> "GYR"
        2 -> "MAG"
        11 -> "ROT"
        15 -> "GRV"
        6 -> "PRS"
        else -> null
    }

    /** Android sensor type of a native kind, or null. */
    @JvmStatic
    fun sensorTypeOf(kind: String): Int? = when (kind) {
        "ACC" -> 1
        "GYR" -> 4
        "MAG" -> 2
        "ROT" -> 11
        "GRV" -> 15
        "PRS" -> 6
        else -> null
    }
}

/** One event of a native log. Sensor values are as the engine takes them (`Sensor.TYPE_*`). */
sealed class LogEvent {
    abstract val tNs: Long

    data class Sensor(override val tNs: Long, val sensorType: Int, val values: DoubleArray) : LogEvent() {
        override fun equals(other: Any?) =
            other is Sensor && other.tNs == tNs && other.sensorType == sensorType && other.values.contentEquals(values)
        override fun hashCode() = 31 * (31 * tNs.hashCode() + sensorType) + values.contentHashCode()
    }

    data class Ble(override val tNs: Long, val beaconId: String, val rssiDbm: Double, val txPowerDbm: Double?) : LogEvent()

    data class Gnss(
        override val tNs: Long,
        val latDeg: Double,
        val lonDeg: Double,
        val altM: Double?,
        val accuracyM: Double?,
        val speedMps: Double?,
        val bearingDeg: Double?,
    ) : LogEvent()

    data class Truth(override val tNs: Long, val xM: Double, val yM: Double, val floor: Int?) : LogEvent()

    /** One WiFi scan (v2): the results as Android delivered them at once. */
    data class Wifi(override val tNs: Long, val results: List<WifiResult>) : LogEvent()
}

/** One result of a WiFi scan: canonical BSSID, RSSI dBm, channel centre MHz, last seen (ns, <= the scan's time). */
data class WifiResult(val bssid: String, val rssiDbm: Double, val freqMhz: Int, val seenTNs: Long)

/**
 * Writes a native log, v2 by default ([version] 1 writes no WiFi). Not
 * thread-safe: the recorder serialises calls. A sample fpbp does not use
 * (unknown sensor type, too few values) is skipped and counted in
 * [skipped], as the engine would count it; so is a WiFi result the engine's
 * bridge drops (not a BSSID, non-finite RSSI, frequency <= 0, last seen
 * after its scan), so a recorded log replays what the live engine received.
 */
class NativeLogWriter @JvmOverloads constructor(
    private val out: Writer,
    meta: Map<String, String> = emptyMap(),
    val version: Int = NativeLog.VERSION,
) : Closeable {
    private val sb = StringBuilder(128)

    /** Samples (and WiFi results) not written: unknown type, too few values, whitespace in a beacon id, a bad WiFi result. */
    var skipped: Long = 0
        private set

    init {
        require(version == 1 || version == 2) { "native log: version $version is not 1 or 2" }
        out.write("${NativeLog.MAGIC} $version\n")
        for ((k, v) in meta.toSortedMap()) {
            require(k.isNotEmpty() && k.none { it.isWhitespace() || it == '=' }) { "native log: bad metadata key `$k`" }
            require(v.none { it == '\n' || it == '\r' }) { "native log: value of `$k` has a line break" }
            out.write("#meta $k=$v\n")
        }
    }

    /** One sensor sample, values as `SensorEvent.values` widened to double. */
    fun sensor(tNs: Long, sensorType: Int, values: DoubleArray) {
        val kind = NativeLog.kindOf(sensorType)
        val need = if (sensorType == 6) 1 else 3
        if (kind == null || values.size < need) {
            skipped++
            return
        }
        sb.setLength(0)
        sb.append(tNs).append(' ').append(kind)
        when (sensorType) {
            6 -> sb.append(' ').append(values[0])
            11, 15 -> {
                val (x, y, z) = Triple(values[0], values[1], values[2])
                // Same rule as SensorData::from_android when the phone omits w.
                val w = if (values.size >= 4) values[3] else sqrt(maxOf(1.0 - x * x - y * y - z * z, 0.0))
                sb.append(' ').append(x).append(' ').append(y).append(' ').append(z).append(' ').append(w)
            }
            else -> sb.append(' ').append(values[0]).append(' ').append(values[1]).append(' ').append(values[2])
        }
        line()
    }

    /** One BLE advertisement. */
    fun ble(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) {
        if (beaconId.isEmpty() || beaconId.any { it.isWhitespace() }) {
            skipped++
            return
        }
        sb.setLength(0)
        sb.append(tNs).append(" BLE ").append(beaconId).append(' ').append(rssiDbm).append(' ')
        opt(txPowerDbm)
        line()
    }

    /** One GNSS fix. */
    fun gnss(tNs: Long, latDeg: Double, lonDeg: Double, altM: Double?, accuracyM: Double?, speedMps: Double?, bearingDeg: Double?) {
        sb.setLength(0)
        sb.append(tNs).append(" GNSS ").append(latDeg).append(' ').append(lonDeg)
        for (v in listOf(altM, accuracyM, speedMps, bearingDeg)) {
            sb.append(' ')
            opt(v)
        }
        line()
    }

    /** One ground-truth point (e.g. a tap on the map while recording). */
    fun truth(tNs: Long, xM: Double, yM: Double, floor: Int?) {
        sb.setLength(0)
        sb.append(tNs).append(" TRUTH ").append(xM).append(' ').append(yM).append(' ').append(floor?.toString() ?: "-")
        line()
    }

    /**
     * One WiFi scan at [tNs] in the arrays [io.fpbp.android.FpbpPositioning]
     * and the engine take (the first `min(sizes)` entries). Results are
     * written with their BSSID lower-cased; the results the bridge drops are
     * skipped (counted), and so are those beyond
     * [NativeLog.MAX_WIFI_RESULTS_PER_SCAN]. A scan with no result left is
     * still written (`WIFI 0`: nothing heard is information). Returns the
     * number of results written, or -1 when the scan was skipped (a v1 file).
     */
    fun wifi(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray): Int {
        if (version < 2) {
            skipped++
            return -1
        }
        val n = minOf(bssids.size, rssiDbm.size, freqMhz.size, seenTNs.size)
        val body = StringBuilder(48 * minOf(n, 64))
        var kept = 0
        for (i in 0 until n) {
            val b = bssids[i]?.lowercase()
            if (b == null || !NativeLog.isBssid(b) || !rssiDbm[i].isFinite() || freqMhz[i] <= 0 || seenTNs[i] > tNs ||
                kept == NativeLog.MAX_WIFI_RESULTS_PER_SCAN
            ) {
                skipped++
                continue
            }
            body.append(' ').append(b).append(' ').append(rssiDbm[i]).append(' ').append(freqMhz[i]).append(' ').append(seenTNs[i])
            kept++
        }
        sb.setLength(0)
        sb.append(tNs).append(" WIFI ").append(kept).append(body)
        line()
        return kept
    }

    /** Writes any [LogEvent]. */
    fun write(e: LogEvent) {
        when (e) {
            is LogEvent.Sensor -> sensor(e.tNs, e.sensorType, e.values)
            is LogEvent.Ble -> ble(e.tNs, e.beaconId, e.rssiDbm, e.txPowerDbm)
            is LogEvent.Gnss -> gnss(e.tNs, e.latDeg, e.lonDeg, e.altM, e.accuracyM, e.speedMps, e.bearingDeg)
            is LogEvent.Truth -> truth(e.tNs, e.xM, e.yM, e.floor)
            is LogEvent.Wifi -> wifi(
                e.tNs,
                Array(e.results.size) { e.results[it].bssid },
                DoubleArray(e.results.size) { e.results[it].rssiDbm },
                IntArray(e.results.size) { e.results[it].freqMhz },
                LongArray(e.results.size) { e.results[it].seenTNs },
            )
        }
    }

    private fun opt(v: Double?) {
        if (v == null) sb.append('-') else sb.append(v)
    }

    private fun line() {
        sb.append('\n')
        out.write(sb.toString())
    }

    fun flush() = out.flush()

    override fun close() = out.close()
}

/** Reads a native v1 or v2 log; a malformed line throws [IllegalArgumentException] naming its number. */
object NativeLogReader {
    /** Metadata, events and header version of a log. */
    data class Log(val meta: Map<String, String>, val events: List<LogEvent>, val version: Int = NativeLog.VERSION)

    @JvmStatic
    fun read(r: BufferedReader): Log {
        val meta = sortedMapOf<String, String>()
        val events = ArrayList<LogEvent>()
        var n = 0
        var version = 0
        r.forEachLine { raw ->
            n++
            val line = raw.trimEnd('\r', '\n')
            if (n == 1) {
                val v = line.removePrefix(NativeLog.MAGIC).trim()
                require(line.startsWith(NativeLog.MAGIC) && (v == "1" || v == "2")) {
                    "line 1: not a native log v1 or v2 (`$line`)"
                }
                version = v.toInt()
                return@forEachLine
            }
            if (line.isBlank()) return@forEachLine
            if (line.startsWith("#")) {
                if (line.startsWith("#meta ")) {
                    val kv = line.removePrefix("#meta ")
                    val i = kv.indexOf('=')
                    if (i > 0) meta[kv.substring(0, i).trim()] = kv.substring(i + 1)
                }
                return@forEachLine
            }
            events.add(parseEvent(line, n, version))
        }
        return Log(meta, events, version)
    }

    private fun parseEvent(line: String, n: Int, version: Int): LogEvent {
        val f = line.trim().split(Regex("\\s+"))
        fun bad(msg: String): Nothing = throw IllegalArgumentException("line $n: $msg: `$line`")
        fun num(i: Int): Double = f.getOrNull(i)?.toDoubleOrNull() ?: bad("field ${i + 1} is not a number")
        fun opt(i: Int): Double? = if (f.getOrNull(i) == "-") null else num(i)
        fun need(k: Int) { if (f.size != k) bad("${f[1]} needs ${k - 2} values, got ${f.size - 2}") }
        if (f.size < 2) bad("expected `t_ns KIND ...`")
        val t = f[0].toLongOrNull() ?: bad("t_ns is not an integer")
        val kind = f[1]
        NativeLog.sensorTypeOf(kind)?.let { type ->
            val k = when (type) { 6 -> 1; 11, 15 -> 4; else -> 3 }
            need(k + 2)
            return LogEvent.Sensor(t, type, DoubleArray(k) { num(2 + it) })
        }
        return when (kind) {
            "BLE" -> { need(5); LogEvent.Ble(t, f[2], num(3), opt(4)) }
            "GNSS" -> { need(8); LogEvent.Gnss(t, num(2), num(3), opt(4), opt(5), opt(6), opt(7)) }
            "TRUTH" -> {
                need(5)
                val floor = if (f[4] == "-") null else (f[4].toIntOrNull() ?: bad("floor is not an integer"))
                LogEvent.Truth(t, num(2), num(3), floor)
            }
            "WIFI" -> {
                if (version < 2) bad("WIFI lines need native log version 2")
                val k = f.getOrNull(2)?.toIntOrNull()?.takeIf { it in 0..NativeLog.MAX_WIFI_RESULTS_PER_SCAN }
                    ?: bad("field 3 (n_results) is not in 0..${NativeLog.MAX_WIFI_RESULTS_PER_SCAN}")
                need(3 + 4 * k)
                LogEvent.Wifi(
                    t,
                    List(k) { j ->
                        val i = 3 + 4 * j
                        val b = f[i].lowercase().takeIf(NativeLog::isBssid) ?: bad("field ${i + 1} is not a BSSID")
                        val freq = f[i + 2].toIntOrNull() ?: bad("field ${i + 3} (freq_mhz) is not an integer")
                        val seen = f[i + 3].toLongOrNull() ?: bad("field ${i + 4} (seen_t_ns) is not an integer")
                        if (seen > t) bad("field ${i + 4} (seen_t_ns) is after the scan's time")
                        WifiResult(b, num(i + 1), freq, seen)
                    },
                )
            }
            else -> bad("unknown event kind `$kind`")
        }
    }
}
