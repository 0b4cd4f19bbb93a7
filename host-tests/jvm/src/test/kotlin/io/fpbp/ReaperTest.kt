package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Test
import java.util.concurrent.CountDownLatch
import java.util.concurrent.TimeUnit
import java.util.concurrent.atomic.AtomicInteger

/** [Reaper] runs an action once for an object the program dropped, and at most once. */
class ReaperTest {
    @Test
    fun aDroppedObjectsActionRuns() {
        // guards: an action that never runs (a reference kept, no queue thread)
        val ran = CountDownLatch(1)
        registerDropped { ran.countDown() }
        var n = 0
        while (ran.count > 0 && n++ < 200) {
            System.gc()
            ran.await(50, TimeUnit.MILLISECONDS)
        }
        assertEquals(0L, ran.count, "the action of a dropped object did not run")
    }

    @Test
    fun cleanRunsTheActionOnce() {
        val runs = AtomicInteger()
        val keep = Any()
        val c = Reaper.register(keep) { runs.incrementAndGet() }
        c.clean()
        c.clean()
        assertEquals(1, runs.get())
        java.lang.ref.Reference.reachabilityFence(keep)
    }

    private fun registerDropped(action: Runnable) {
        Reaper.register(Any(), action)
    }
}
