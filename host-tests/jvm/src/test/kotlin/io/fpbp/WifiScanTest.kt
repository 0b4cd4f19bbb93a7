package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Test

/** onWifiScan: entries counted, bad ones and malformed scans counted as rejected, never thrown. */
class WifiScanTest {
    @Test
    fun scansAreForwardedAndBadInputCounted() {
        TestSupport.startOpen().use { e ->
            val h = e.handle
            e.onWifiScan(
                1_000,
                arrayOf("aa:bb:cc:dd:ee:01", "AA-BB-CC-DD-EE-02", null, "zz", "aa:bb:cc:dd:ee:05"),
                doubleArrayOf(-50.0, -60.0, -70.0, -70.0, Double.NaN),
                intArrayOf(2412, 5180, 2412, 2412, 2412),
                longArrayOf(900, 1_000, 1_000, 1_000, 1_000),
            )
            assertEquals(1L, e.stats().wifiScans)
            assertEquals(2L, e.stats().wifiResults)
            assertEquals(3L, e.stats().bridgeRejected)
            // a result seen after its scan, mismatched lengths, null arrays, too many results
            e.onWifiScan(2_000, arrayOf("aa:bb:cc:dd:ee:01"), doubleArrayOf(-50.0), intArrayOf(2412), longArrayOf(2_001))
            NativeBridge.onWifiScan(h, 3_000, arrayOf("aa:bb:cc:dd:ee:01"), doubleArrayOf(-50.0, -51.0), intArrayOf(2412), longArrayOf(0))
            NativeBridge.onWifiScan(h, 3_000, null, null, null, null)
            val n = NativeBridge.MAX_WIFI_RESULTS + 1
            NativeBridge.onWifiScan(h, 4_000, Array(n) { "aa:bb:cc:dd:ee:01" }, DoubleArray(n) { -50.0 }, IntArray(n) { 2412 }, LongArray(n))
            assertEquals(1L, e.stats().wifiScans)
            assertEquals(3L + 4, e.stats().bridgeRejected)
            // the largest scan allowed and an empty one (nothing heard) are forwarded
            val m = NativeBridge.MAX_WIFI_RESULTS
            NativeBridge.onWifiScan(
                h, 5_000, Array(m) { "aa:bb:cc:dd:%02x:%02x".format(it / 256, it % 256) }, DoubleArray(m) { -60.0 },
                IntArray(m) { 2437 }, LongArray(m) { 4_000 },
            )
            e.onWifiScan(6_000, arrayOf(), doubleArrayOf(), intArrayOf(), longArrayOf())
            assertEquals(3L, e.stats().wifiScans)
            assertEquals(2L + m, e.stats().wifiResults)
        }
    }
}
