package io.fpbp

import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows
import kotlin.math.hypot
import kotlin.math.log10
import kotlin.math.max

/** A walked-survey fingerprint database handed through JNI reaches `robust-ekf`. */
class FingerprintsTest {
    private val beacons = listOf(1.0 to 1.0, 19.0 to 1.0, 19.0 to 11.0, 1.0 to 11.0)

    /** The open site's path-loss model (R0 -59 dBm, n 2) at (x, y). */
    private fun rssiAt(x: Double, y: Double) =
        beacons.map { (bx, by) -> -59.0 - 20.0 * log10(max(hypot(x - bx, y - by), 0.5)) }

    /** A database whose every point lies at (x, y): WKNN can only answer (x, y). */
    private fun databaseAt(x: Double, y: Double, ids: List<String> = TestSupport.openSiteBeacons): String {
        val rssi = rssiAt(x, y).joinToString(", ") { "%.2f".format(java.util.Locale.ROOT, it) }
        val point = """{"x_m": $x, "y_m": $y, "cluster": 0, "rssi_dbm": [$rssi]}"""
        val idList = ids.joinToString(", ") { "\"$it\"" }
        return """{"format": "fpbp-fingerprints", "version": 1, "site": "host-test open floor", "source": "survey",
            "floors": [{"floor": 0, "missing_rssi_dbm": -100.0, "beacons": [$idList], "clusters": 1, "reassigned": 0,
            "points": [$point, $point]}]}"""
    }

    /** BLE position after 3 s of scans taken at (5, 3), with or without a database. */
    private fun blePositionWith(fingerprints: String?): Pose? =
        FpbpEngine.start(
            TestSupport.openSiteJson, TestSupport.repo.path, "robust-ekf", "", null, fingerprints,
        ).use { e ->
            val scan = rssiAt(5.0, 3.0)
            for (k in 0 until 30) {
                val t = k * 100_000_000L
                TestSupport.openSiteBeacons.forEachIndexed { i, id -> e.onBleScan(t, id, scan[i]) }
                if (k % 10 == 9) e.runRadio(t)
            }
            e.blePosition()
        }

    @Test
    fun robustEkfUsesTheDatabaseItIsGiven() {
        if ("robust-ekf" !in TestSupport.engines) {
            println("skipped: engine robust-ekf is not registered")
            return
        }
        val model = blePositionWith(null)
        val survey = blePositionWith(databaseAt(15.0, 9.0))
        requireNotNull(model) { "no BLE fix from the model database" }
        requireNotNull(survey) { "no BLE fix from the survey database" }
        assertTrue(hypot(model.xM - 5.0, model.yM - 3.0) < 3.0, "model database fix $model should be near (5, 3)")
        assertTrue(hypot(survey.xM - 15.0, survey.yM - 9.0) < 0.5, "survey database fix $survey should be at (15, 9)")
    }

    @Test
    fun aDatabaseNamingAnUnknownBeaconIsRejectedWithItsField() {
        val bad = databaseAt(15.0, 9.0, TestSupport.openSiteBeacons.dropLast(1) + "mac:00:00:00:00:00:99")
        val e = assertThrows<IllegalArgumentException> {
            FpbpEngine.start(TestSupport.openSiteJson, TestSupport.repo.path, "robust-ekf", "", null, bad)
        }
        val m = e.message ?: ""
        assertTrue(m.contains("floors[0].beacons[3]") && m.contains("00:99"), m)
        val e2 = assertThrows<IllegalArgumentException> {
            FpbpEngine.start(TestSupport.openSiteJson, TestSupport.repo.path, "robust-ekf", "", null, "{ nope")
        }
        assertTrue((e2.message ?: "").contains("line 1"), e2.message)
    }
}
