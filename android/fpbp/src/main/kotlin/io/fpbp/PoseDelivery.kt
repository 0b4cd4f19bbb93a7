package io.fpbp

import kotlinx.coroutines.channels.Channel
import kotlinx.coroutines.channels.awaitClose
import kotlinx.coroutines.flow.Flow
import kotlinx.coroutines.flow.buffer
import kotlinx.coroutines.flow.callbackFlow
import java.util.concurrent.CopyOnWriteArrayList
import java.util.concurrent.Executor

/**
 * How often a listener wants poses.
 *
 * A pose is delivered when it changed (any field but its time) and at least
 * [minUpdateIntervalMs] passed since the last delivery, or when [intervalMs]
 * passed since the last delivery (the latest pose again, so its age shows).
 * Nothing is delivered before the first fix.
 *
 * @property intervalMs longest gap between deliveries while a pose exists.
 * @property minUpdateIntervalMs shortest gap between deliveries.
 */
data class PoseRequest @JvmOverloads constructor(
    val intervalMs: Long = DEFAULT_INTERVAL_MS,
    val minUpdateIntervalMs: Long = DEFAULT_MIN_UPDATE_INTERVAL_MS,
) {
    init {
        require(intervalMs > 0) { "intervalMs must be > 0, got $intervalMs" }
        require(minUpdateIntervalMs in 0..intervalMs) {
            "minUpdateIntervalMs must be in [0, intervalMs = $intervalMs], got $minUpdateIntervalMs"
        }
    }

    companion object {
        /** Default [intervalMs]: one pose a second while standing still. */
        const val DEFAULT_INTERVAL_MS: Long = 1000

        /** Default [minUpdateIntervalMs]: the default fusion period (`tasks.fusion_period_ms` = 200). */
        const val DEFAULT_MIN_UPDATE_INTERVAL_MS: Long = 200

        /** The default request. */
        @JvmField
        val DEFAULT = PoseRequest()
    }
}

/** Receives poses on the executor it was registered with. */
fun interface PoseListener {
    fun onPose(pose: Pose)
}

/** A registration with [PoseDispatcher.add]; [remove] stops further deliveries. */
interface PoseSubscription {
    fun remove()
}

/**
 * Decides, for each registered listener, when a pose is delivered
 * ([PoseRequest]) and hands it to the listener's [Executor]. Plain JVM:
 * [offer] is called with the latest pose after every task run, after a
 * `setPosition` and on a heartbeat; [clock] is the poses' clock.
 *
 * [offer] never throws for a listener: an executor that refuses the
 * delivery (`RejectedExecutionException`, or any exception from `execute`)
 * or a listener that throws is counted in [faults] and handed to [onFault]
 * (on the thread it happened on); the other listeners still get the pose,
 * and that listener the next one.
 */
class PoseDispatcher @JvmOverloads constructor(
    private val clock: Clock,
    private val onFault: ((Throwable) -> Unit)? = null,
) {
    private inner class Sub(
        val request: PoseRequest,
        val executor: Executor,
        val listener: PoseListener,
    ) : PoseSubscription {
        @Volatile var active = true
        var lastDeliveredNs = Long.MIN_VALUE
        var last: Pose? = null

        override fun remove() {
            active = false
            subs.remove(this)
        }
    }

    private val subs = CopyOnWriteArrayList<Sub>()

    private val deliveries = java.util.concurrent.atomic.AtomicLong()

    /** Deliveries handed to executors so far (all listeners). */
    val delivered: Long get() = deliveries.get()

    private val faultCount = java.util.concurrent.atomic.AtomicLong()

    /** Deliveries an executor refused or a listener threw from, so far. */
    val faults: Long get() = faultCount.get()

    /** Registered listeners. */
    val size: Int get() = subs.size

    /** Registers [listener]; its poses run on [executor]. */
    fun add(request: PoseRequest, executor: Executor, listener: PoseListener): PoseSubscription =
        Sub(request, executor, listener).also { subs.add(it) }

    /** Shortest [PoseRequest.minUpdateIntervalMs] of the listeners (heartbeat period), null without any. */
    fun shortestIntervalMs(): Long? = subs.minOfOrNull { it.request.minUpdateIntervalMs.coerceAtLeast(1) }

    /** Offers the latest pose (null before a fix) to every listener. */
    fun offer(pose: Pose?) {
        if (pose == null) return
        val now = clock.nowNs()
        for (s in subs) {
            val due = synchronized(s) {
                val since = if (s.lastDeliveredNs == Long.MIN_VALUE) Long.MAX_VALUE else now - s.lastDeliveredNs
                val changed = !pose.sameEstimate(s.last)
                val go = (changed && since >= s.request.minUpdateIntervalMs * 1_000_000) ||
                    since >= s.request.intervalMs * 1_000_000
                if (go) {
                    s.lastDeliveredNs = now
                    s.last = pose
                }
                go
            }
            if (due) {
                deliveries.incrementAndGet()
                try {
                    s.executor.execute {
                        try {
                            if (s.active) s.listener.onPose(pose)
                        } catch (e: Exception) {
                            fault(e)
                        }
                    }
                } catch (e: Exception) {
                    fault(e)
                }
            }
        }
    }

    private fun fault(e: Exception) {
        faultCount.incrementAndGet()
        try {
            onFault?.invoke(e)
        } catch (_: Exception) {
            // the report must not fail the delivery either
        }
    }

    /** Forgets every listener. */
    fun clear() {
        for (s in subs) s.active = false
        subs.clear()
    }

    /**
     * The poses of [request] as a cold [Flow]: collecting registers a
     * listener, cancelling removes it. Conflated: a slow collector gets the
     * latest pose, never a backlog.
     */
    fun flow(request: PoseRequest = PoseRequest.DEFAULT): Flow<Pose> = callbackFlow {
        val sub = add(request, { it.run() }) { trySend(it) }
        awaitClose { sub.remove() }
    }.buffer(Channel.CONFLATED)
}
