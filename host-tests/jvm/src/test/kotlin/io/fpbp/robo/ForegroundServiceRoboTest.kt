package io.fpbp.robo

import android.Manifest
import android.app.Application
import android.content.Intent
import android.content.pm.ServiceInfo
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpPositioningService
import org.junit.Assert.assertEquals
import org.junit.Assert.assertFalse
import org.junit.Assert.assertNotNull
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.RuntimeEnvironment
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config

/** The foreground service of type location starts, shows its notification, and stops. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class ForegroundServiceRoboTest {
    private val app: Application get() = RuntimeEnvironment.getApplication()

    @Test
    fun startsInTheForegroundAsLocationAndStops() {
        shadowOf(app).grantPermissions(Manifest.permission.ACCESS_FINE_LOCATION)
        val p = FpbpPositioning(app, RoboSupport.openSite)
        p.start().get(30, java.util.concurrent.TimeUnit.SECONDS)
        p.startForegroundService("walking")
        val started = shadowOf(app).nextStartedService
        assertNotNull("startForegroundService sent no intent", started)
        assertEquals(FpbpPositioningService::class.java.name, started.component?.className)
        val controller = Robolectric.buildService(FpbpPositioningService::class.java, started).create().startCommand(0, 1)
        val service = controller.get()
        val shadow = shadowOf(service)
        val n = shadow.lastForegroundNotification
        assertNotNull("no foreground notification", n)
        assertEquals("walking", n.extras.getString(android.app.Notification.EXTRA_TITLE))
        assertEquals(ServiceInfo.FOREGROUND_SERVICE_TYPE_LOCATION, service.foregroundServiceType)
        assertTrue(FpbpPositioningService.isForeground)
        p.stopForegroundService()
        assertEquals(FpbpPositioningService::class.java.name, shadowOf(app).nextStoppedService?.component?.className)
        controller.destroy()
        assertTrue(shadow.isForegroundStopped)
        assertFalse(FpbpPositioningService.isForeground)
        p.close()
    }

    @Test
    fun withoutLocationPermissionItStopsInsteadOfCrashing() {
        shadowOf(app).denyPermissions(Manifest.permission.ACCESS_FINE_LOCATION)
        val controller = Robolectric.buildService(FpbpPositioningService::class.java, Intent()).create().startCommand(0, 7)
        val shadow = shadowOf(controller.get())
        // startForeground first (the startForegroundService contract), then stop
        assertEquals(FpbpPositioningService.NOTIFICATION_ID, shadow.lastForegroundNotificationId)
        assertTrue(shadow.isForegroundStopped)
        assertTrue(shadow.isStoppedBySelf)
        assertFalse(FpbpPositioningService.isForeground)
    }
}
