package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertNotNull
import org.junit.jupiter.api.Assertions.assertNull
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows
import java.io.IOException
import java.io.StringReader
import java.io.StringWriter
import java.io.Writer

/** The survey recorder's file format and counts (plain JVM; the Android side: robo.SurveyRecordingTest). */
class SurveyLogWriterTest {
    private fun read(text: String) = NativeLogReader.read(StringReader(text).buffered())

    /** Guards: what is written is what the counts say, bad WiFi results are dropped as the engine drops them. */
    @Test
    fun writesAV2SurveyAndCountsWhatItWrote() {
        val out = StringWriter()
        val w = SurveyLogWriter(out, mapOf("site" to "demo"))
        w.mark(SurveyMark(1_000, 1.0, 2.0, 0))
        w.sensor(1, 1_100, doubleArrayOf(0.1, 0.2, 9.8))
        w.sensor(6, 1_100, doubleArrayOf(1013.0))
        w.sensor(99, 1_100, doubleArrayOf(1.0)) // not a type fpbp uses: skipped
        w.ble(1_200, "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:2", -70.0, -59.0)
        w.wifi(
            2_000,
            arrayOf("AA:BB:CC:DD:EE:01", "bad", null, "aa:bb:cc:dd:ee:02", "aa:bb:cc:dd:ee:03"),
            doubleArrayOf(-50.0, -60.0, -60.0, Double.NaN, -80.0),
            intArrayOf(2412, 2412, 2412, 5180, 5180),
            longArrayOf(1_900, 1_900, 1_900, 1_900, 2_001), // the last one seen after its scan
        )
        w.wifi(3_000, emptyArray(), DoubleArray(0), IntArray(0), LongArray(0))
        w.mark(SurveyMark(5_000, 4.0, 6.0, 0)) // 5 m from the first
        w.mark(SurveyMark(30_000_006_000, 4.0, 6.0, 1)) // 30 s later: a long gap; another floor
        w.close()
        w.sensor(1, 99_000, doubleArrayOf(0.0, 0.0, 9.8)) // after close: ignored

        val c = w.counts()
        assertEquals(3L, c.marks)
        assertEquals(1L, c.bleAdverts)
        assertEquals(2L, c.wifiScans)
        assertEquals(1L, c.wifiResults)
        assertEquals(2L, c.sensorSamples)
        assertEquals(mapOf("ACC" to 1L, "PRS" to 1L), c.samplesByKind)
        assertEquals(5L, c.skipped) // sensor 99 + four WiFi results
        assertEquals(5.0, c.trackM, 1e-9)
        assertEquals(1L, c.longGaps)
        assertNull(w.failure)

        val log = read(out.toString())
        assertEquals(2, log.version)
        assertEquals("demo", log.meta["site"])
        assertEquals("fpbp-survey", log.meta["recorder"])
        val wifi = log.events.filterIsInstance<LogEvent.Wifi>()
        assertEquals(listOf(WifiResult("aa:bb:cc:dd:ee:01", -50.0, 2412, 1_900)), wifi[0].results)
        assertEquals(emptyList<WifiResult>(), wifi[1].results)
        assertEquals(
            listOf(SurveyMark(1_000, 1.0, 2.0, 0), SurveyMark(5_000, 4.0, 6.0, 0), SurveyMark(30_000_006_000, 4.0, 6.0, 1)),
            log.events.filterIsInstance<LogEvent.Truth>().map { SurveyMark(it.tNs, it.xM, it.yM, it.floor!!) },
        )
        assertEquals(w.marks(), log.events.filterIsInstance<LogEvent.Truth>().map { SurveyMark(it.tNs, it.xM, it.yM, it.floor!!) })
        assertEquals(8, log.events.size)
    }

    /** Guards: a full disk stops the recording with a reason instead of throwing on a sensor thread. */
    @Test
    fun anIoErrorStopsWritingWithAReason() {
        val failing = object : Writer() {
            var n = 0
            override fun write(cbuf: CharArray, off: Int, len: Int) {
                n += len
                if (n > 200) throw IOException("no space left on device")
            }
            override fun flush() = Unit
            override fun close() = Unit
        }
        val w = SurveyLogWriter(failing)
        repeat(100) { w.sensor(1, it.toLong(), doubleArrayOf(0.1, 0.2, 9.8)) }
        assertNotNull(w.failure)
        assertTrue(w.failure!!.contains("no space left"), w.failure)
        assertTrue(w.counts().sensorSamples < 100)
        w.mark(SurveyMark(1, 0.0, 0.0, 0)) // ignored, no throw
        w.close()
    }

    /** Guards: a mark at a non-finite position is a caller's bug, not a TRUTH row calibrate would choke on. */
    @Test
    fun aNonFiniteMarkIsRefused() {
        val w = SurveyLogWriter(StringWriter())
        assertThrows<IllegalArgumentException> { w.mark(SurveyMark(1, Double.NaN, 0.0, 0)) }
        assertEquals(0L, w.counts().marks)
    }

    /** Guards: a v1 file carries no WiFi (the Rust reader would refuse the line). */
    @Test
    fun aV1WriterSkipsWifiScans() {
        val out = StringWriter()
        NativeLogWriter(out, emptyMap(), 1).use { w ->
            assertEquals(-1, w.wifi(5, arrayOf("aa:bb:cc:dd:ee:01"), doubleArrayOf(-50.0), intArrayOf(2412), longArrayOf(5)))
            assertEquals(1L, w.skipped)
        }
        val log = read(out.toString())
        assertEquals(1, log.version)
        assertTrue(log.events.isEmpty())
        assertThrows<IllegalArgumentException> { read("#fpbp-log 1\n5 WIFI 0\n") }
    }
}
