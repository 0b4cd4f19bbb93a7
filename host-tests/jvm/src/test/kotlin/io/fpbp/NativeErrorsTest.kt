package io.fpbp

import org.junit.jupiter.api.Assertions.assertDoesNotThrow
import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows

/** (c) Bad input throws IllegalArgumentException, stale handles IllegalStateException, and nothing crashes. */
class NativeErrorsTest {
    private val site = TestSupport.openSiteJson
    private val dir = TestSupport.repo.path

    private fun assertMessage(e: Throwable, vararg parts: String) {
        val m = e.message ?: ""
        for (p in parts) assertTrue(m.contains(p), "message `$m` should mention `$p`")
    }

    @Test
    fun badSiteJsonNamesLineAndColumn() {
        val e = assertThrows<IllegalArgumentException> {
            NativeBridge.start("{ \"format\": ", dir, "", TestSupport.engine, null, null)
        }
        assertMessage(e, "site.json", "line 1")
    }

    @Test
    fun siteJsonWithAnUnknownFieldIsRejected() {
        val bad = site.replaceFirst("\"name\": \"host-test open floor\"", "\"name\": \"x\", \"colour\": 3")
        val e = assertThrows<IllegalArgumentException> { NativeBridge.start(bad, dir, "", TestSupport.engine, null, null) }
        assertMessage(e, "colour")
    }

    @Test
    fun badConfigJsonNamesTheField() {
        val e = assertThrows<IllegalArgumentException> {
            NativeBridge.start(site, dir, "{\"tasks\": {\"radio_period_ms\": 0}}", TestSupport.engine, null, null)
        }
        assertMessage(e, "tasks.radio_period_ms")
        val e2 = assertThrows<IllegalArgumentException> {
            NativeBridge.start(site, dir, "{\"no_such_field\": 1}", TestSupport.engine, null, null)
        }
        assertMessage(e2, "no_such_field")
    }

    @Test
    fun aLongEchoedInputIsClippedAndItsLengthGiven() {
        val name = "e".repeat(100_000)
        val e = assertThrows<IllegalArgumentException> { NativeBridge.start(site, dir, "", name, null, null) }
        val m = e.message ?: ""
        assertTrue(m.length < 1_000, "message of ${m.length} chars")
        assertMessage(e, "(100000 chars)", "fpbp")
        val bad = site.replaceFirst("\"name\": \"host-test open floor\"", "\"name\": \"x\", \"${"k".repeat(50_000)}\": 3")
        val e2 = assertThrows<IllegalArgumentException> { NativeBridge.start(bad, dir, "", TestSupport.engine, null, null) }
        assertTrue((e2.message ?: "").length < 3_000, "message of ${e2.message?.length} chars")
        assertMessage(e2, "(50000 chars)")
    }

    @Test
    fun unknownEngineListsTheKnownOnes() {
        val e = assertThrows<IllegalArgumentException> { NativeBridge.start(site, dir, "", "no-such-engine", null, null) }
        assertMessage(e, "no-such-engine")
        for (name in TestSupport.engines) assertMessage(e, name)
    }

    @Test
    fun missingPlanNamesTheFile() {
        val withPlan = site.replace("\"open_area_m\": [20.0, 12.0]", "\"plan\": \"no/such/plan.png\"")
        val e = assertThrows<IllegalArgumentException> { NativeBridge.start(withPlan, dir, "", TestSupport.engine, null, null) }
        assertMessage(e, "plan.png")
    }

    @Test
    fun badInitialPositionIsRejected() {
        assertThrows<IllegalArgumentException> { NativeBridge.start(site, dir, "", TestSupport.engine, doubleArrayOf(1.0, 2.0), null) }
        assertThrows<IllegalArgumentException> {
            NativeBridge.start(site, dir, "", TestSupport.engine, doubleArrayOf(1.0, 2.0, 0.5, Double.NaN), null)
        }
    }

    @Test
    fun aPanicBecomesFpbpNativeExceptionAndTheLibraryKeepsWorking() {
        val e = assertThrows<FpbpNativeException> { NativeSelfTest.selfTestPanic() }
        assertMessage(e, "selfTestPanic", "self-test panic")
        TestSupport.startOpen().use { assertTrue(it.statsJson().contains("\"sensor_events\":0")) }
    }

    @Test
    fun neverIssuedHandlesThrowIllegalState() {
        val out = DoubleArray(NativeBridge.POSE_LEN)
        for (h in listOf(0L, -1L, Long.MAX_VALUE)) {
            assertThrows<IllegalStateException> { NativeBridge.onSensor(h, 1, 0, doubleArrayOf(0.0, 0.0, 9.8)) }
            assertThrows<IllegalStateException> { NativeBridge.onBleScan(h, 0, "mac:00:00:00:00:00:01", -70.0, Double.NaN) }
            assertThrows<IllegalStateException> { NativeBridge.runRadio(h, 0) }
            assertThrows<IllegalStateException> { NativeBridge.runFusion(h, 0) }
            assertThrows<IllegalStateException> { NativeBridge.getPose(h, out, LongArray(1)) }
            assertThrows<IllegalStateException> { NativeBridge.setPosition(h, 0, doubleArrayOf(1.0, 1.0, 0.0, Double.NaN)) }
            assertThrows<IllegalStateException> { NativeBridge.onWifiScan(h, 0, arrayOf("aa:bb:cc:dd:ee:ff"), doubleArrayOf(-60.0), intArrayOf(2412), longArrayOf(0)) }
            assertThrows<IllegalStateException> { NativeBridge.stats(h) }
            assertThrows<IllegalStateException> { NativeBridge.stop(h) }
        }
    }

    @Test
    fun stoppedHandleThrowsAndCloseIsIdempotent() {
        val e = TestSupport.startOpen()
        val h = e.handle
        e.close()
        e.close() // idempotent
        assertTrue(e.isClosed)
        val stale = assertThrows<IllegalStateException> { e.pose() }
        assertMessage(stale, "$h")
        assertThrows<IllegalStateException> { e.onSensor(1, 0, doubleArrayOf(0.0, 0.0, 9.8)) }
        assertThrows<IllegalStateException> { NativeBridge.stop(h) }
        // A new engine never gets the old handle back.
        TestSupport.startOpen().use { assertTrue(it.handle != h) }
    }

    @Test
    fun badSamplesAreCountedNotThrown() {
        TestSupport.startOpen().use { e ->
            assertDoesNotThrow {
                e.onSensor(1, 1_000, doubleArrayOf(0.0, 9.8)) // too few values
                e.onSensor(999, 2_000, doubleArrayOf(1.0, 2.0, 3.0)) // unknown type
                e.onSensor(4, 3_000, doubleArrayOf(Double.NaN, 0.0, 0.0)) // non-finite
                NativeBridge.onSensor(e.handle, 1, 4_000, null) // no array
                NativeBridge.onBleScan(e.handle, 5_000, null, -70.0, Double.NaN) // no id
                e.onGnss(6_000, Double.NaN, 0.0)
            }
            val stats = e.statsJson()
            assertTrue(stats.contains("\"bridge_rejected\":6"), stats)
        }
    }

    @Test
    fun shortPoseArrayAndBadTaskCodeAreIllegalArguments() {
        TestSupport.startOpen().use { e ->
            assertThrows<IllegalArgumentException> { NativeBridge.getPose(e.handle, DoubleArray(NativeBridge.POSE_LEN - 1), LongArray(1)) }
            assertThrows<IllegalArgumentException> { NativeBridge.getPose(e.handle, DoubleArray(NativeBridge.POSE_LEN), LongArray(0)) }
            assertThrows<IllegalArgumentException> { NativeBridge.taskPeriodNs(e.handle, 7) }
        }
    }

    @Test
    fun taskPeriodsComeFromTheConfig() {
        val cfg = "{\"tasks\": {\"radio_period_ms\": 700, \"fusion_period_ms\": 150}}"
        FpbpEngine.start(site, dir, TestSupport.engine, cfg, InitialPosition(10.0, 6.0, 0)).use { e ->
            val periods = listOf(e.radioPeriodNs, e.fusionPeriodNs)
            // An engine may lack a task (period 0); the ones it has follow the config.
            assertTrue(periods.all { it == 0L || it == 700_000_000L || it == 150_000_000L }, "$periods")
            assertTrue(periods.any { it > 0 }, "engine has no periodic task: $periods")
            if (TestSupport.engine == "fpbp") assertEquals(listOf(700_000_000L, 150_000_000L), periods)
        }
    }
}
