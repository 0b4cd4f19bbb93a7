package io.fpbp.robo

import android.Manifest
import android.content.Context
import android.content.Intent
import android.net.wifi.ScanResult
import android.net.wifi.WifiManager
import io.fpbp.EngineStats
import io.fpbp.Radio
import io.fpbp.android.FpbpPositioning
import org.junit.Assert.assertEquals
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config

/** WiFi scan results (passive broadcasts) reach the engine through onWifiScan. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class WifiSourceRoboTest : OpenSitePositioningTest() {
    private fun result(bssid: String, level: Int, freq: Int): ScanResult = ScanResult().apply {
        BSSID = bssid
        this.level = level
        frequency = freq
        timestamp = 0
    }

    @Test
    fun scanResultsReachTheEngine() {
        shadowOf(app).grantPermissions(Manifest.permission.ACCESS_FINE_LOCATION, Manifest.permission.ACCESS_COARSE_LOCATION, Manifest.permission.NEARBY_WIFI_DEVICES)
        val wifi = app.getSystemService(Context.WIFI_SERVICE) as WifiManager
        shadowOf(wifi).setWifiState(WifiManager.WIFI_STATE_ENABLED)
        shadowOf(wifi).setScanResults(
            listOf(result("aa:bb:cc:dd:ee:01", -55, 2412), result("AA:BB:CC:DD:EE:02", -71, 5180), result("bad", -60, 2412)),
        )
        val p = start(FpbpPositioning.Options(radios = setOf(Radio.WIFI)))
        RoboSupport.idleUntil(300) { false }
        app.sendBroadcast(Intent(WifiManager.SCAN_RESULTS_AVAILABLE_ACTION))
        assertTrue(RoboSupport.idleUntil { (p.stats()?.wifiScans ?: 0L) >= 1L })
        // the typed stats the app reads say the same as the JSON (one read:
        // the library scans again while the test runs)
        val json = checkNotNull(p.statsJson()) { "no stats while running" }
        val stats = EngineStats.parse(json)
        assertEquals(stats.toString(), 2L * stats.wifiScans, stats.wifiResults)
        assertTrue(stats.toString(), stats.bridgeRejected >= 1L)
        assertTrue(json, Regex("\"wifi_scans\":${stats.wifiScans}(?![0-9])").containsMatchIn(json))
    }
}
