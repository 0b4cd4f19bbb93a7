package io.fpbp.android

import android.annotation.SuppressLint
import android.bluetooth.BluetoothAdapter
import android.bluetooth.BluetoothManager
import android.bluetooth.le.BluetoothLeScanner
import android.bluetooth.le.ScanCallback
import android.bluetooth.le.ScanFilter
import android.bluetooth.le.ScanResult
import android.bluetooth.le.ScanSettings
import android.content.BroadcastReceiver
import android.content.Context
import android.content.Intent
import android.content.IntentFilter
import android.os.Build
import android.os.Handler
import android.os.ParcelUuid
import io.fpbp.BeaconFilter
import io.fpbp.BeaconIds
import io.fpbp.Clock
import io.fpbp.Problem
import io.fpbp.StartLimiter
import io.fpbp.StatusTracker

/**
 * The library's BLE input: one `BluetoothLeScanner` scan with hardware
 * filters on the site's beacons (an unfiltered scan gets nothing with the
 * screen off), `SCAN_MODE_LOW_LATENCY` in the foreground and
 * `SCAN_MODE_LOW_POWER` in the background, at most 5 starts per 30 s
 * ([StartLimiter.ble]: past that Android withholds results silently), a
 * restart every [RESTART_MS] (Android demotes scans older than 30 min to
 * opportunistic), `onScanFailed` retried with backoff, and Bluetooth on/off
 * followed through `ACTION_STATE_CHANGED`. Each advertisement goes to [sink]
 * with its canonical beacon id and `ScanResult.getTimestampNanos()`.
 *
 * All methods run on [handler]'s thread (the facade's control thread).
 */
internal class BleSource(
    context: Context,
    private val handler: Handler,
    clock: Clock,
    private val filters: List<BeaconFilter>,
    private val status: StatusTracker,
    private val onStatusChanged: () -> Unit,
    private val sink: (tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) -> Unit,
) {
    companion object {
        /** Restart period, below Android's 30-minute demotion to opportunistic scans. */
        const val RESTART_MS: Long = 25 * 60_000L

        /** First retry after `onScanFailed`; doubles up to [MAX_RETRY_MS]. */
        const val FIRST_RETRY_MS: Long = 2_000L
        const val MAX_RETRY_MS: Long = 60_000L

        /** The `ScanFilter`s of [filters]. */
        @JvmStatic
        fun scanFilters(filters: List<BeaconFilter>): List<ScanFilter> = filters.map { f ->
            val b = ScanFilter.Builder()
            when (f) {
                is BeaconFilter.Manufacturer -> b.setManufacturerData(f.companyId, f.data, f.mask)
                is BeaconFilter.ServiceData ->
                    b.setServiceData(ParcelUuid.fromString("0000%04x-0000-1000-8000-00805f9b34fb".format(f.uuid16)), f.data, f.mask)
                is BeaconFilter.Address -> b.setDeviceAddress(f.mac)
            }
            b.build()
        }
    }

    private val app = context.applicationContext
    private val adapter: BluetoothAdapter? =
        (app.getSystemService(Context.BLUETOOTH_SERVICE) as BluetoothManager?)?.adapter
    private val limiter = StartLimiter.ble(clock)
    private var wanted = false
    private var scanning: BluetoothLeScanner? = null
    private var foreground = true
    private var retryMs = FIRST_RETRY_MS
    private var receiverRegistered = false

    /** Scan starts made (for tests and diagnostics). */
    var starts = 0
        private set

    /** Whether a scan is running now. */
    val isScanning: Boolean get() = scanning != null

    private val callback = object : ScanCallback() {
        override fun onScanResult(callbackType: Int, result: ScanResult) = deliver(result)

        override fun onBatchScanResults(results: MutableList<ScanResult>) = results.forEach(::deliver)

        override fun onScanFailed(errorCode: Int) {
            handler.post { failed(errorCode) }
        }
    }

    private val stateReceiver = object : BroadcastReceiver() {
        override fun onReceive(context: Context, intent: Intent) {
            when (intent.getIntExtra(BluetoothAdapter.EXTRA_STATE, BluetoothAdapter.ERROR)) {
                BluetoothAdapter.STATE_ON -> handler.post { if (wanted) startNow() }
                BluetoothAdapter.STATE_TURNING_OFF, BluetoothAdapter.STATE_OFF -> handler.post {
                    scanning = null // the stack dropped the scan
                    handler.removeCallbacks(restart)
                    status.set(Problem.BLUETOOTH_OFF, true)
                    onStatusChanged()
                }
            }
        }
    }

    private val restart = Runnable {
        if (wanted) {
            stopScan()
            startNow()
        }
    }

    private val retry = Runnable { if (wanted && scanning == null) startNow() }

    private fun deliver(r: ScanResult) {
        val frame = BeaconIds.fromAdvertisement(r.scanRecord?.bytes, r.device.address)
        sink(r.timestampNanos, frame.id, r.rssi.toDouble(), frame.txPowerDbm?.toDouble())
    }

    /** Starts scanning (or waits for Bluetooth, the start limit or a retry). */
    fun start(foreground: Boolean) {
        this.foreground = foreground
        wanted = true
        if (!receiverRegistered) {
            registerReceiverCompat(app, stateReceiver, IntentFilter(BluetoothAdapter.ACTION_STATE_CHANGED))
            receiverRegistered = true
        }
        startNow()
    }

    /** Switches the scan mode (a restart, counted by the start limit). */
    fun setForeground(fg: Boolean) {
        if (fg == foreground) return
        foreground = fg
        if (wanted && scanning != null) {
            stopScan()
            startNow()
        }
    }

    /** Stops scanning and forgets the receiver; nothing runs after it. */
    fun stop() {
        wanted = false
        handler.removeCallbacks(restart)
        handler.removeCallbacks(retry)
        stopScan()
        if (receiverRegistered) {
            app.unregisterReceiver(stateReceiver)
            receiverRegistered = false
        }
        status.set(Problem.SCAN_THROTTLED, false)
    }

    @SuppressLint("MissingPermission") // the facade checks the permissions before start
    private fun startNow() {
        if (!wanted || scanning != null) return
        val a = adapter
        if (a == null) {
            status.set(Problem.BLUETOOTH_UNAVAILABLE, true)
            onStatusChanged()
            return
        }
        val scanner = a.takeIf { it.isEnabled }?.bluetoothLeScanner
        if (scanner == null) {
            status.set(Problem.BLUETOOTH_OFF, true)
            onStatusChanged()
            return
        }
        status.set(Problem.BLUETOOTH_OFF, false)
        val wait = limiter.waitMs()
        if (wait > 0) {
            status.set(Problem.SCAN_THROTTLED, true)
            onStatusChanged()
            handler.postDelayed(retry, wait)
            return
        }
        limiter.tryStart()
        status.set(Problem.SCAN_THROTTLED, false)
        val settings = ScanSettings.Builder()
            .setScanMode(if (foreground) ScanSettings.SCAN_MODE_LOW_LATENCY else ScanSettings.SCAN_MODE_LOW_POWER)
            .setReportDelay(0)
            .build()
        scanner.startScan(scanFilters(filters), settings, callback)
        starts++
        scanning = scanner
        handler.removeCallbacks(restart)
        handler.postDelayed(restart, RESTART_MS)
        onStatusChanged()
    }

    @SuppressLint("MissingPermission")
    private fun stopScan() {
        val s = scanning ?: return
        scanning = null
        if (adapter?.isEnabled == true) {
            try {
                s.stopScan(callback)
            } catch (_: IllegalStateException) {
                // Bluetooth went off in between: the scan is gone anyway
            }
        }
    }

    private fun failed(errorCode: Int) {
        if (errorCode == ScanCallback.SCAN_FAILED_ALREADY_STARTED) return
        scanning = null
        handler.removeCallbacks(restart)
        status.scanFailed(errorCode)
        onStatusChanged()
        handler.removeCallbacks(retry)
        handler.postDelayed(retry, retryMs)
        retryMs = (retryMs * 2).coerceAtMost(MAX_RETRY_MS)
    }
}

/** `registerReceiver` for system broadcasts (not exported on 33+, where the flag exists). */
internal fun registerReceiverCompat(context: Context, receiver: BroadcastReceiver, filter: IntentFilter) {
    if (Build.VERSION.SDK_INT >= 33) {
        context.registerReceiver(receiver, filter, Context.RECEIVER_NOT_EXPORTED)
    } else {
        @Suppress("UnspecifiedRegisterReceiverFlag")
        context.registerReceiver(receiver, filter)
    }
}
