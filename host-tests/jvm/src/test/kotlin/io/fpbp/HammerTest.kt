package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import java.util.concurrent.ConcurrentLinkedQueue
import java.util.concurrent.CountDownLatch
import java.util.concurrent.atomic.AtomicBoolean
import java.util.concurrent.atomic.AtomicLong
import kotlin.math.cos
import kotlin.math.sin

/**
 * (b) Hammer: a sensor thread at full speed, a BLE thread, the GML and fusion
 * tasks in tight loops and a getPose reader, all on one handle for a bounded
 * time; plus start/stop churn on other handles while they run. Checks: no
 * exception, every pose finite, counters equal what was sent.
 */
class HammerTest {
    private val durationMs = (System.getProperty("fpbp.hammer.ms") ?: "3000").toLong()

    @Test
    fun fourThreadsAndAReaderStayConsistent() {
        val engine = TestSupport.startOpen()
        val clock = AtomicLong(1_000_000_000L)
        val stopFlag = AtomicBoolean(false)
        val errors = ConcurrentLinkedQueue<Throwable>()
        val sensorsSent = AtomicLong()
        val bleSent = AtomicLong()
        val posesRead = AtomicLong()
        val taskRuns = AtomicLong()
        val badPoses = ConcurrentLinkedQueue<Pose>()
        val start = CountDownLatch(1)

        fun worker(name: String, body: () -> Unit) = Thread({
            start.await()
            try {
                while (!stopFlag.get()) body()
            } catch (t: Throwable) {
                errors.add(t)
            }
        }, name)

        var i = 0L
        val threads = listOf(
            worker("sensor") {
                val t = clock.addAndGet(5_000_000L) // 200 Hz of log time per call
                val phase = (t / 5_000_000L) * 0.157
                engine.onSensor(1, t, doubleArrayOf(0.3 * sin(phase), 0.2, 9.81 + 1.5 * sin(phase)))
                engine.onSensor(4, t, doubleArrayOf(0.01, -0.02, 0.05 * cos(phase)))
                engine.onSensor(11, t, doubleArrayOf(0.0, 0.0, sin(0.1), cos(0.1)))
                sensorsSent.addAndGet(3)
            },
            worker("ble") {
                val t = clock.get()
                val b = TestSupport.openSiteBeacons[(i++ % 4).toInt()]
                engine.onBleScan(t, b, -60.0 - (t / 1_000_000L % 20), -59.0)
                bleSent.incrementAndGet()
                Thread.sleep(0, 200_000)
            },
            worker("gml") { engine.runRadio(clock.get()); taskRuns.incrementAndGet() },
            worker("fusion") { engine.runFusion(clock.get()); taskRuns.incrementAndGet() },
            worker("ui") {
                engine.pose()?.let { p ->
                    posesRead.incrementAndGet()
                    if (!(p.xM.isFinite() && p.yM.isFinite() && p.headingRad.isFinite() && p.accuracyM.isFinite())) badPoses.add(p)
                }
            },
        )
        // Start/stop churn on other handles while the hammer runs: a stale
        // handle may only throw IllegalStateException.
        val churn = Thread({
            start.await()
            try {
                while (!stopFlag.get()) {
                    val other = TestSupport.startOpen()
                    val racer = Thread {
                        try {
                            repeat(10_000) { other.onSensor(1, 1, doubleArrayOf(0.0, 0.0, 9.8)) }
                        } catch (_: IllegalStateException) {
                            // expected once stop() wins the race
                        } catch (t: Throwable) {
                            errors.add(t)
                        }
                    }
                    racer.start()
                    other.close()
                    racer.join()
                }
            } catch (t: Throwable) {
                errors.add(t)
            }
        }, "churn")
        (threads + churn).forEach { it.start() }
        start.countDown()
        Thread.sleep(durationMs)
        stopFlag.set(true)
        (threads + churn).forEach { it.join(10_000) }

        assertTrue(errors.isEmpty(), "exceptions: ${errors.map { "${it.javaClass.name}: ${it.message}" }.take(5)}")
        assertTrue(badPoses.isEmpty(), "non-finite poses: ${badPoses.take(5)}")
        val stats = engine.statsJson()
        fun stat(key: String) = Regex("\"$key\":(\\d+)").find(stats)?.groupValues?.get(1)?.toLong() ?: -1
        assertEquals(sensorsSent.get(), stat("sensor_events"), stats)
        assertEquals(bleSent.get(), stat("ble_observations"), stats)
        assertEquals(0, stat("bridge_rejected"), stats)
        println(
            "hammer ${durationMs} ms on `${engine.engineName}`: ${sensorsSent.get()} sensor calls, ${bleSent.get()} BLE, " +
                "${taskRuns.get()} task runs, ${posesRead.get()} poses read; stats $stats",
        )
        engine.close()
    }

    @Test
    fun scheduledTasksRunOnTheirExecutorsAtTheirPeriodsAndStopCleanly() {
        val cfg = "{\"tasks\": {\"radio_period_ms\": 50, \"fusion_period_ms\": 10}}"
        FpbpEngine.start(TestSupport.openSiteJson, TestSupport.repo.path, TestSupport.engine, cfg, InitialPosition(10.0, 6.0, 0)).use { e ->
            val t0 = System.nanoTime()
            val clock = Clock { System.nanoTime() - t0 + 1_000_000_000L }
            val scheduler = TaskScheduler(e, clock)
            var k = 0
            while (System.nanoTime() - t0 < 1_000_000_000L) {
                val t = clock.nowNs()
                e.onSensor(1, t, doubleArrayOf(0.0, 0.3 * sin(k * 0.3), 9.81 + 2 * sin(k * 0.3)))
                if (k % 10 == 0) e.onBleScan(t, TestSupport.openSiteBeacons[k / 10 % 4], -65.0, null)
                k++
                Thread.sleep(2)
            }
            val elapsedS = (System.nanoTime() - t0) / 1e9
            scheduler.close()
            val (gml, fusion) = scheduler.radioRuns to scheduler.fusionRuns
            Thread.sleep(100)
            assertEquals(gml to fusion, scheduler.radioRuns to scheduler.fusionRuns, "tasks ran after close()")
            assertEquals(null, scheduler.lastError)
            println("scheduler: ${"%.2f".format(elapsedS)} s -> $gml radio task runs (period 50 ms), $fusion fusion runs (period 10 ms)")
            // Fixed-rate executors on a loaded 2-core machine: at least a third of the nominal count.
            if (e.radioPeriodNs > 0) assertTrue(gml >= (elapsedS / 0.05 / 3).toLong() && gml <= (elapsedS / 0.05 + 2).toLong(), "radio task runs $gml")
            if (e.fusionPeriodNs > 0) assertTrue(fusion >= (elapsedS / 0.01 / 3).toLong() && fusion <= (elapsedS / 0.01 + 2).toLong(), "fusion runs $fusion")
        }
    }
}
