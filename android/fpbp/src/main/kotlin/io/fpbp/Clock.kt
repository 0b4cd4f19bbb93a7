package io.fpbp

import java.util.concurrent.atomic.AtomicLong

/**
 * Where the tasks read "now" from, in nanoseconds on the clock the sensor and
 * BLE timestamps use (Android: `SystemClock.elapsedRealtimeNanos()`).
 */
fun interface Clock {
    fun nowNs(): Long
}

/** A clock set by hand: replays drive tasks by a log's clock with it. */
class ManualClock(startNs: Long = 0) : Clock {
    private val now = AtomicLong(startNs)

    override fun nowNs(): Long = now.get()

    /** Sets the time, ns. */
    fun set(tNs: Long) = now.set(tNs)
}
