package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertThrows
import org.junit.jupiter.api.Test
import kotlin.random.Random

/**
 * The Kotlin map <-> WGS-84 conversion ([SiteGeo]) agrees with the engine's
 * (rust/core/src/geo.rs, the pose's lat/lon fields) to 1e-9 degrees, and its
 * inverse returns the map point. Guards a Kotlin formula that drifts from
 * the Rust one (axis order, rotation sign, projection latitude).
 */
class SiteGeoTest {
    private val rot = 0.3
    private val geo = SiteGeo(48.137, 11.575, 10.0, 6.0, rot)

    private val siteJson = TestSupport.openSiteJson.replaceFirst(
        "\"name\": \"host-test open floor\",",
        "\"name\": \"geo\", \"map_from_enu_rad\": $rot, " +
            "\"georef\": {\"lat_deg\": 48.137, \"lon_deg\": 11.575, \"x_m\": 10.0, \"y_m\": 6.0},",
    )

    @Test
    fun kotlinAndEngineConversionsAgree() {
        val rng = Random(37)
        FpbpEngine.start(siteJson, TestSupport.repo.path, "pdr", "", InitialPosition(10.0, 6.0, 0, 0.0)).use { e ->
            for (k in 1..50) {
                val x = rng.nextDouble(0.0, 20.0)
                val y = rng.nextDouble(0.0, 12.0)
                val h = rng.nextDouble(-3.0, 3.0)
                e.setPosition(k.toLong(), InitialPosition(x, y, 0, h))
                val p = e.pose()!!
                val ll = geo.toWgs84(x, y)
                assertEquals(p.latDeg!!, ll.latDeg, 1e-9, "lat at ($x, $y)")
                assertEquals(p.lonDeg!!, ll.lonDeg, 1e-9, "lon at ($x, $y)")
                val back = geo.toMap(p.latDeg, p.lonDeg)
                assertEquals(x, back.xM, 1e-6)
                assertEquals(y, back.yM, 1e-6)
                val d = (geo.bearingDeg(h) - p.bearingDeg).mod(360.0)
                assertEquals(0.0, minOf(d, 360.0 - d), 1e-9, "bearing of heading $h")
                val hb = geo.headingRad(p.bearingDeg)
                assertEquals(0.0, Math.IEEEremainder(hb - h, 2 * Math.PI), 1e-9, "heading of bearing ${p.bearingDeg}")
            }
        }
    }

    @Test
    fun theGeorefPointIsExactAndNorthIsUpWithoutRotation() {
        val g = SiteGeo(48.0, 11.0, 10.0, 6.0)
        assertEquals(LatLon(48.0, 11.0), g.toWgs84(10.0, 6.0))
        // 1 m north: + 1 / (R pi / 180) deg of latitude
        assertEquals(48.0 + 180.0 / (Math.PI * SiteGeo.EARTH_RADIUS_M), g.toWgs84(10.0, 7.0).latDeg, 1e-15)
        assertEquals(0.0, g.bearingDeg(Math.PI / 2), 1e-12)
        assertEquals(90.0, g.bearingDeg(0.0), 1e-12)
    }

    @Test
    fun badGeorefsAreRejected() {
        assertThrows(IllegalArgumentException::class.java) { SiteGeo(91.0, 0.0, 0.0, 0.0) }
        assertThrows(IllegalArgumentException::class.java) { SiteGeo(0.0, 181.0, 0.0, 0.0) }
        assertThrows(IllegalArgumentException::class.java) { SiteGeo(0.0, 0.0, Double.NaN, 0.0) }
    }
}
