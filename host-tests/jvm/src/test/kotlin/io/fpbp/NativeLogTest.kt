package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows
import org.junit.jupiter.api.io.TempDir
import java.io.File
import java.io.StringReader
import java.util.Random
import java.util.concurrent.TimeUnit

/** The Kotlin native-log writer (used by the app's recorder and the survey) against the Rust reader and writer. */
class NativeLogTest {
    private fun randomEvents(seed: Long, n: Int): List<LogEvent> {
        val r = Random(seed)
        var t = 123_456_789_000L
        fun f() = (r.nextFloat() * 40 - 20).toDouble() // what SensorEvent.values widen to
        fun d() = r.nextGaussian() * 10.0.let { Math.pow(it, (r.nextInt(9) - 4).toDouble()) }
        return List(n) {
            t += r.nextInt(5_000_000)
            when (r.nextInt(10)) {
                0 -> LogEvent.Sensor(t, 1, doubleArrayOf(f(), f(), f()))
                1 -> LogEvent.Sensor(t, 4, doubleArrayOf(d(), d(), d()))
                2 -> LogEvent.Sensor(t, 2, doubleArrayOf(f(), f(), f()))
                3 -> LogEvent.Sensor(t, 11, doubleArrayOf(0.1 * f(), 0.01 * f(), 0.02 * f(), 0.5))
                4 -> LogEvent.Sensor(t, 15, doubleArrayOf(0.01 * f(), 0.01 * f(), 0.01 * f(), 0.9))
                5 -> LogEvent.Sensor(t, 6, doubleArrayOf(1013.25 + f()))
                6 -> LogEvent.Ble(t, "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:${r.nextInt(65536)}", -40.0 - r.nextInt(60), if (r.nextBoolean()) -59.0 else null)
                7 -> LogEvent.Gnss(t, 49.0 + r.nextDouble(), 11.0 + r.nextDouble(), if (r.nextBoolean()) d() else null, 5.0, null, d())
                8 -> LogEvent.Truth(t, d(), d(), if (r.nextBoolean()) -1 else null)
                // a WiFi scan (v2): 0-5 results, each last seen up to 3 s before it
                else -> LogEvent.Wifi(
                    t,
                    List(r.nextInt(6)) {
                        val mac = List(6) { "%02x".format(r.nextInt(256)) }.joinToString(":")
                        val freq = if (r.nextBoolean()) 2412 + 5 * r.nextInt(13) else 5180 + 20 * r.nextInt(8)
                        WifiResult(mac, -30.0 - r.nextInt(65), freq, t - r.nextInt(3_000_000))
                    },
                )
            }
        }
    }

    @Test
    fun kotlinWrittenLogParsesWithTheRustReaderToTheSameValues(@TempDir dir: File) {
        val bin = System.getProperty("fpbp.log_echo")?.let(::File)
        require(bin != null && bin.canExecute()) { "fpbp.log_echo (rust/jni/examples/log_echo) not built: run host-tests/jvm/run.sh" }
        val events = randomEvents(7, 3000)
        val kotlinLog = File(dir, "kotlin.log")
        NativeLogWriter(kotlinLog.bufferedWriter(), mapOf("device" to "host test", "seed" to "7")).use { w -> events.forEach(w::write) }
        val rustLog = File(dir, "rust.log")
        val p = ProcessBuilder(bin.path, kotlinLog.path, rustLog.path).redirectErrorStream(true).start()
        val out = p.inputStream.bufferedReader().readText()
        assertTrue(p.waitFor(60, TimeUnit.SECONDS))
        assertEquals(0, p.exitValue(), out)
        // Truth lines with `-` floor come back as `-` (no default floor given).
        val back = rustLog.bufferedReader().use { NativeLogReader.read(it) }.events
        assertEquals(events.size, back.size)
        for (i in events.indices) assertEquals(events[i], back[i], "event $i")
    }

    @Test
    fun rotationVectorWithoutWGetsTheSameWAsTheCore() {
        val sb = java.io.StringWriter()
        NativeLogWriter(sb).use { it.sensor(5, 11, doubleArrayOf(0.1, 0.2, 0.3)) }
        val ev = NativeLogReader.read(StringReader(sb.toString()).buffered()).events.single() as LogEvent.Sensor
        assertEquals(Math.sqrt(1.0 - 0.1 * 0.1 - 0.2 * 0.2 - 0.3 * 0.3), ev.values[3])
    }

    @Test
    fun readerNamesTheBadLine() {
        val text = "#fpbp-log 1\n1 ACC 0 0 9.8\n2 ACC 0 zero 9.8\n"
        val e = assertThrows<IllegalArgumentException> { NativeLogReader.read(StringReader(text).buffered()) }
        assertTrue(e.message!!.startsWith("line 3"), e.message)
    }
}
