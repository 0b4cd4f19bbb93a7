package io.fpbp

import java.io.File
import java.time.Duration
import org.junit.jupiter.api.Assertions.assertTimeoutPreemptively
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows
import org.junit.jupiter.api.function.ThrowingSupplier

/**
 * Issue 20's reproducers through the JNI surface: each used to hang `start`
 * (or the handle behind it) or abort the JVM; each now throws
 * IllegalArgumentException naming the field. The timeout is a watchdog that
 * turns a hang into a failure (a clean error takes microseconds), not a speed
 * limit; native memory is measured by rust/core/tests/input_bounds.rs.
 */
class InputBoundsTest {
    private val site = TestSupport.openSiteJson
    private val dir = TestSupport.repo.path

    private fun refused(siteJson: String, config: String, init: DoubleArray?, vararg parts: String) {
        val e: IllegalArgumentException = assertTimeoutPreemptively(
            Duration.ofSeconds(10),
            ThrowingSupplier {
                assertThrows<IllegalArgumentException> {
                    NativeBridge.start(siteJson, dir, config, "fpbp", init, null)
                }
            },
        )
        val m = e.message ?: ""
        for (p in parts) assertTrue(m.contains(p), "message `$m` should mention `$p`")
        assertTrue(m.length < 1000, "message of ${m.length} characters")
    }

    private fun floor(f: String) = site.replace(
        "{ \"id\": 0, \"name\": \"ground\", \"open_area_m\": [20.0, 12.0], \"pixels_per_meter\": 10.0 }",
        f,
    )

    @Test
    fun tinyResolutionIsRefused() =
        refused(floor("{\"id\":0,\"open_area_m\":[10,10],\"pixels_per_meter\":1e-300}"), "", null, "floors[0].pixels_per_meter")

    @Test
    fun tinyGridIntervalsAreRefused() {
        for (v in listOf("1e-6", "0.001")) {
            refused(site.replaceFirst("\"floors\"", "\"grid_interval_m\": $v, \"floors\""), "", null, "grid_interval_m")
        }
    }

    @Test
    fun hugeOpenFloorsAreRefused() {
        for (side in listOf(2000, 1000)) {
            refused(
                floor("{\"id\":0,\"open_area_m\":[$side,$side],\"pixels_per_meter\":10}"), "", null,
                "floors[0].open_area_m", "over the limit",
            )
        }
    }

    @Test
    fun unboundedConfigWorkIsRefused() {
        refused(site, "{\"prox_pf\":{\"raycast_step_m\":1e-300}}", null, "prox_pf.raycast_step_m")
        refused(site, "{\"ekf\":{\"fingerprint\":{\"ap_iterations\":1000000000}}}", null, "ekf.fingerprint.ap_iterations")
        refused(site, "{\"ekf\":{\"fingerprint\":{\"grid_step_m\":1e-300}}}", null, "ekf.fingerprint.grid_step_m")
    }

    @Test
    fun startPositionsOffTheSiteAreRefused() {
        refused(site, "", doubleArrayOf(-1.58e274, 5.0, -2147483647.0, Double.NaN), "initial_position.floor")
        refused(site, "", doubleArrayOf(-1.58e274, 5.0, 0.0, Double.NaN), "outside floor 0")
        refused(site, "", doubleArrayOf(5.0, Double.POSITIVE_INFINITY, 0.0, Double.NaN), "must be finite")
    }

    @Test
    fun aPlanThatIsAFifoIsRefusedWithoutBlocking() {
        val d = File(System.getProperty("java.io.tmpdir"), "fpbp-fifo-${ProcessHandle.current().pid()}")
        d.mkdirs()
        val fifo = File(d, "plan.png")
        fifo.delete()
        val made = runCatching { ProcessBuilder("mkfifo", fifo.path).start().waitFor() == 0 }.getOrDefault(false)
        if (!made) {
            println("skipped: mkfifo not available")
            return
        }
        val withPlan = site.replace(
            "\"open_area_m\": [20.0, 12.0]",
            "\"plan\": \"${fifo.path}\"",
        )
        refused(withPlan, "", null, "not a regular file")
        fifo.delete()
        d.delete()
    }
}
