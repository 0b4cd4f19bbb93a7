package io.fpbp

import org.junit.jupiter.api.Tag
import org.junit.jupiter.api.Test

/**
 * Per-call overhead of onSensor and getPose through JNI (a simple loop
 * benchmark, run by hand: `host-tests/jvm/run.sh --bench`). Prints figures;
 * asserts nothing about time.
 */
@Tag("bench")
class JniOverheadBench {
    private fun measure(label: String, calls: Int, body: (Int) -> Unit) {
        repeat(3) { for (i in 0 until calls / 10) body(i) } // warm-up
        val runs = (1..5).map {
            val t0 = System.nanoTime()
            for (i in 0 until calls) body(i)
            (System.nanoTime() - t0).toDouble() / calls
        }.sorted()
        println("bench %-34s median %7.1f ns/call (min %.1f, max %.1f; %d calls x 5)".format(label, runs[2], runs[0], runs[4], calls))
    }

    @Test
    fun perCallOverhead() {
        TestSupport.startOpen().use { e ->
            val h = e.handle
            val v = doubleArrayOf(0.1, 0.2, 9.81)
            val out = DoubleArray(NativeBridge.POSE_LEN)
            val outT = LongArray(1)
            var t = 1_000_000_000L
            measure("taskPeriodNs (bridge fixed cost)", 2_000_000) { NativeBridge.taskPeriodNs(h, 1) }
            measure("onSensor(ACC) NativeBridge", 2_000_000) { NativeBridge.onSensor(h, 1, t++, v) }
            measure("onSensor(GYR) NativeBridge", 2_000_000) { NativeBridge.onSensor(h, 4, t++, v) }
            measure("onSensor(ACC) FpbpEngine FloatArray", 1_000_000) { e.onSensor(1, t++, floatArrayOf(0.1f, 0.2f, 9.81f)) }
            e.runFusion(t)
            measure("getPose NativeBridge (reused array)", 2_000_000) { NativeBridge.getPose(h, out, outT) }
            measure("getPose FpbpEngine (Pose object)", 1_000_000) { e.pose() }
            measure("onBleScan NativeBridge", 500_000) { NativeBridge.onBleScan(h, t++, "mac:00:00:00:00:00:01", -70.0, -59.0) }
            println("bench engine `${e.engineName}`, stats ${e.statsJson()}")
        }
    }
}
