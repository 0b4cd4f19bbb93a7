package io.fpbp.robo

import android.Manifest
import android.bluetooth.BluetoothManager
import android.bluetooth.le.ScanCallback
import android.bluetooth.le.ScanRecord
import android.bluetooth.le.ScanResult
import android.content.Context
import android.os.SystemClock
import io.fpbp.PositioningState
import io.fpbp.Problem
import io.fpbp.android.FpbpPositioning
import org.junit.Assert.assertEquals
import org.junit.Assert.assertTrue
import org.junit.Before
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.shadows.ShadowBluetoothLeScanner

/** The library's BLE source on the Android framework, feeding the real libfpbp. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class BleSourceRoboTest : OpenSitePositioningTest() {

    private val bluetooth get() = app.getSystemService(Context.BLUETOOTH_SERVICE) as BluetoothManager
    private val scanner get() = shadowOf(bluetooth.adapter.bluetoothLeScanner) as ShadowBluetoothLeScanner

    @Before
    fun setUp() {
        shadowOf(app).grantPermissions(Manifest.permission.BLUETOOTH_SCAN, Manifest.permission.ACCESS_FINE_LOCATION, Manifest.permission.ACCESS_COARSE_LOCATION)
        shadowOf(bluetooth.adapter).setEnabled(true)
    }

    private fun advert(mac: String, rssi: Int): ScanResult {
        val device = bluetooth.adapter.getRemoteDevice(mac)
        // A plain advertisement without beacon frames: the library falls back to the `mac:` id.
        val record = ScanRecord.parseFromBytes(byteArrayOf(2, 1, 6))
        return ScanResult(
            device, 0x11, 1, 0, ScanResult.SID_NOT_PRESENT, ScanResult.TX_POWER_NOT_PRESENT, rssi,
            ScanResult.PERIODIC_INTERVAL_NOT_PRESENT, record, SystemClock.elapsedRealtimeNanos(),
        )
    }

    @Test
    fun scanResultsReachTheEngineThroughTheRealLibrary() {
        val p = start()
        assertTrue("no scan started", RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        val scan = scanner.activeScans.single()
        assertEquals("one hardware filter per site beacon", 4, scan.scanFilters().size)
        val cb: ScanCallback = scanner.scanCallbacks.single()
        for (k in 0 until 12) cb.onScanResult(ScanSettingsCallbackType, advert("00:00:00:00:00:0${k % 4 + 1}", -60 - k))
        cb.onScanResult(ScanSettingsCallbackType, advert("AA:BB:CC:DD:EE:FF", -70))
        assertTrue(RoboSupport.idleUntil { p.stats()?.bleObservations == 13L })
        assertEquals("the stranger is not a site beacon", 1L, p.stats()?.unknownBeacons)
    }

    @Test
    fun bluetoothOffIsAStatusAndScanningStartsWhenItComesOn() {
        shadowOf(bluetooth.adapter).setEnabled(false)
        val p = start()
        assertTrue(RoboSupport.idleUntil { Problem.BLUETOOTH_OFF in p.status.problems })
        assertTrue(scanner.scanCallbacks.isEmpty())
        shadowOf(bluetooth.adapter).setEnabled(true)
        app.sendBroadcast(
            android.content.Intent(android.bluetooth.BluetoothAdapter.ACTION_STATE_CHANGED)
                .putExtra(android.bluetooth.BluetoothAdapter.EXTRA_STATE, android.bluetooth.BluetoothAdapter.STATE_ON),
        )
        assertTrue("no scan after Bluetooth came on", RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        assertTrue(RoboSupport.idleUntil { Problem.BLUETOOTH_OFF !in p.status.problems })
    }

    @Test
    fun missingPermissionIsAStatusAndNoScanStarts() {
        shadowOf(app).denyPermissions(Manifest.permission.BLUETOOTH_SCAN)
        val p = start()
        assertTrue(RoboSupport.idleUntil { Problem.PERMISSION_MISSING in p.status.problems })
        assertEquals(listOf(Manifest.permission.BLUETOOTH_SCAN), p.status.missingPermissions)
        assertEquals(PositioningState.WAITING_FOR_FIX, p.status.state)
        Thread.sleep(200)
        RoboSupport.idleUntil(200) { false }
        assertTrue("scanned without the permission", scanner.scanCallbacks.isEmpty())
        // Granted later: refreshPermissions starts the scan.
        shadowOf(app).grantPermissions(Manifest.permission.BLUETOOTH_SCAN)
        p.refreshPermissions()
        assertTrue(RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        assertTrue(RoboSupport.idleUntil { Problem.PERMISSION_MISSING !in p.status.problems })
    }

    @Test
    fun stopReleasesTheScanner() {
        val p = start()
        assertTrue(RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        p.stop().get(30, java.util.concurrent.TimeUnit.SECONDS)
        assertTrue("scan still registered after stop", RoboSupport.idleUntil { scanner.scanCallbacks.isEmpty() })
        assertEquals(PositioningState.STOPPED, p.status.state)
    }

    @Test
    fun scanStartsStayWithinFivePerThirtySeconds() {
        val p = start()
        assertTrue(RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        // Ten foreground/background switches in a row: each is a restart.
        repeat(10) { p.setForeground(it % 2 == 1) }
        RoboSupport.idleUntil(500) { false }
        assertEquals("starts within the window", 5, p.bleScanStarts)
        assertTrue(RoboSupport.idleUntil { Problem.SCAN_THROTTLED in p.status.problems })
    }

    private companion object {
        const val ScanSettingsCallbackType = android.bluetooth.le.ScanSettings.CALLBACK_TYPE_ALL_MATCHES
    }
}
