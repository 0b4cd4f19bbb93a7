package io.fpbp.robo

import android.Manifest
import android.app.Application
import android.content.Context
import android.content.Intent
import android.hardware.Sensor
import android.hardware.SensorManager
import io.fpbp.sample.MainActivity
import org.junit.Assert.assertEquals
import org.junit.Assert.assertNotNull
import org.junit.Assert.assertSame
import org.junit.Assert.assertTrue
import org.junit.Rule
import org.junit.Test
import org.junit.rules.TemporaryFolder
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.RuntimeEnvironment
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import java.io.File

/** The sample app on the Android framework with the real libfpbp. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class SampleActivityRoboTest {
    @get:Rule
    val tmp = TemporaryFolder()

    private val app: Application get() = RuntimeEnvironment.getApplication()

    /** A two-floor site without plans, tied to WGS-84. */
    private fun twoFloorSite(): File {
        val dir = tmp.newFolder("site")
        File(dir, "site.json").writeText(
            """
            {"format": "fpbp-site", "version": 1, "name": "two floors",
             "georef": {"lat_deg": 48.0, "lon_deg": 11.0, "x_m": 0.0, "y_m": 0.0},
             "floors": [{"id": 0, "open_area_m": [20.0, 12.0], "pixels_per_meter": 10.0},
                        {"id": 1, "open_area_m": [20.0, 12.0], "pixels_per_meter": 10.0, "height_m": 4.0}],
             "beacons": [{"id": "mac:00:00:00:00:00:01", "floor": 0, "x_m": 1.0, "y_m": 1.0, "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0}]}
            """.trimIndent(),
        )
        return dir
    }

    private fun launch(site: File) = Robolectric.buildActivity(
        MainActivity::class.java,
        Intent(app, MainActivity::class.java).putExtra(MainActivity.EXTRA_SITE_DIR, site.path),
    ).setup()

    @Test
    fun showsTheFloorOfThePoseAndSurvivesARotation() {
        shadowOf(app).grantPermissions(Manifest.permission.BLUETOOTH_SCAN, Manifest.permission.ACCESS_FINE_LOCATION, Manifest.permission.ACCESS_COARSE_LOCATION)
        val controller = launch(twoFloorSite())
        val activity = controller.get()
        // the site loads and positioning starts off the main thread
        assertTrue(activity.statusText, RoboSupport.idleUntil { activity.positioning?.isRunning == true })
        val p = activity.positioning
        assertNotNull("the activity did not start positioning: ${activity.statusText}", p)
        assertEquals(0, activity.shownFloor)
        // A tap on floor 1 (what FloorPlanView.onTap does), through setPosition.
        assertTrue("not started: ${activity.statusText}", p!!.isRunning)
        p.setPosition(5.0, 6.0, 1)
        assertTrue("no pose on floor 1 shown: ${activity.poseText}", RoboSupport.idleUntil { activity.shownFloor == 1 })
        assertTrue(activity.poseText, activity.poseText.startsWith("floor 1 "))
        assertTrue("lat/lon missing: ${activity.poseText}", activity.poseText.contains("48.0000"))
        // the default engine (tcpf) estimates the phone's offset; the pose line shows it
        assertTrue("no phone offset shown: ${activity.poseText}", activity.poseText.contains(" phone RSSI "))
        assertTrue(activity.statusText, activity.statusText.startsWith("positioning") || activity.statusText.startsWith("waiting"))
        // Rotation: the positioning object carries over, listeners do not pile up.
        controller.recreate()
        val again = controller.get()
        assertSame(p, again.positioning)
        assertEquals(1, p.poseListenerCount)
        assertEquals(1, p.statusListenerCount)
        assertTrue(RoboSupport.idleUntil { again.shownFloor == 1 })
        // Finishing the activity stops positioning and releases the sensors.
        controller.pause().stop().destroy()
        val sensors = shadowOf(app.getSystemService(Context.SENSOR_SERVICE) as SensorManager)
        // close() returns at once; the control thread releases everything
        assertTrue(RoboSupport.idleUntil { !p.isRunning && sensors.listeners.isEmpty() })
        assertEquals(0, p.poseListenerCount)
    }

    @Test
    fun aDeniedPermissionIsExplainedOnTheStatusLine() {
        shadowOf(app).denyPermissions(Manifest.permission.BLUETOOTH_SCAN, Manifest.permission.ACCESS_FINE_LOCATION, Manifest.permission.ACCESS_COARSE_LOCATION)
        shadowOf(app.getSystemService(Context.SENSOR_SERVICE) as SensorManager)
            .addSensor(org.robolectric.shadows.ShadowSensor.newInstance(Sensor.TYPE_ACCELEROMETER))
        val controller = launch(twoFloorSite())
        val activity = controller.get()
        assertTrue(
            activity.statusText,
            RoboSupport.idleUntil { activity.statusText.contains("missing permission") && activity.statusText.contains("tap where you are") },
        )
        controller.pause().stop().destroy()
    }
}
