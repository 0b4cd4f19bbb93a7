package io.fpbp.sample

import android.annotation.SuppressLint
import android.bluetooth.BluetoothManager
import android.bluetooth.le.ScanCallback
import android.bluetooth.le.ScanResult
import android.bluetooth.le.ScanSettings
import android.content.Context
import android.util.Log
import io.fpbp.BeaconIds

/**
 * Scans BLE advertisements (plain `ScanCallback`, low-latency mode) and hands
 * each one, with its canonical beacon id (iBeacon / Eddystone-UID from the
 * scan record, else `mac:`), to [sink]. Timestamps are
 * `ScanResult.getTimestampNanos()` (elapsedRealtime ns, the sensors' clock).
 */
class BleScanner(context: Context, private val sink: (tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) -> Unit) {
    private val adapter = (context.getSystemService(Context.BLUETOOTH_SERVICE) as BluetoothManager?)?.adapter

    private val callback = object : ScanCallback() {
        override fun onScanResult(callbackType: Int, result: ScanResult) = deliver(result)

        override fun onBatchScanResults(results: MutableList<ScanResult>) = results.forEach(::deliver)

        override fun onScanFailed(errorCode: Int) {
            Log.w(TAG, "BLE scan failed: error $errorCode")
        }
    }

    private fun deliver(r: ScanResult) {
        val frame = BeaconIds.fromAdvertisement(r.scanRecord?.bytes, r.device.address)
        sink(r.timestampNanos, frame.id, r.rssi.toDouble(), frame.txPowerDbm?.toDouble())
    }

    /** Starts scanning; false when Bluetooth is off or missing. Needs the scan permission. */
    @SuppressLint("MissingPermission")
    fun start(): Boolean {
        val scanner = adapter?.takeIf { it.isEnabled }?.bluetoothLeScanner ?: return false
        val settings = ScanSettings.Builder()
            .setScanMode(ScanSettings.SCAN_MODE_LOW_LATENCY)
            .setReportDelay(0)
            .build()
        scanner.startScan(null, settings, callback)
        return true
    }

    @SuppressLint("MissingPermission")
    fun stop() {
        adapter?.takeIf { it.isEnabled }?.bluetoothLeScanner?.stopScan(callback)
    }

    private companion object {
        const val TAG = "fpbp.ble"
    }
}
