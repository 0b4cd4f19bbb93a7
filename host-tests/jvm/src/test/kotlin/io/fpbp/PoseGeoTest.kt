package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertNull
import org.junit.jupiter.api.Test
import kotlin.math.PI

/** The pose's lat/lon through the site's georef and its bearing through map_from_enu_rad. */
class PoseGeoTest {
    private fun site(rot: Double, georef: Boolean) = TestSupport.openSiteJson.replaceFirst(
        "\"name\": \"host-test open floor\",",
        "\"name\": \"geo\", \"map_from_enu_rad\": $rot," +
            (if (georef) " \"georef\": {\"lat_deg\": 48.0, \"lon_deg\": 11.0, \"x_m\": 10.0, \"y_m\": 6.0}," else ""),
    )

    @Test
    fun latLonAndBearingFollowTheSite() {
        FpbpEngine.start(site(0.0, true), TestSupport.repo.path, "pdr", "", InitialPosition(10.0, 6.0, 0, PI / 2)).use { e ->
            // at the georef point: its lat/lon exactly; heading +y = north = bearing 0
            e.setPosition(1, InitialPosition(10.0, 6.0, 0, PI / 2))
            var p = e.pose()!!
            assertEquals(48.0, p.latDeg)
            assertEquals(11.0, p.lonDeg)
            assertEquals(0.0, p.bearingDeg, 1e-9)
            // 1 m north: + 1 / (R pi / 180) deg of latitude (R = 6378137 m)
            e.setPosition(2, InitialPosition(10.0, 7.0, 0, 0.0))
            p = e.pose()!!
            assertEquals(48.0 + 180.0 / (PI * 6_378_137.0), p.latDeg!!, 1e-12)
            assertEquals(11.0, p.lonDeg!!, 1e-12)
            assertEquals(90.0, p.bearingDeg, 1e-9, "heading +x = east")
        }
        // MCS x axis pointing north: map_from_enu_rad = +pi/2 rotates east onto +y
        FpbpEngine.start(site(PI / 2, false), TestSupport.repo.path, "pdr", "", InitialPosition(1.0, 1.0, 0, 0.0)).use { e ->
            e.setPosition(1, InitialPosition(1.0, 1.0, 0, PI / 2))
            val p = e.pose()!!
            assertEquals(90.0, p.bearingDeg, 1e-9, "MCS +y is east")
            assertNull(p.latDeg, "no georef: no latitude")
            assertNull(p.lonDeg)
            assertEquals(1.0, p.floorProb)
            assertEquals(PoseSource.DEAD_RECKONING, p.source)
            assertEquals(5L, p.ageNs(6L))
        }
    }
}
