package io.fpbp

import java.util.concurrent.Executors
import java.util.concurrent.ScheduledExecutorService
import java.util.concurrent.ThreadFactory
import java.util.concurrent.TimeUnit
import java.util.concurrent.atomic.AtomicBoolean
import java.util.concurrent.atomic.AtomicLong
import java.util.concurrent.atomic.AtomicReference

/**
 * The radio task (BLE and WiFi; in the FP-BP paper the GML positioning over
 * the candidate grid) as a [Runnable]: each run calls the engine's radio task
 * at [clock]'s time. It meets [FusionTask] only inside the engine.
 */
class RadioTask(
    private val engine: FpbpEngine,
    private val clock: Clock,
    private val afterRun: (() -> Unit)? = null,
) : Runnable {
    override fun run() {
        engine.runRadio(clock.nowNs())
        afterRun?.invoke()
    }
}

/**
 * The fusion task (particle filter + post-position correction) as a
 * [Runnable]; after each run, [onPose] receives the latest pose (if any).
 */
class FusionTask(
    private val engine: FpbpEngine,
    private val clock: Clock,
    private val onPose: ((Pose) -> Unit)? = null,
) : Runnable {
    override fun run() {
        engine.runFusion(clock.nowNs())
        val listener = onPose ?: return
        engine.pose()?.let(listener)
    }
}

/**
 * Runs [RadioTask] and [FusionTask] on their own single-thread
 * [ScheduledExecutorService]s at the engine's periods (`tasks.radio_period_ms`,
 * `tasks.fusion_period_ms` of the config), as the paper's Runnables do.
 * [onPose] receives the latest pose after each fusion run; [afterTask] is
 * called after every run of either task (delivery checks: a BLE-only engine
 * has no fusion task).
 *
 * A task that throws is not rescheduled by its executor; the first such error
 * is kept in [lastError], both tasks stop and [onError] receives it once
 * (the Android facade turns it into [PositioningState.FAILED]). [close] stops
 * the executors and waits for a running task to end (call it before
 * [FpbpEngine.close]).
 */
class TaskScheduler @JvmOverloads constructor(
    private val engine: FpbpEngine,
    private val clock: Clock,
    onPose: ((Pose) -> Unit)? = null,
    afterTask: (() -> Unit)? = null,
) : AutoCloseable {
    private val radioExecutor: ScheduledExecutorService = Executors.newSingleThreadScheduledExecutor(named("fpbp-radio"))
    private val fusionExecutor: ScheduledExecutorService = Executors.newSingleThreadScheduledExecutor(named("fpbp-fusion"))
    private val error = AtomicReference<Throwable?>(null)
    private val reported = AtomicBoolean(false)

    @Volatile private var errorListener: ((Throwable) -> Unit)? = null

    /**
     * Receives the first error a task threw, once in all, on the failing
     * task's thread; set after an error no listener heard yet, it is called
     * at once on the setter's thread.
     */
    var onError: ((Throwable) -> Unit)?
        get() = errorListener
        set(value) {
            errorListener = value
            report()
        }

    private fun report() {
        val t = error.get() ?: return
        val listener = errorListener ?: return
        if (reported.compareAndSet(false, true)) listener(t)
    }

    private val radioCount = AtomicLong()
    private val fusionCount = AtomicLong()

    /** Completed runs of the radio task. */
    val radioRuns: Long get() = radioCount.get()

    /** Completed runs of the fusion task. */
    val fusionRuns: Long get() = fusionCount.get()

    /** The first error a task threw, if any. */
    val lastError: Throwable? get() = error.get()

    /** Period the radio task runs at, ns (0 = not scheduled). */
    val radioPeriodNs: Long = engine.radioPeriodNs

    /** Period the fusion task runs at, ns (0 = not scheduled). */
    val fusionPeriodNs: Long = engine.fusionPeriodNs

    init {
        schedule(radioExecutor, RadioTask(engine, clock, afterTask), radioPeriodNs, radioCount)
        val fusion = FusionTask(engine, clock, onPose)
        schedule(fusionExecutor, Runnable { fusion.run(); afterTask?.invoke() }, fusionPeriodNs, fusionCount)
    }

    private fun schedule(executor: ScheduledExecutorService, task: Runnable, periodNs: Long, runs: AtomicLong) {
        if (periodNs <= 0) return
        val guarded = Runnable {
            try {
                task.run()
                runs.incrementAndGet()
            } catch (t: Throwable) {
                error.compareAndSet(null, t)
                radioExecutor.shutdown()
                fusionExecutor.shutdown()
                report()
                throw t
            }
        }
        executor.scheduleAtFixedRate(guarded, periodNs, periodNs, TimeUnit.NANOSECONDS)
    }

    override fun close() {
        radioExecutor.shutdownNow()
        fusionExecutor.shutdownNow()
        radioExecutor.awaitTermination(5, TimeUnit.SECONDS)
        fusionExecutor.awaitTermination(5, TimeUnit.SECONDS)
    }

    private fun named(name: String) = ThreadFactory { r -> Thread(r, name).apply { isDaemon = true } }
}

/**
 * Drives the two tasks by a log's clock instead of the wall clock, with the
 * scheduling rule of rust/core/src/engine/replay.rs, so a JVM replay matches
 * the Rust replay exactly:
 *
 * task clocks start at the first event's time; before an event at `t` is
 * handed to the engine, every task whose next due time is <= `t` runs,
 * earliest first, radio before fusion on ties, with [clock] set to its due time,
 * and its due time advances by its period. [finish] runs what is due at the
 * last event's time. The pose after every task run that changed it is
 * appended to [track].
 */
class LogClockDriver(
    private val engine: FpbpEngine,
    private val clock: ManualClock = ManualClock(),
) {
    private val gml = RadioTask(engine, clock)
    private val fusion = FusionTask(engine, clock)
    private val periods = longArrayOf(engine.radioPeriodNs, engine.fusionPeriodNs)
    private val nextDue = arrayOfNulls<Long>(2)
    private var firstT: Long? = null
    private var lastT: Long? = null

    /** Poses after each task run that changed the pose (replay.rs `track`). */
    val track: MutableList<Pose> = ArrayList()

    /** Call before handing the engine an event at [tNs] (events in time order). */
    fun beforeEvent(tNs: Long) {
        if (firstT == null) {
            firstT = tNs
            for (i in 0..1) nextDue[i] = if (periods[i] > 0) tNs + periods[i] else null
        }
        runDue(tNs)
        lastT = lastT?.let { maxOf(it, tNs) } ?: tNs
    }

    /** Ends the replay: runs the tasks due at the last event's time. */
    fun finish() {
        lastT?.let { runDue(it) }
    }

    private fun runDue(t: Long) {
        while (true) {
            var best = -1
            var bestDue = 0L
            for (i in 0..1) {
                val due = nextDue[i] ?: continue
                if (due <= t && (best < 0 || due < bestDue)) {
                    best = i
                    bestDue = due
                }
            }
            if (best < 0) return
            val before = engine.pose()
            clock.set(bestDue)
            if (best == 0) gml.run() else fusion.run()
            val after = engine.pose()
            if (after != null && !samePoseIeee(after, before)) track.add(after)
            nextDue[best] = bestDue + (if (periods[best] > 0) periods[best] else Long.MAX_VALUE / 4)
        }
    }
}

/**
 * Pose equality as Rust's derived `PartialEq` on f64 (IEEE: NaN != NaN,
 * 0.0 == -0.0), unlike a data class's `equals`.
 */
internal fun samePoseIeee(a: Pose?, b: Pose?): Boolean {
    if (a == null || b == null) return a == null && b == null
    return a.tNs == b.tNs && a.xM == b.xM && a.yM == b.yM && a.floor == b.floor &&
        a.headingRad == b.headingRad && a.accuracyM == b.accuracyM &&
        a.floorProb == b.floorProb && a.source == b.source
}
