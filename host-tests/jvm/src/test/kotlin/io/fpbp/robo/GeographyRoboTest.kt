package io.fpbp.robo

import android.location.Location
import android.os.SystemClock
import io.fpbp.InitialPosition
import io.fpbp.Pose
import io.fpbp.PoseSource
import io.fpbp.Problem
import io.fpbp.TestSupport
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.LocationExtras
import io.fpbp.android.geo
import io.fpbp.android.toLocation
import org.junit.Assert.assertEquals
import org.junit.Assert.assertNotNull
import org.junit.Assert.assertNull
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.annotation.Config
import java.util.concurrent.ExecutionException
import java.util.concurrent.TimeUnit

/** WGS-84 in ([FpbpPositioning.setPositionWgs84]) and out ([toLocation]) through the site's georef. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class GeographyRoboTest {
    private val app get() = org.robolectric.RuntimeEnvironment.getApplication()

    private val geoSite = FpbpPositioning.Site(
        TestSupport.openSiteJson.replaceFirst(
            "\"name\": \"host-test open floor\",",
            "\"name\": \"geo\", \"map_from_enu_rad\": 0.3, " +
                "\"georef\": {\"lat_deg\": 48.137, \"lon_deg\": 11.575, \"x_m\": 10.0, \"y_m\": 6.0},",
        ),
        TestSupport.repo.path,
    )

    private fun positioning(site: FpbpPositioning.Site) = FpbpPositioning(
        app, site, FpbpPositioning.Options(engine = "pdr", initialPosition = InitialPosition(10.0, 6.0, 0, 0.0), ownBle = false, ownSensors = false),
    )

    @Test
    fun aWgs84PositionLandsOnItsMapPoint() {
        val p = positioning(geoSite)
        try {
            p.start().get(30, TimeUnit.SECONDS)
            val geo = geoSite.geo()!!
            val target = geo.toWgs84(4.0, 9.0)
            p.setPositionWgs84(target.latDeg, target.lonDeg, 0, 2.0, 45.0).get(30, TimeUnit.SECONDS)
            val pose = p.currentPose()!!
            assertEquals(4.0, pose.xM, 1e-6)
            assertEquals(9.0, pose.yM, 1e-6)
            assertEquals(45.0, pose.bearingDeg, 1e-9)
            assertEquals(target.latDeg, pose.latDeg!!, 1e-9)
            // the same through an android.location.Location
            val l = Location("test").apply {
                latitude = geo.toWgs84(15.0, 3.0).latDeg
                longitude = geo.toWgs84(15.0, 3.0).lonDeg
                accuracy = 3f
            }
            p.setPosition(l, 0).get(30, TimeUnit.SECONDS)
            assertEquals(15.0, p.currentPose()!!.xM, 1e-6)
            assertEquals(3.0, p.currentPose()!!.yM, 1e-6)
            // a fix less accurate than MAX_SET_POSITION_ACCURACY_M is refused, as a status too
            val e = try {
                p.setPositionWgs84(target.latDeg, target.lonDeg, 0, 25.0).get(30, TimeUnit.SECONDS)
                null
            } catch (x: ExecutionException) {
                x.cause
            }
            assertTrue("$e", e is IllegalArgumentException)
            assertTrue(p.status.toString(), RoboSupport.idleUntil { Problem.POSITION_REFUSED in p.status.problems })
            assertEquals(15.0, p.currentPose()!!.xM, 1e-6)
        } finally {
            p.closeAsync().get(30, TimeUnit.SECONDS)
        }
    }

    @Test
    fun withoutAGeorefWgs84IsRefused() {
        val site = FpbpPositioning.Site(TestSupport.openSiteJson, TestSupport.repo.path)
        assertNull(site.geo())
        val p = positioning(site)
        try {
            p.start().get(30, TimeUnit.SECONDS)
            val e = try {
                p.setPositionWgs84(48.0, 11.0, 0, 1.0).get(30, TimeUnit.SECONDS)
                null
            } catch (x: ExecutionException) {
                x.cause
            }
            assertTrue("$e", e is IllegalArgumentException)
            assertTrue(RoboSupport.idleUntil { p.status.messages[Problem.POSITION_REFUSED]?.contains("georef") == true })
        } finally {
            p.closeAsync().get(30, TimeUnit.SECONDS)
        }
    }

    @Test
    fun aPoseBecomesALocation() {
        val now = SystemClock.elapsedRealtimeNanos()
        val pose = Pose(
            tNs = now - 2_000_000_000L, xM = 4.0, yM = 9.0, floor = 2, headingRad = 0.0, accuracyM = 1.5,
            floorProb = 0.75, source = PoseSource.FUSED, latDeg = 48.1, lonDeg = 11.6, bearingDeg = 123.0,
        )
        val before = System.currentTimeMillis()
        val l = pose.toLocation()
        assertNotNull(l)
        l!!
        assertEquals("fpbp", l.provider)
        assertEquals(48.1, l.latitude, 0.0)
        assertEquals(11.6, l.longitude, 0.0)
        assertEquals(1.5f, l.accuracy, 0f)
        assertEquals(123f, l.bearing, 0f)
        assertEquals(pose.tNs, l.elapsedRealtimeNanos)
        // wall time: now minus the pose's age (2 s)
        assertTrue("${l.time} vs $before", l.time <= before - 1_900 && l.time >= before - 2_000 - 60_000)
        assertEquals(2, l.extras!!.getInt(LocationExtras.FLOOR))
        assertEquals(0.75, l.extras!!.getDouble(LocationExtras.FLOOR_PROB), 0.0)
        assertEquals(4.0, l.extras!!.getDouble(LocationExtras.X_M), 0.0)
        assertEquals("FUSED", l.extras!!.getString(LocationExtras.SOURCE))
        assertNull("no georef, no location", pose.copy(latDeg = null, lonDeg = null).toLocation())
    }
}
