package io.fpbp

/**
 * An engine's counters and online estimates, as [FpbpEngine.statsJson] gives
 * them (docs/android.md, "stats JSON"), typed.
 *
 * @property engine the engine's name (`tcpf`, `fpbp`, ...).
 * @property sensorEvents motion-sensor samples the engine took.
 * @property bleObservations BLE observations the engine took.
 * @property unknownBeacons of those, beacons the site does not list.
 * @property rejectedInputs inputs rejected as invalid, by the engine or the bridge.
 * @property bridgeRejected of those, rejected by the bridge (bad arrays, ids, values).
 * @property wifiScans WiFi scans handed to the engine.
 * @property wifiResults access-point results in those scans.
 * @property steps steps the PDR detected.
 * @property noFix task runs that could not produce a position.
 * @property rssiOffsetDb the phone's RSSI offset the engine estimates while
 *   walking (heard minus the site's model, dB; a phone that reads weaker is
 *   negative); null for engines that estimate none.
 * @property stepScale the factor the engine multiplies the PDR's step
 *   lengths by, for an engine that learns one online; null otherwise (no
 *   engine learns one today).
 * @property radioTrust how far the engine trusts its radio, in [0, 1]: 1
 *   unless its integrity checks (`tcpf.integrity`) found the radio misfitting
 *   its model (on by default after a told start without a radio map) or
 *   pulling the track beyond what the walk allows (off by default; then the
 *   accuracy radius is widened too); null for engines without one, or a library
 *   older than the field.
 * @property deviceBleOffsetDb the phone model's BLE offset the radio map gave
 *   the engine (its config's `device`, [io.fpbp.android.DeviceModel]), dB,
 *   subtracted from every reading; null when the map has none for the model,
 *   the engine uses none, or the library is older than the field.
 * @property deviceWifiOffsetDb the same for WiFi, dB.
 */
data class EngineStats(
    val engine: String,
    val sensorEvents: Long,
    val bleObservations: Long,
    val unknownBeacons: Long,
    val rejectedInputs: Long,
    val bridgeRejected: Long,
    val wifiScans: Long,
    val wifiResults: Long,
    val steps: Long,
    val noFix: Long,
    val rssiOffsetDb: Double?,
    val stepScale: Double?,
    val radioTrust: Double? = null,
    val deviceBleOffsetDb: Double? = null,
    val deviceWifiOffsetDb: Double? = null,
) {
    companion object {
        /** Longest stats JSON [parse] reads: the bridge's is ~400 bytes. */
        const val MAX_JSON_CHARS = 64 * 1024

        /**
         * Reads the stats JSON the bridge writes: one flat object of strings,
         * numbers and nulls. Keys this version does not know are skipped, so a
         * newer library's stats still read.
         *
         * @throws IllegalArgumentException when [json] is not such an object,
         *   or a field is missing or of the wrong type (the message names it).
         */
        @JvmStatic
        fun parse(json: String): EngineStats {
            require(json.length <= MAX_JSON_CHARS) { "stats JSON: ${json.length} chars, more than $MAX_JSON_CHARS" }
            val f = FlatJson(json).fields()
            fun count(key: String): Long {
                val v = f[key] ?: throw IllegalArgumentException("stats JSON: field \"$key\" missing")
                require(v is Double && v >= 0 && v == Math.floor(v) && v <= Long.MAX_VALUE.toDouble()) {
                    "stats JSON: field \"$key\" is not a count: $v"
                }
                return v.toLong()
            }
            fun optional(key: String): Double? =
                when (val v = f[key]) {
                    null, FlatJson.NULL -> null
                    is Double -> v
                    else -> throw IllegalArgumentException("stats JSON: field \"$key\" is not a number: \"$v\"")
                }
            val engine = f["engine"] as? String
                ?: throw IllegalArgumentException("stats JSON: field \"engine\" missing or not a string")
            return EngineStats(
                engine = engine,
                sensorEvents = count("sensor_events"),
                bleObservations = count("ble_observations"),
                unknownBeacons = count("unknown_beacons"),
                rejectedInputs = count("rejected_inputs"),
                bridgeRejected = count("bridge_rejected"),
                wifiScans = count("wifi_scans"),
                wifiResults = count("wifi_results"),
                steps = count("steps"),
                noFix = count("no_fix"),
                rssiOffsetDb = optional("rssi_offset_db"),
                stepScale = optional("step_scale"),
                radioTrust = optional("radio_trust"),
                deviceBleOffsetDb = optional("device_ble_offset_db"),
                deviceWifiOffsetDb = optional("device_wifi_offset_db"),
            )
        }
    }
}

/**
 * A reader of one flat JSON object (string, number, boolean and null values;
 * no nesting): the shape of the bridge's stats. Values: [String], [Double],
 * [Boolean] or [NULL].
 */
internal class FlatJson(private val s: String) {
    private var i = 0

    object NULL {
        override fun toString() = "null"
    }

    fun fields(): Map<String, Any> {
        val out = LinkedHashMap<String, Any>()
        skipSpace()
        expect('{')
        skipSpace()
        if (peek() == '}') {
            i++
        } else {
            while (true) {
                skipSpace()
                val key = string()
                skipSpace()
                expect(':')
                skipSpace()
                out[key] = value(key)
                skipSpace()
                when (next()) {
                    ',' -> continue
                    '}' -> break
                    else -> fail("',' or '}' expected")
                }
            }
        }
        skipSpace()
        if (i != s.length) fail("text after the object")
        return out
    }

    private fun value(key: String): Any =
        when (val c = peek()) {
            '"' -> string()
            'n' -> word("null", NULL)
            't' -> word("true", true)
            'f' -> word("false", false)
            '{', '[' -> fail("field \"$key\": nested values are not stats")
            else -> if (c == '-' || c in '0'..'9') number(key) else fail("field \"$key\": value expected")
        }

    private fun number(key: String): Double {
        val start = i
        while (i < s.length && (s[i].isDigit() || s[i] in "+-.eE")) i++
        return s.substring(start, i).toDoubleOrNull()?.takeIf { it.isFinite() }
            ?: fail("field \"$key\": bad number \"${s.substring(start, i)}\"")
    }

    private fun string(): String {
        expect('"')
        val b = StringBuilder()
        while (true) {
            when (val c = next()) {
                '"' -> return b.toString()
                '\\' ->
                    when (val e = next()) {
                        '"', '\\', '/' -> b.append(e)
                        'b' -> b.append('\b')
                        'f' -> b.append('\u000C')
                        'n' -> b.append('\n')
                        'r' -> b.append('\r')
                        't' -> b.append('\t')
                        'u' -> {
                            if (i + 4 > s.length) fail("short \\u escape")
                            val code = s.substring(i, i + 4).toIntOrNull(16) ?: fail("bad \\u escape")
                            b.append(code.toChar())
                            i += 4
                        }
                        else -> fail("bad escape \\$e")
                    }
                else -> b.append(c)
            }
        }
    }

    private fun <T> word(w: String, v: T): T {
        if (!s.startsWith(w, i)) fail("'$w' expected")
        i += w.length
        return v
    }

    private fun skipSpace() {
        while (i < s.length && s[i].isWhitespace()) i++
    }

    private fun peek(): Char = if (i < s.length) s[i] else fail("unexpected end")

    private fun next(): Char = peek().also { i++ }

    private fun expect(c: Char) {
        if (next() != c) fail("'$c' expected")
    }

    private fun fail(why: String): Nothing = throw IllegalArgumentException("stats JSON at char ${i.coerceAtMost(s.length)}: $why")
}
