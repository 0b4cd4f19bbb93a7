package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertNull
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows

/** EngineStats: the typed stats read the bridge's JSON, and refuse what is not stats. */
class EngineStatsTest {
    private val counts =
        "\"sensor_events\":12,\"ble_observations\":5,\"unknown_beacons\":1,\"rejected_inputs\":3," +
            "\"bridge_rejected\":2,\"wifi_scans\":4,\"wifi_results\":40,\"steps\":7,\"no_fix\":0"

    @Test
    fun readsEveryFieldAndNulls() {
        val s = EngineStats.parse("{\"engine\":\"tcpf\",$counts,\"rssi_offset_db\":-8.25,\"step_scale\":1.0}")
        assertEquals(EngineStats("tcpf", 12, 5, 1, 3, 2, 4, 40, 7, 0, -8.25, 1.0), s)
        val n = EngineStats.parse(" { \"engine\" : \"fpbp\" , $counts , \"rssi_offset_db\" : null , \"step_scale\" : null } ")
        assertNull(n.rssiOffsetDb)
        assertNull(n.stepScale)
        // an older bridge without the estimates, and a newer one with fields this version does not know
        assertNull(EngineStats.parse("{\"engine\":\"bp\",$counts}").rssiOffsetDb)
        val newer = EngineStats.parse("{\"engine\":\"a\\\"b\\u00e9\",$counts,\"future\":true,\"later\":\"v\"}")
        assertEquals("a\"b\u00e9", newer.engine)
        assertEquals(1e3, EngineStats.parse("{\"engine\":\"x\",$counts,\"step_scale\":1e3}").stepScale)
        // the radio's trust: read when given, null when null or absent (an older bridge)
        assertEquals(0.25, EngineStats.parse("{\"engine\":\"tcpf\",$counts,\"radio_trust\":0.25}").radioTrust)
        assertNull(EngineStats.parse("{\"engine\":\"fpbp\",$counts,\"radio_trust\":null}").radioTrust)
        assertNull(s.radioTrust)
    }

    @Test
    fun refusesWhatIsNotStatsNamingTheField() {
        fun message(json: String) = assertThrows<IllegalArgumentException> { EngineStats.parse(json) }.message ?: ""
        assertTrue(message("{\"engine\":\"tcpf\"}").contains("\"sensor_events\" missing"))
        assertTrue(message("{\"engine\":\"tcpf\",${counts.replace("\"steps\":7", "\"steps\":-7")}}").contains("\"steps\""))
        assertTrue(message("{\"engine\":\"tcpf\",${counts.replace("\"steps\":7", "\"steps\":7.5")}}").contains("\"steps\""))
        assertTrue(message("{\"engine\":\"tcpf\",$counts,\"rssi_offset_db\":\"x\"}").contains("\"rssi_offset_db\""))
        assertTrue(message("{\"engine\":\"tcpf\",$counts,\"radio_trust\":true}").contains("\"radio_trust\""))
        assertTrue(message("{\"engine\":3,$counts}").contains("\"engine\""))
        assertTrue(message("{\"engine\":\"tcpf\",$counts,\"x\":{}}").contains("nested"))
        for (bad in listOf("", "[]", "{", "{\"engine\":\"t", "{\"engine\":\"tcpf\"} x", "{\"a\":1,}", "{\"a\":nul}", "{\"a\":1e999}")) {
            assertThrows<IllegalArgumentException>("accepted: $bad") { EngineStats.parse(bad) }
        }
        assertThrows<IllegalArgumentException> { EngineStats.parse("{\"engine\":\"" + "x".repeat(EngineStats.MAX_JSON_CHARS) + "\"}") }
    }

    @Test
    fun readsWhatTheBridgeWrites() {
        for (name in listOf("tcpf", "fpbp").filter { it in TestSupport.engines }) {
            TestSupport.startOpen(name).use { e ->
                e.onBleScan(1_000_000, TestSupport.openSiteBeacons[0], -60.0)
                e.onSensor(99, 1_000_000, floatArrayOf(0f))
                val s = e.stats()
                assertEquals(name, s.engine)
                assertEquals(1, s.bleObservations)
                assertTrue(s.bridgeRejected >= 1, "the unknown sensor type is counted: $s")
                assertEquals(name == "tcpf", s.rssiOffsetDb != null, "offset for $name: $s")
                // tcpf reports its radio trust (1: no told start, no check lowers it), the others none
                assertEquals(if (name == "tcpf") 1.0 else null, s.radioTrust, "radio trust for $name: $s")
            }
        }
    }
}
