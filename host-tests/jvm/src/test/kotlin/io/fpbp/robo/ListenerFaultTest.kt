package io.fpbp.robo

import android.hardware.Sensor
import android.os.Looper
import io.fpbp.InitialPosition
import io.fpbp.Pose
import io.fpbp.PoseRequest
import io.fpbp.PositioningState
import io.fpbp.Problem
import io.fpbp.Status
import io.fpbp.android.FpbpPositioning
import org.junit.Assert.assertEquals
import org.junit.Assert.assertNotEquals
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.shadows.ShadowLog
import java.time.Duration
import java.util.concurrent.ConcurrentHashMap
import java.util.concurrent.CopyOnWriteArrayList
import java.util.concurrent.Executor
import java.util.concurrent.RejectedExecutionException
import java.util.concurrent.TimeUnit

/**
 * Issue 60, item 4: an app's failing callback is reported and contained,
 * never fatal to positioning. Before the fix a pose executor that refused
 * or a pose listener that threw on a task thread made the engine FAILED, a
 * throw on the tick thread ended the heartbeat and the status checks
 * silently, and a status executor that refused on the control thread ended
 * that thread (on a phone: the process).
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class ListenerFaultTest : OpenSitePositioningTest() {
    private val rejecting = Executor { throw RejectedExecutionException("queue full") }
    private val direct = Executor { it.run() }
    private val often = PoseRequest(intervalMs = 100, minUpdateIntervalMs = 0)

    @Test
    fun aPoseExecutorThatRefusesIsReportedAndPositioningGoesOn() {
        val p = startAt()
        val good = CopyOnWriteArrayList<Pose>()
        p.addPoseListener(often, rejecting) { }
        p.addPoseListener(often, direct) { good.add(it) }
        // on the control thread (setPosition), the task threads and the tick thread
        p.setPosition(10.0, 6.0, 0).get(30, TimeUnit.SECONDS)
        assertTrue("the other listener got ${good.size} poses", passUntil { good.size >= 10 })
        assertGoesOn(p, "pose listener: RejectedExecutionException: queue full")
    }

    @Test
    fun aPoseListenerThatThrowsOnAnyThreadIsContained() {
        val p = startAt()
        val threads = ConcurrentHashMap.newKeySet<String>()
        val good = CopyOnWriteArrayList<Pose>()
        p.addPoseListener(often, direct) {
            threads.add(Thread.currentThread().name)
            throw IllegalStateException("app bug")
        }
        p.addPoseListener(often, direct) { good.add(it) }
        p.setPosition(10.0, 6.0, 0).get(30, TimeUnit.SECONDS)
        // the throw reached the tick thread and a task thread
        assertTrue(
            "$threads",
            passUntil { "fpbp-tick" in threads && threads.any { it == "fpbp-fusion" || it == "fpbp-radio" } },
        )
        // the heartbeat is still alive: ticks go on, and so do the deliveries
        val ticks = p.ticks
        val delivered = good.size
        assertTrue("the ticker stopped at $ticks", passUntil { p.ticks >= ticks + 5 })
        assertTrue(passUntil { good.size > delivered })
        assertGoesOn(p, "pose listener: IllegalStateException: app bug")
    }

    @Test
    fun statusListenersThatFailNeverEndTheControlThread() {
        val p = startAt()
        val good = CopyOnWriteArrayList<Status>()
        // the first status is delivered on this thread, the next ones on the control thread
        p.addStatusListener(rejecting) { }
        p.addStatusListener(direct) { throw IllegalStateException("app bug") }
        p.addStatusListener(direct) { good.add(it) }
        p.pause().get(30, TimeUnit.SECONDS)
        p.resume().get(30, TimeUnit.SECONDS)
        assertTrue("$good", good.any { it.state == PositioningState.PAUSED })
        assertTrue(p.controlThread.isAlive)
        assertGoesOn(p, "status listener: RejectedExecutionException: queue full")
        assertTrue("$good", RoboSupport.idleUntil { good.last().problems.contains(Problem.LISTENER_FAULT) })
        // the control thread still works: stop completes and is published
        p.stop().get(30, TimeUnit.SECONDS)
        assertTrue(RoboSupport.idleUntil { good.last().state == PositioningState.STOPPED })
    }

    @Test
    fun completionCallbacksAndInputObserversThatFailAreCounted() {
        val p = startAt()
        p.start(rejecting) { } // already running: completes on the control thread at once
        assertTrue("${p.listenerFaults}", RoboSupport.idleUntil { p.listenerFaults == 1L })
        p.pause(direct) { throw IllegalStateException("callback bug") }
        assertTrue("${p.listenerFaults}", RoboSupport.idleUntil { p.listenerFaults == 2L })
        p.inputObserver = object : FpbpPositioning.InputObserver {
            override fun onSensor(type: Int, tNs: Long, values: DoubleArray) = throw IllegalStateException("observer bug")
        }
        p.onSensor(Sensor.TYPE_ACCELEROMETER, 1, doubleArrayOf(0.0, 0.0, 9.81))
        assertEquals(3L, p.listenerFaults)
        assertEquals("the failing observer is removed", null, p.inputObserver)
        p.resume().get(30, TimeUnit.SECONDS)
        assertGoesOn(p, "completion callback: RejectedExecutionException: queue full")
        // one log line for the first fault, not one per fault
        assertEquals(1, ShadowLog.getLogsForTag("fpbp").count { it.type == android.util.Log.WARN })
    }

    /**
     * Runs the main looper in steps of 100 ms of the Android clock (the
     * poses' clock: it stands still under Robolectric unless advanced) while
     * the library's threads run, until [done] or 10 s of wall time.
     */
    private fun passUntil(done: () -> Boolean): Boolean {
        val end = System.nanoTime() + TimeUnit.SECONDS.toNanos(10)
        while (System.nanoTime() < end) {
            shadowOf(Looper.getMainLooper()).idleFor(Duration.ofMillis(100))
            if (done()) return true
            Thread.sleep(20)
        }
        return done()
    }

    private fun startAt(): FpbpPositioning = start(FpbpPositioning.Options(initialPosition = InitialPosition(10.0, 6.0, 0, 0.0)))

    /** Positioning runs, the fault is counted and named in the status ([first]: the first fault). */
    private fun assertGoesOn(p: FpbpPositioning, first: String) {
        assertTrue(RoboSupport.idleUntil { Problem.LISTENER_FAULT in p.status.problems })
        assertTrue(p.isRunning)
        assertNotEquals(p.status.describe(), PositioningState.FAILED, p.status.state)
        assertTrue(p.listenerFaults > 0)
        assertEquals(first, p.status.messages[Problem.LISTENER_FAULT])
        assertTrue(p.status.describe(), p.status.describe().contains("listener fault ($first)"))
    }
}
