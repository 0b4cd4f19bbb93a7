package io.fpbp.robo

import android.Manifest
import android.app.NotificationManager
import android.content.Context
import android.hardware.Sensor
import io.fpbp.PositioningState
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpPositioningService
import org.junit.Assert.assertEquals
import org.junit.Assert.assertFalse
import org.junit.Assert.assertNotNull
import org.junit.Assert.assertTrue
import org.junit.Before
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.Shadows.shadowOf
import org.robolectric.android.controller.ServiceController
import org.robolectric.annotation.Config
import java.util.concurrent.TimeUnit

/**
 * Issue 60, item 3: the foreground service ends with the positioning it
 * serves. Before the fix `stop()` and an engine failure left the service in
 * the foreground with its notification, against the documented contract.
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class ServiceLifecycleTest : OpenSitePositioningTest() {
    private val notifications get() = shadowOf(app.getSystemService(Context.NOTIFICATION_SERVICE) as NotificationManager)

    @Before
    fun grant() {
        shadowOf(app).grantPermissions(Manifest.permission.ACCESS_FINE_LOCATION, Manifest.permission.ACCESS_COARSE_LOCATION)
    }

    @Test
    fun stopEndsTheServiceAndRemovesItsNotification() {
        val p = start()
        val service = inTheForeground(p)
        p.stop().get(30, TimeUnit.SECONDS)
        assertEnded(service)
        service.destroy()
    }

    @Test
    @Config(shadows = [PanickingSensorShadow::class])
    fun anEngineFailureEndsTheServiceAndRemovesItsNotification() {
        val p = start()
        val service = inTheForeground(p)
        p.onSensor(Sensor.TYPE_ACCELEROMETER, 1, doubleArrayOf(0.0, 0.0, 9.81))
        assertTrue(p.status.toString(), RoboSupport.idleUntil { p.status.state == PositioningState.FAILED })
        assertEnded(service)
        service.destroy()
    }

    @Test
    fun aStartCommandAfterTheStopEntersTheForegroundThenStops() {
        val p = start()
        p.startForegroundService("walking")
        val intent = assertStarted()
        p.stop().get(30, TimeUnit.SECONDS)
        // the command arrives late: startForeground (the contract), then stop
        val service = Robolectric.buildService(FpbpPositioningService::class.java, intent).create().startCommand(0, 1)
        val shadow = shadowOf(service.get())
        assertEquals(FpbpPositioningService.NOTIFICATION_ID, shadow.lastForegroundNotificationId)
        assertTrue(shadow.isForegroundStopped)
        assertTrue(shadow.isStoppedBySelf)
        assertFalse(FpbpPositioningService.isForeground)
        assertEquals(0, notifications.size())
        service.destroy()
    }

    @Test
    fun closeEndsTheServiceToo() {
        val p = start()
        val service = inTheForeground(p)
        p.closeAsync().get(30, TimeUnit.SECONDS)
        assertEnded(service)
        service.destroy()
    }

    /** Starts the service for [p] and runs its start command: in the foreground with its notification. */
    private fun inTheForeground(p: FpbpPositioning): ServiceController<FpbpPositioningService> {
        p.startForegroundService("walking")
        val intent = assertStarted()
        val service = Robolectric.buildService(FpbpPositioningService::class.java, intent).create().startCommand(0, 1)
        assertTrue(FpbpPositioningService.isForeground)
        assertEquals("the notification is not shown", 1, notifications.size())
        assertTrue(RoboSupport.idleUntil { p.foregroundMode })
        return service
    }

    private fun assertStarted(): android.content.Intent {
        val intent = shadowOf(app).nextStartedService
        assertNotNull("startForegroundService sent no intent", intent)
        return intent
    }

    private fun assertEnded(service: ServiceController<FpbpPositioningService>) {
        val shadow = shadowOf(service.get())
        assertTrue("the service did not stop", RoboSupport.idleUntil { shadow.isStoppedBySelf })
        assertEquals(FpbpPositioningService::class.java.name, shadowOf(app).nextStoppedService?.component?.className)
        assertTrue("the service stayed in the foreground", shadow.isForegroundStopped)
        assertFalse(FpbpPositioningService.isForeground)
        assertEquals("the notification stayed", 0, notifications.size())
    }
}
