package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Assumptions.assumeTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.fail
import java.io.File
import java.util.zip.GZIPInputStream

/**
 * (a) A shipped log replayed through the JNI surface, with [RadioTask] and
 * [FusionTask] driven by the log's clock ([LogClockDriver]), gives the same
 * track, bit for bit, as the pure-Rust replay (`fpbp_core::engine::replay`)
 * of the same log, written by rust/jni/examples/replay_reference.rs.
 *
 * run.sh passes: fpbp.replay.site, fpbp.replay.log, fpbp.replay.reference,
 * fpbp.replay.engine, fpbp.replay.init (`first-truth` or `none`).
 */
class ReplayEqualityTest {
    private fun prop(name: String): String =
        System.getProperty(name)?.takeIf { it.isNotEmpty() }
            ?: fail("system property $name is not set: run host-tests/jvm/run.sh")

    private data class Ref(val engine: String, val events: Int, val stats: String, val track: List<Pose>)

    private fun bits(s: String) = java.lang.Double.longBitsToDouble(java.lang.Long.parseUnsignedLong(s, 16))

    private fun readReference(f: File): Ref {
        val lines = f.readLines()
        val head = lines.first()
        require(head.startsWith("# fpbp-replay-reference 2")) { "$f: bad header `$head`" }
        val engine = Regex("engine=(\\S+)").find(head)!!.groupValues[1]
        val events = Regex("events=(\\d+)").find(head)!!.groupValues[1].toInt()
        val stats = lines[1].removePrefix("# stats ")
        val track = lines.drop(2).filter { it.isNotBlank() }.map { l ->
            val p = l.split(' ')
            Pose(
                p[0].toLong(), bits(p[1]), bits(p[2]), p[3].toInt(), bits(p[4]), bits(p[5]),
                floorProb = bits(p[6]), source = PoseSource.fromCode(p[7].toInt()),
            )
        }
        return Ref(engine, events, stats, track)
    }

    private fun readLog(f: File): NativeLogReader.Log {
        val input = f.inputStream().buffered()
        val stream = if (f.name.endsWith(".gz")) GZIPInputStream(input) else input
        return stream.bufferedReader().use { NativeLogReader.read(it) }
    }

    private fun raw(p: Pose) = listOf(
        p.tNs, p.xM.toRawBits(), p.yM.toRawBits(), p.floor.toLong(), p.headingRad.toRawBits(), p.accuracyM.toRawBits(),
        p.floorProb.toRawBits(), p.source.code.toLong(),
    )

    @Test
    fun jniReplayEqualsRustReplayBitForBit() {
        assumeTrue(System.getProperty("fpbp.replay.log") != "none") { "no shipped log in host-tests/logs/" }
        val site = File(prop("fpbp.replay.site"))
        val log = File(prop("fpbp.replay.log"))
        val ref = readReference(File(prop("fpbp.replay.reference")))
        val engineName = prop("fpbp.replay.engine")
        assertEquals(engineName, ref.engine)
        val events = readLog(log).events
        assertEquals(ref.events, events.size, "the Kotlin and Rust readers see different event counts in $log")
        assertTrue(events.zipWithNext().all { (a, b) -> a.tNs <= b.tNs }, "$log is not in time order")

        val init = if (System.getProperty("fpbp.replay.init") == "first-truth") {
            events.filterIsInstance<LogEvent.Truth>().firstOrNull()?.let { InitialPosition(it.xM, it.yM, it.floor ?: 0) }
        } else {
            null
        }
        val engine = FpbpEngine.start(site.readText(), site.parentFile.path, engineName, "", init)
        val driver = LogClockDriver(engine)
        engine.use { e ->
            for (ev in events) {
                driver.beforeEvent(ev.tNs)
                when (ev) {
                    is LogEvent.Sensor -> e.onSensor(ev.sensorType, ev.tNs, ev.values)
                    is LogEvent.Ble -> e.onBleScan(ev.tNs, ev.beaconId, ev.rssiDbm, ev.txPowerDbm)
                    is LogEvent.Gnss -> e.onGnss(ev.tNs, ev.latDeg, ev.lonDeg, ev.altM, ev.accuracyM, ev.speedMps, ev.bearingDeg)
                    is LogEvent.Wifi -> e.onWifiScan(
                        ev.tNs,
                        Array(ev.results.size) { ev.results[it].bssid },
                        DoubleArray(ev.results.size) { ev.results[it].rssiDbm },
                        IntArray(ev.results.size) { ev.results[it].freqMhz },
                        LongArray(ev.results.size) { ev.results[it].seenTNs },
                    )
                    is LogEvent.Truth -> Unit // never given to the engine
                }
            }
            driver.finish()
            val stats = e.statsJson()
            val jvm = driver.track
            println(
                "replay equality: ${log.name} on `$engineName` (init ${if (init == null) "none" else "first truth"}): " +
                    "${events.size} events, JVM track ${jvm.size} poses, Rust track ${ref.track.size} poses",
            )
            assertTrue(ref.track.isNotEmpty(), "the Rust replay produced no pose: nothing to compare")
            val firstDiff = jvm.indices.firstOrNull { it >= ref.track.size || raw(jvm[it]) != raw(ref.track[it]) }
            if (firstDiff != null || jvm.size != ref.track.size) {
                val k = firstDiff ?: minOf(jvm.size, ref.track.size)
                fail("tracks differ at pose $k: JVM ${jvm.getOrNull(k)} vs Rust ${ref.track.getOrNull(k)} (sizes ${jvm.size} vs ${ref.track.size})")
            }
            assertEquals(ref.stats, stats, "engine counters differ")
            if (engineName == "tcpf") {
                // the online phone RSSI offset reaches the app (issue 16)
                assertTrue(Regex("\"rssi_offset_db\":-?[0-9]").containsMatchIn(stats), "no RSSI offset in $stats")
                // and reads the same through the typed accessor
                val typed = e.stats()
                assertEquals("tcpf", typed.engine)
                assertTrue(typed.rssiOffsetDb != null, "typed stats lack the offset: $typed")
                assertTrue(typed.steps > 0, "no steps counted: $typed")
            }
            println("replay equality: ${jvm.size} poses identical bit for bit; stats identical")
        }
    }
}
