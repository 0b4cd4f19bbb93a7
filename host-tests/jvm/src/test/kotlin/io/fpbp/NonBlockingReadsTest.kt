package io.fpbp

import org.junit.jupiter.api.AfterEach
import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import java.util.concurrent.Executors
import java.util.concurrent.TimeUnit

/**
 * getPose, getBlePosition, stats and taskPeriodNs return while a task is
 * blocked inside the engine (the self-test engine waits at a gate holding the
 * engine lock). If a read waited on that lock it would not return before the
 * gate opens, and the 20 s deadlock guard below would fail the test.
 */
class NonBlockingReadsTest {
    private val pool = Executors.newCachedThreadPool()

    @AfterEach
    fun tearDown() {
        NativeSelfTest.selfTestGate(true)
        pool.shutdownNow()
    }

    @Test
    fun readsReturnWhileATaskIsBlocked() {
        val h = NativeSelfTest.selfTestStartBlocking()
        try {
            NativeSelfTest.selfTestGate(false)
            val task = pool.submit { NativeBridge.runFusion(h, 42) }
            val deadline = System.nanoTime() + TimeUnit.SECONDS.toNanos(20)
            while (NativeSelfTest.selfTestBlockedTasks() < 1 && System.nanoTime() < deadline) Thread.sleep(1)
            assertEquals(1, NativeSelfTest.selfTestBlockedTasks(), "the task never reached the gate")

            val out = DoubleArray(NativeBridge.POSE_LEN)
            val t = LongArray(1)
            val reads = pool.submit<List<Any>> {
                listOf(
                    NativeBridge.getPose(h, out, t),
                    t[0],
                    NativeBridge.getBlePosition(h, DoubleArray(NativeBridge.POSE_LEN), LongArray(1)),
                    NativeBridge.stats(h),
                    NativeBridge.taskPeriodNs(h, NativeBridge.TASK_FUSION),
                )
            }
            val r = reads.get(20, TimeUnit.SECONDS) // throws TimeoutException if a read waited for the task
            assertEquals(1, NativeSelfTest.selfTestBlockedTasks(), "the task finished before the reads: nothing shown")
            assertEquals(true, r[0])
            assertEquals(1L, r[1], "the pose published before the blocked task")
            assertEquals(true, r[2])
            assertTrue((r[3] as String).contains("self-test-blocking"))
            assertEquals(100_000_000L, r[4])

            NativeSelfTest.selfTestGate(true)
            task.get(20, TimeUnit.SECONDS)
            assertTrue(NativeBridge.getPose(h, out, t))
            assertEquals(42L, t[0], "the pose after the task")
            assertEquals(1.0, out[NativeBridge.POSE_X_M])
        } finally {
            NativeSelfTest.selfTestGate(true)
            NativeBridge.stop(h)
        }
    }

    @Test
    fun noPoseIsAStatusNotATime() {
        TestSupport.startOpen("gml").use { e ->
            val t = LongArray(1) { 7 }
            val out = DoubleArray(NativeBridge.POSE_LEN) { -1.0 }
            assertEquals(false, NativeBridge.getPose(e.handle, out, t))
            assertEquals(7L, t[0], "time written without a pose")
            assertTrue(out.all { it == -1.0 }, "pose written without a pose")
            assertEquals(null, e.pose())
            // Long.MIN_VALUE is an ordinary time now: a pose set at it is reported at it.
            e.setPosition(Long.MIN_VALUE, InitialPosition(3.0, 4.0, 0))
            assertEquals(Long.MIN_VALUE, e.pose()?.tNs)
        }
    }
}
