package io.fpbp

import java.util.ArrayDeque

/**
 * At most [maxStarts] starts in any [windowMs] (Android: 5 BLE scan starts
 * per 30 s per app, beyond which results are withheld silently; 4 WiFi
 * `startScan` per 2 min in the foreground since Android 9). Plain JVM, by
 * [clock] (elapsedRealtime ns).
 */
class StartLimiter(private val maxStarts: Int, private val windowMs: Long, private val clock: Clock) {
    init {
        require(maxStarts > 0 && windowMs > 0) { "maxStarts and windowMs must be > 0" }
    }

    private val starts = ArrayDeque<Long>()

    /** 0 when a start is allowed now, else how long to wait for one, ms. */
    @Synchronized
    fun waitMs(): Long {
        val now = clock.nowNs()
        val window = windowMs * 1_000_000
        while (starts.isNotEmpty() && now - starts.peekFirst() >= window) starts.pollFirst()
        if (starts.size < maxStarts) return 0
        return (starts.peekFirst() + window - now + 999_999) / 1_000_000
    }

    /** Records a start now if one is allowed; false when it must wait ([waitMs]). */
    @Synchronized
    fun tryStart(): Boolean {
        if (waitMs() > 0) return false
        starts.addLast(clock.nowNs())
        return true
    }

    companion object {
        /** Android's BLE scan start limit: 5 per 30 s. */
        @JvmStatic
        fun ble(clock: Clock) = StartLimiter(5, 30_000, clock)

        /** Android 9+'s foreground WiFi scan limit: 4 per 2 min. */
        @JvmStatic
        fun wifiForeground(clock: Clock) = StartLimiter(4, 120_000, clock)

        /** Android 9+'s background WiFi scan limit: 1 per 30 min. */
        @JvmStatic
        fun wifiBackground(clock: Clock) = StartLimiter(1, 30 * 60_000, clock)
    }
}
