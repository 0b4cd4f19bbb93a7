package io.fpbp

import kotlinx.coroutines.flow.take
import kotlinx.coroutines.flow.toList
import kotlinx.coroutines.runBlocking
import kotlinx.coroutines.withTimeout
import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import java.io.File
import java.util.concurrent.ConcurrentLinkedQueue
import java.util.zip.GZIPInputStream
import kotlin.math.floor

/** When poses are delivered (PoseRequest), through listeners and the Flow. */
class PoseDeliveryTest {
    private fun pose(t: Long, x: Double) = Pose(t, x, 0.0, 0, 0.0, 1.0)

    @Test
    fun deliveredWhenChangedOrWhenTheIntervalElapsed() {
        val clock = ManualClock(0)
        val d = PoseDispatcher(clock)
        val got = ArrayList<Pose>()
        val sub = d.add(PoseRequest(1000, 200), { it.run() }) { got.add(it) }
        d.offer(null)
        assertEquals(0, got.size, "delivered before a fix")
        d.offer(pose(0, 1.0))
        assertEquals(1, got.size, "first pose at once")
        clock.set(100_000_000)
        d.offer(pose(100_000_000, 2.0))
        assertEquals(1, got.size, "changed, but before minUpdateInterval")
        clock.set(200_000_000)
        d.offer(pose(200_000_000, 2.0))
        assertEquals(2, got.size, "changed and minUpdateInterval passed")
        for (k in 3..11) {
            clock.set(k * 100_000_000L)
            d.offer(pose(k * 100_000_000L, 2.0)) // same estimate, fresher time
        }
        assertEquals(2, got.size, "unchanged within the interval")
        clock.set(1_200_000_000)
        d.offer(pose(1_200_000_000, 2.0))
        assertEquals(3, got.size, "interval elapsed: delivered again")
        assertEquals(1_200_000_000, got.last().tNs)
        sub.remove()
        clock.set(5_000_000_000)
        d.offer(pose(5_000_000_000, 9.0))
        assertEquals(3, got.size, "delivered after remove")
        assertEquals(0, d.size)
    }

    @Test
    fun theFlowDeliversAndUnregistersOnCancel() = runBlocking {
        val clock = ManualClock(0)
        val d = PoseDispatcher(clock)
        val feeder = Thread {
            var k = 0L
            while (!Thread.currentThread().isInterrupted) {
                clock.set(k * 250_000_000)
                d.offer(pose(k * 250_000_000, k.toDouble()))
                k++
                try {
                    Thread.sleep(2)
                } catch (_: InterruptedException) {
                    return@Thread
                }
            }
        }
        feeder.start()
        val poses = withTimeout(20_000) { d.flow().take(3).toList() }
        feeder.interrupt()
        feeder.join()
        assertEquals(3, poses.size)
        assertTrue(poses.zipWithNext().all { (a, b) -> b.tNs > a.tNs })
        assertEquals(0, d.size, "the flow's listener outlived its collector")
    }

    /**
     * The delivery rate at the default request, measured on a shipped log
     * replayed through the real engine by the log's clock (deterministic:
     * the same log gives the same count). Printed for the closing note.
     */
    @Test
    fun deliveryRateAtTheDefaultRequestOnADemoWalk() {
        val log = File(TestSupport.repo, "host-tests/logs/demo-walk-1.log.gz")
        val site = TestSupport.demoSite
        if (!log.isFile || !site.isFile) error("missing $log or $site")
        val events = GZIPInputStream(log.inputStream()).bufferedReader().use { NativeLogReader.read(it) }.events
        val clock = ManualClock()
        val d = PoseDispatcher(clock)
        val got = ConcurrentLinkedQueue<Pose>()
        d.add(PoseRequest.DEFAULT, { it.run() }) { got.add(it) }
        FpbpEngine.start(site.readText(), site.parentFile.path, FpbpDefaults.ENGINE).use { e ->
            val driver = LogClockDriver(e, clock)
            var offers = 0
            val tickNs = 100_000_000L // the facade's heartbeat (FpbpPositioning.TICK_MS)
            var nextTick = events.first().tNs
            for (ev in events) {
                driver.beforeEvent(ev.tNs)
                while (nextTick <= ev.tNs) {
                    clock.set(nextTick)
                    d.offer(e.pose())
                    offers++
                    nextTick += tickNs
                }
                when (ev) {
                    is LogEvent.Sensor -> e.onSensor(ev.sensorType, ev.tNs, ev.values)
                    is LogEvent.Ble -> e.onBleScan(ev.tNs, ev.beaconId, ev.rssiDbm, ev.txPowerDbm)
                    else -> Unit
                }
            }
            val first = got.first().tNs
            val spanS = (events.last().tNs - first) / 1e9
            val rate = got.size / spanS
            val changes = driver.track.size / ((events.last().tNs - events.first().tNs) / 1e9)
            println(
                "delivery rate: ${log.name} on `${e.engineName}`, default request (interval ${PoseRequest.DEFAULT_INTERVAL_MS} ms, " +
                    "min ${PoseRequest.DEFAULT_MIN_UPDATE_INTERVAL_MS} ms), heartbeat $tickNs ns: ${got.size} poses in " +
                    "%.1f s of log time after the first fix = %.2f per s (engine pose changes %.2f per s, %d offers)".format(spanS, rate, changes, offers),
            )
            // Deterministic bounds of the rule (log clock, not wall clock).
            // deliveries at least the minimum interval apart over spanS: the
            // first at 0, so at most spanS / min + 1 of them
            val most = floor(spanS * 1000.0 / PoseRequest.DEFAULT_MIN_UPDATE_INTERVAL_MS).toInt() + 1
            assertTrue(got.size <= most, "${got.size} poses in $spanS s, at most $most (rate $rate)")
            assertTrue(rate >= 1000.0 / PoseRequest.DEFAULT_INTERVAL_MS * 0.9, "rate $rate")
            got.zipWithNext().forEach { (a, b) -> assertTrue(b.tNs >= a.tNs) }
        }
    }
}
