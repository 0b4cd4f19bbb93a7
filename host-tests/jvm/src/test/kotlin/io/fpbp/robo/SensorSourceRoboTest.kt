package io.fpbp.robo

import android.content.Context
import android.hardware.Sensor
import android.hardware.SensorManager
import io.fpbp.Problem
import io.fpbp.android.FpbpPositioning
import org.junit.Assert.assertEquals
import org.junit.Assert.assertFalse
import org.junit.Assert.assertTrue
import org.junit.Before
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.shadows.SensorEventBuilder
import org.robolectric.shadows.ShadowSensor
import org.robolectric.shadows.ShadowSensorManager
import java.util.concurrent.TimeUnit

/** The library's sensor source on the Android framework, feeding the real libfpbp. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class SensorSourceRoboTest : OpenSitePositioningTest() {
    private lateinit var sensors: ShadowSensorManager

    @Before
    fun setUp() {
        sensors = shadowOf(app.getSystemService(Context.SENSOR_SERVICE) as SensorManager)
        // A phone with an accelerometer and a gyroscope only.
        sensors.addSensor(ShadowSensor.newInstance(Sensor.TYPE_ACCELEROMETER))
        sensors.addSensor(ShadowSensor.newInstance(Sensor.TYPE_GYROSCOPE))
    }

    @Test
    fun sensorEventsReachTheEngineAndMissingSensorsAreReported() {
        val p = start()
        assertTrue("no sensor listener", RoboSupport.idleUntil { sensors.listeners.isNotEmpty() })
        val manager = app.getSystemService(Context.SENSOR_SERVICE) as SensorManager
        val accSensor = manager.getDefaultSensor(Sensor.TYPE_ACCELEROMETER)!!
        val gyrSensor = manager.getDefaultSensor(Sensor.TYPE_GYROSCOPE)!!
        for (k in 1..20) {
            val t = k * 20_000_000L
            sensors.sendSensorEventToListeners(
                SensorEventBuilder.newBuilder().setSensor(accSensor).setValues(floatArrayOf(0.1f, 0.2f, 9.81f)).setTimestamp(t).build(),
            )
            sensors.sendSensorEventToListeners(
                SensorEventBuilder.newBuilder().setSensor(gyrSensor).setValues(floatArrayOf(0.0f, 0.01f, 0.0f)).setTimestamp(t).build(),
            )
        }
        assertTrue(RoboSupport.idleUntil { p.stats()?.sensorEvents == 40L })
        assertEquals(0L, p.stats()?.bridgeRejected)
        val s = p.status
        assertTrue(Problem.SENSOR_MISSING in s.problems)
        assertEquals(
            listOf(Sensor.TYPE_MAGNETIC_FIELD, Sensor.TYPE_ROTATION_VECTOR, Sensor.TYPE_GAME_ROTATION_VECTOR, Sensor.TYPE_PRESSURE),
            s.missingSensors,
        )
    }

    @Test
    fun stopUnregistersEverySensorListener() {
        val p = start()
        assertTrue(RoboSupport.idleUntil { sensors.listeners.isNotEmpty() })
        p.stop().get(30, TimeUnit.SECONDS)
        assertTrue("sensor listeners left after stop: ${sensors.listeners}", sensors.listeners.isEmpty())
        assertFalse(p.isRunning)
    }

    @Test
    fun pauseReleasesTheSensorsAndResumeTakesThemBack() {
        val p = start()
        assertTrue(RoboSupport.idleUntil { sensors.listeners.isNotEmpty() })
        p.pause().get(30, TimeUnit.SECONDS)
        assertTrue(sensors.listeners.isEmpty())
        assertTrue(p.isRunning)
        p.resume()
        assertTrue(RoboSupport.idleUntil { sensors.listeners.isNotEmpty() })
    }
}
