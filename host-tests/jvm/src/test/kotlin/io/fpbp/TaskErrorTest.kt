package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertSame
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import java.util.concurrent.CountDownLatch
import java.util.concurrent.TimeUnit
import java.util.concurrent.atomic.AtomicInteger
import java.util.concurrent.atomic.AtomicReference

/** A task that throws stops both tasks and reaches [TaskScheduler]'s onError once (the facade's FAILED status). */
class TaskErrorTest {
    @Test
    fun theFirstTaskErrorIsReportedOnce() {
        // guards: lastError kept but never reported: poses just stopped
        TestSupport.startOpen().use { e ->
            val boom = RuntimeException("boom")
            val reported = AtomicReference<Throwable?>(null)
            val reports = AtomicInteger()
            val latch = CountDownLatch(1)
            val s = TaskScheduler(e, Clock { System.nanoTime() }, afterTask = { throw boom })
            s.onError = { t ->
                reports.incrementAndGet()
                reported.set(t)
                latch.countDown()
            }
            assertTrue(latch.await(30, TimeUnit.SECONDS), "no error reported")
            s.close()
            assertSame(boom, reported.get())
            assertSame(boom, s.lastError)
            // reported once in all: a listener set later does not hear it again
            val late = AtomicReference<Throwable?>(null)
            s.onError = { late.set(it) }
            assertEquals(null, late.get(), "the error was already reported")
            assertEquals(1, reports.get())
        }
    }
}
