package io.fpbp

import io.fpbp.android.FpbpPositioning
import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertNotEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Assumptions.assumeTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.fail
import java.io.File

/**
 * Issue 37's measure: a real log with WiFi (an odd path of ILC site 1 F1,
 * from ../shared/datasets) fed through the library with its site bundle
 * gives the same track, bit for bit, as `fpbp eval --radio-map` on the same
 * log. The engine is started the way [FpbpPositioning] starts it
 * ([FpbpPositioning.Site.startEngine] of [FpbpPositioning.Site.fromBundle]);
 * its tasks run on the log's clock ([LogClockDriver]: FpbpPositioning's
 * own scheduler runs on the wall clock and needs Android's threads).
 *
 * Also: the plain `Site(json, dir, radioMapJson)` form gives the same track,
 * and without the radio map the track differs (the map does reach the
 * engine: this fails if FpbpPositioning drops it again).
 *
 * run.sh builds everything under target/ at test time (never committed):
 * `fpbp import ilc`, `fpbp calibrate --split even --wifi --radio-map` on a
 * few survey paths, `fpbp bundle`, `fpbp eval --radio-map --tracks` on the
 * odd path, and the log's events (rust/jni/examples/events_dump.rs). It
 * passes fpbp.facade.{bundle,site,radiomap,events,track}, or
 * fpbp.facade.events=none when ../shared/datasets is missing (this test is
 * then skipped, which fails the run under CI=true).
 */
class FacadeReplayTest {
    private fun prop(name: String): String =
        System.getProperty(name)?.takeIf { it.isNotEmpty() }
            ?: fail("system property $name is not set: run host-tests/jvm/run.sh")

    private fun bits(s: String) = java.lang.Double.longBitsToDouble(java.lang.Long.parseUnsignedLong(s, 16))

    /** Feeds the events_dump file [f] to [e] on the log's clock; returns the track. */
    private fun replay(e: FpbpEngine, f: File): List<Pose> {
        val driver = LogClockDriver(e)
        var n = 0
        f.bufferedReader().useLines { lines ->
            for (line in lines) {
                if (line.startsWith("#") || line.isBlank()) continue
                val p = line.split(' ')
                val t = p[1].toLong()
                driver.beforeEvent(t)
                n++
                when (p[0]) {
                    "S" -> e.onSensor(p[2].toInt(), t, DoubleArray(p.size - 3) { bits(p[3 + it]) })
                    "B" -> e.onBleScan(t, p[2], bits(p[3]), bits(p[4]).takeUnless { it.isNaN() })
                    "W" -> {
                        val k = p[2].toInt()
                        e.onWifiScan(
                            t,
                            Array(k) { p[3 + 4 * it] },
                            DoubleArray(k) { bits(p[4 + 4 * it]) },
                            IntArray(k) { p[5 + 4 * it].toInt() },
                            LongArray(k) { p[6 + 4 * it].toLong() },
                        )
                    }
                    "G" -> {
                        val v = (2..7).map { bits(p[it]) }
                        fun o(x: Double) = x.takeUnless { it.isNaN() }
                        e.onGnss(t, v[0], v[1], o(v[2]), o(v[3]), o(v[4]), o(v[5]))
                    }
                    "T" -> Unit // truth: runs the due tasks, never fed
                    else -> fail("$f: unknown event line `${line.take(40)}`")
                }
            }
        }
        driver.finish()
        assertTrue(n > 0, "$f holds no events")
        return driver.track
    }

    /** `fpbp eval --tracks` CSV (report::track_csv): the pose rows. */
    private fun readEvalTrack(f: File): List<Pose> {
        fun num(s: String) = when (s) {
            "inf" -> Double.POSITIVE_INFINITY
            "-inf" -> Double.NEGATIVE_INFINITY
            else -> s.toDouble()
        }
        fun ns(s: String): Long {
            val neg = s.startsWith("-")
            val (a, b) = s.removePrefix("-").split('.')
            val v = a.toLong() * 1_000_000_000L + b.padEnd(9, '0').toLong()
            return if (neg) -v else v
        }
        return f.readLines().drop(1).filter { it.startsWith("pose,") }.map { l ->
            val c = l.split(',')
            Pose(
                ns(c[1]), num(c[2]), num(c[3]), c[4].toInt(), num(c[5]), num(c[6]),
                floorProb = num(c[7]), source = PoseSource.fromCode(c[8].toInt()),
            )
        }
    }

    private fun raw(p: Pose) = listOf(
        p.tNs, p.xM.toRawBits(), p.yM.toRawBits(), p.floor.toLong(), p.headingRad.toRawBits(), p.accuracyM.toRawBits(),
        p.floorProb.toRawBits(), p.source.code.toLong(),
    )

    private fun assertSameTrack(what: String, want: List<Pose>, got: List<Pose>) {
        val k = got.indices.firstOrNull { it >= want.size || raw(got[it]) != raw(want[it]) }
        if (k != null || got.size != want.size) {
            val at = k ?: minOf(got.size, want.size)
            fail("$what: tracks differ at pose $at: ${got.getOrNull(at)} vs ${want.getOrNull(at)} (sizes ${got.size} vs ${want.size})")
        }
    }

    private fun heapUsed(): Long {
        val r = Runtime.getRuntime()
        System.gc()
        return r.totalMemory() - r.freeMemory()
    }

    @Test
    fun bundleThroughTheFacadeGivesTheEvalTrackBitForBit() {
        assumeTrue(System.getProperty("fpbp.facade.events") != "none") {
            "../shared/datasets not found: the ILC F1 facade replay did not run"
        }
        val bundleFile = File(prop("fpbp.facade.bundle"))
        val events = File(prop("fpbp.facade.events"))
        val want = readEvalTrack(File(prop("fpbp.facade.track")))
        assertTrue(want.isNotEmpty(), "fpbp eval wrote no pose: nothing to compare")
        val engine = FpbpDefaults.ENGINE

        val heap0 = heapUsed()
        val t0 = System.nanoTime()
        val site = FpbpPositioning.Site.fromBundle(bundleFile)
        val viaBundle = site.startEngine(engine, "", null)
        val loadMs = (System.nanoTime() - t0) / 1e6
        val heapMb = (heapUsed() - heap0) / 1e6
        val bundleTrack = viaBundle.use { replay(it, events) }
        println(
            "facade replay: ${events.name}, bundle ${bundleFile.length()} bytes: " +
                "Site.fromBundle + startEngine %.1f ms, Java heap %+.1f MB; ".format(loadMs, heapMb) +
                "${bundleTrack.size} poses, eval track ${want.size} poses",
        )
        assertSameTrack("bundle vs fpbp eval --radio-map", want, bundleTrack)

        // the plain form with the radio map's JSON: the same track
        val siteFile = File(prop("fpbp.facade.site"))
        val mapJson = File(prop("fpbp.facade.radiomap")).readText()
        val plain = FpbpPositioning.Site(siteFile.readText(), siteFile.parentFile.path, mapJson)
        val plainTrack = plain.startEngine(engine, "", null).use { replay(it, events) }
        assertSameTrack("Site(json, dir, radioMapJson) vs fpbp eval --radio-map", want, plainTrack)

        // without the map the engine runs on the path-loss model: another track
        val noMap = FpbpPositioning.Site(siteFile.readText(), siteFile.parentFile.path)
        val noMapTrack = noMap.startEngine(engine, "", null).use { replay(it, events) }
        assertNotEquals(want.map(::raw), noMapTrack.map(::raw), "the radio map changed nothing: did it reach the engine?")
        assertEquals(site.json, siteFile.readText(), "the bundle's site.json is the site file")
        println("facade replay: ${bundleTrack.size} poses identical bit for bit to fpbp eval --radio-map (bundle and JSON forms)")
    }
}
