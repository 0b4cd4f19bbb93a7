package io.fpbp.android

import android.annotation.SuppressLint
import android.content.BroadcastReceiver
import android.content.Context
import android.content.Intent
import android.content.IntentFilter
import android.net.wifi.WifiManager
import android.os.Handler
import io.fpbp.Clock
import io.fpbp.Problem
import io.fpbp.StartLimiter
import io.fpbp.StatusTracker

/**
 * The library's WiFi input. Listens to `SCAN_RESULTS_AVAILABLE_ACTION`,
 * which also fires for scans other apps and the system make (those results
 * are free), and reads `WifiManager.getScanResults()` into one scan for
 * [sink]. It asks for scans itself every [SCAN_PERIOD_MS] within Android
 * 9+'s throttle: 4 `startScan` per 2 min in the foreground, 1 per 30 min in
 * the background ([StartLimiter]); a refused or throttled start only waits
 * for the next passive results. With the developer option "WiFi scan
 * throttling" off, the system allows more; the limiter still holds to 4 per
 * 2 min so a phone behaves like a user's. A survey ([FpbpSurvey]) asks
 * every [periodMs] without the limiter ([limited] false): with throttling
 * off the phone scans that often, with it on the refused starts cost
 * nothing. Needs ACCESS_FINE_LOCATION (and NEARBY_WIFI_DEVICES on 13+) and
 * location services on.
 *
 * Runs on [handler]'s thread.
 */
internal class WifiSource(
    context: Context,
    private val handler: Handler,
    private val clock: Clock,
    private val status: StatusTracker,
    private val onStatusChanged: () -> Unit,
    private val periodMs: Long = SCAN_PERIOD_MS,
    private val limited: Boolean = true,
    private val sink: (tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) -> Unit,
) {
    companion object {
        /** How often the source asks for a scan (30 s = 4 per 2 min). */
        const val SCAN_PERIOD_MS: Long = 30_000

        /** Most results one scan hands to the engine (rust/jni `MAX_WIFI_RESULTS`). */
        const val MAX_RESULTS: Int = io.fpbp.NativeBridge.MAX_WIFI_RESULTS
    }

    private val app = context.applicationContext
    private val wifi = app.getSystemService(Context.WIFI_SERVICE) as WifiManager?
    private val foregroundLimiter = StartLimiter.wifiForeground(clock)
    private val backgroundLimiter = StartLimiter.wifiBackground(clock)
    private var foreground = true
    private var wanted = false
    private var registered = false

    /** Scans requested with `startScan` and scans delivered (tests, diagnostics). */
    var requested = 0
        private set
    var delivered = 0
        private set

    private val receiver = object : BroadcastReceiver() {
        override fun onReceive(context: Context, intent: Intent) {
            handler.post { if (wanted) read() }
        }
    }

    private val ask = object : Runnable {
        override fun run() {
            if (!wanted) return
            requestScan()
            handler.postDelayed(this, periodMs)
        }
    }

    fun start(foreground: Boolean) {
        this.foreground = foreground
        wanted = true
        if (!registered) {
            registerReceiverCompat(app, receiver, IntentFilter(WifiManager.SCAN_RESULTS_AVAILABLE_ACTION))
            registered = true
        }
        handler.removeCallbacks(ask)
        handler.post(ask)
    }

    fun setForeground(fg: Boolean) {
        foreground = fg
    }

    fun stop() {
        wanted = false
        handler.removeCallbacks(ask)
        if (registered) {
            app.unregisterReceiver(receiver)
            registered = false
        }
    }

    @Suppress("DEPRECATION") // startScan is deprecated but is the only way to ask for a scan
    private fun requestScan() {
        val w = wifi ?: return
        val off = !w.isWifiEnabled && !w.isScanAlwaysAvailable
        status.set(Problem.WIFI_OFF, off)
        if (off) {
            onStatusChanged()
            return
        }
        val limiter = if (foreground) foregroundLimiter else backgroundLimiter
        if (limited && !limiter.tryStart()) return // passive results still arrive
        if (w.startScan()) requested++
    }

    @SuppressLint("MissingPermission") // the facade checks the permissions before start
    private fun read() {
        val results = try {
            wifi?.scanResults ?: return
        } catch (_: SecurityException) {
            return
        }
        val n = minOf(results.size, MAX_RESULTS)
        val bssids = arrayOfNulls<String>(n)
        val rssi = DoubleArray(n)
        val freq = IntArray(n)
        val seen = LongArray(n)
        for (i in 0 until n) {
            val r = results[i]
            bssids[i] = r.BSSID
            rssi[i] = r.level.toDouble()
            freq[i] = r.frequency
            seen[i] = r.timestamp * 1000 // microseconds since boot -> ns
        }
        delivered++
        sink(clock.nowNs(), bssids, rssi, freq, seen)
    }
}
