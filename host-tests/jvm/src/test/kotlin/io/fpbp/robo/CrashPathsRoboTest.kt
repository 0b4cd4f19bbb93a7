package io.fpbp.robo

import android.Manifest
import android.app.ForegroundServiceStartNotAllowedException
import android.content.ComponentName
import android.content.Context
import android.content.ContextWrapper
import android.content.Intent
import android.hardware.Sensor
import android.hardware.SensorManager
import android.location.LocationManager
import io.fpbp.FpbpEngine
import io.fpbp.FpbpNativeException
import io.fpbp.PositioningState
import io.fpbp.Problem
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpPositioningService
import org.junit.Assert.assertEquals
import org.junit.Assert.assertFalse
import org.junit.Assert.assertNotNull
import org.junit.Assert.assertNull
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.annotation.Implementation
import org.robolectric.annotation.Implements
import org.robolectric.shadows.SensorEventBuilder
import org.robolectric.shadows.ShadowSensor
import java.util.concurrent.CountDownLatch
import java.util.concurrent.ExecutionException
import java.util.concurrent.TimeUnit

/**
 * An engine whose every sensor call fails as one whose lock a panic
 * poisoned does: with FpbpNativeException, the exception libfpbp throws then
 * (NativeErrorsTest checks on the plain JVM that a native panic arrives as
 * one; under Robolectric's sandbox the test-only self-test hooks do not
 * link, so the shadow throws it itself).
 */
@Implements(value = FpbpEngine::class, isInAndroidSdk = false)
class PanickingSensorShadow {
    @Implementation
    fun onSensor(sensorType: Int, tNs: Long, values: DoubleArray): Unit = throw FpbpNativeException(POISONED)
}

/** The message libfpbp gives a call on an engine a panic poisoned. */
private const val POISONED = "engine state poisoned by an earlier panic"

/** An engine whose task runs fail with libfpbp's FpbpNativeException. */
@Implements(value = FpbpEngine::class, isInAndroidSdk = false)
class PanickingTaskShadow {
    @Implementation
    fun runRadio(tNs: Long): Unit = throw FpbpNativeException(POISONED)

    @Implementation
    fun runFusion(tNs: Long): Unit = throw FpbpNativeException(POISONED)
}

/**
 * The crash paths of issue 37, each closed: the foreground-service contract,
 * an engine failure on a sensor or task thread, location switched off after
 * start, lifecycle calls that waited for the control thread, and a dropped
 * instance that leaked its engine and threads. Each test failed on the code
 * before the fix (crash, exception on the caller, or no status).
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class CrashPathsRoboTest : OpenSitePositioningTest() {
    private val fine = Manifest.permission.ACCESS_FINE_LOCATION
    private val coarse = Manifest.permission.ACCESS_COARSE_LOCATION

    @Test
    fun serviceWithoutFineEntersTheForegroundThenStopsAndReports() {
        // guards: stopSelf without startForeground after startForegroundService
        // (ForegroundServiceDidNotStartInTimeException on a phone)
        shadowOf(app).grantPermissions(fine, coarse)
        val p = start()
        p.startForegroundService("walking")
        val intent = shadowOf(app).nextStartedService
        assertNotNull(intent)
        shadowOf(app).denyPermissions(fine)
        val controller = Robolectric.buildService(FpbpPositioningService::class.java, intent).create().startCommand(0, 7)
        val shadow = shadowOf(controller.get())
        assertEquals("startForeground was not called", FpbpPositioningService.NOTIFICATION_ID, shadow.lastForegroundNotificationId)
        assertTrue(shadow.isForegroundStopped)
        assertTrue(shadow.isStoppedBySelf)
        assertFalse(FpbpPositioningService.isForeground)
        assertTrue(p.status.toString(), RoboSupport.idleUntil { Problem.FOREGROUND_SERVICE_REFUSED in p.status.problems })
        assertTrue(p.status.describe(), p.status.messages[Problem.FOREGROUND_SERVICE_REFUSED]!!.contains("ACCESS_FINE_LOCATION"))
        controller.destroy()
    }

    @Test
    fun aStartForegroundRefusedInTheServiceIsAStatus() {
        // guards: ForegroundServiceStartNotAllowedException from startForeground ended the app
        shadowOf(app).grantPermissions(fine, coarse)
        val p = start()
        p.startForegroundService("walking")
        val intent = shadowOf(app).nextStartedService
        val controller = Robolectric.buildService(FpbpPositioningService::class.java, intent).create()
        shadowOf(controller.get()).setThrowInStartForeground(ForegroundServiceStartNotAllowedException("from the background"))
        controller.startCommand(0, 3)
        assertTrue(shadowOf(controller.get()).isStoppedBySelf)
        assertFalse(FpbpPositioningService.isForeground)
        assertTrue(RoboSupport.idleUntil { Problem.FOREGROUND_SERVICE_REFUSED in p.status.problems })
        assertTrue(p.status.describe(), p.status.describe().contains("from the background"))
        controller.destroy()
    }

    @Test
    fun theFacadeDoesNotStartTheServiceWithoutFine() {
        shadowOf(app).denyPermissions(fine)
        val p = start()
        p.startForegroundService("walking")
        assertNull("startForegroundService was called without FINE", shadowOf(app).nextStartedService)
        assertTrue(RoboSupport.idleUntil { Problem.FOREGROUND_SERVICE_REFUSED in p.status.problems })
        assertTrue(p.status.describe(), p.status.describe().contains("foreground service refused"))
    }

    @Test
    fun aServiceStartRefusedFromTheBackgroundIsAStatus() {
        // guards: ForegroundServiceStartNotAllowedException (12+) thrown into the app
        shadowOf(app).grantPermissions(fine, coarse)
        val refusing = object : ContextWrapper(app) {
            override fun getApplicationContext(): Context = this
            override fun startForegroundService(service: Intent): ComponentName? =
                throw ForegroundServiceStartNotAllowedException("app is in the background")
        }
        val p = FpbpPositioning(refusing, RoboSupport.openSite).also { positioning = it }
        p.start().get(30, TimeUnit.SECONDS)
        p.startForegroundService("walking")
        assertTrue(RoboSupport.idleUntil { Problem.FOREGROUND_SERVICE_REFUSED in p.status.problems })
        assertTrue(
            p.status.toString(),
            p.status.messages[Problem.FOREGROUND_SERVICE_REFUSED]!!.contains("ForegroundServiceStartNotAllowedException"),
        )
        assertTrue("positioning goes on", p.isRunning)
    }

    @Test
    @Config(shadows = [PanickingSensorShadow::class])
    fun anEngineFailureOnTheSensorThreadBecomesAStatus() {
        // guards: feed() caught only IllegalStateException; FpbpNativeException
        // on the sensor thread ended the process
        val manager = app.getSystemService(Context.SENSOR_SERVICE) as SensorManager
        val sensors = shadowOf(manager)
        sensors.addSensor(ShadowSensor.newInstance(Sensor.TYPE_ACCELEROMETER))
        val p = start()
        assertTrue(RoboSupport.idleUntil { sensors.listeners.isNotEmpty() })
        val acc = manager.getDefaultSensor(Sensor.TYPE_ACCELEROMETER)!!
        // the library's own sensor listener, then the app-fed path: neither throws
        sensors.sendSensorEventToListeners(
            SensorEventBuilder.newBuilder().setSensor(acc).setValues(floatArrayOf(0f, 0f, 9.81f)).setTimestamp(1).build(),
        )
        p.onSensor(Sensor.TYPE_ACCELEROMETER, 2, doubleArrayOf(0.0, 0.0, 9.81))
        assertTrue(p.status.toString(), RoboSupport.idleUntil { p.status.state == PositioningState.FAILED })
        assertTrue(p.status.failure!!, p.status.failure!!.startsWith(FpbpNativeException::class.java.simpleName))
        assertTrue(p.status.describe(), p.status.describe().startsWith("failed: "))
        assertFalse("the failed engine was not stopped", p.isRunning)
        assertTrue("sensors kept after the failure", sensors.listeners.isEmpty())
        // a late sample is dropped quietly
        p.onSensor(Sensor.TYPE_ACCELEROMETER, 3, doubleArrayOf(0.0, 0.0, 9.81))
    }

    @Test
    @Config(shadows = [PanickingTaskShadow::class])
    fun aFailedTaskBecomesAStatus() {
        // guards: TaskScheduler.lastError was never read; poses just stopped
        val p = start()
        assertTrue(p.status.toString(), RoboSupport.idleUntil { p.status.state == PositioningState.FAILED })
        assertTrue(p.status.failure!!, p.status.failure!!.contains(POISONED))
        assertFalse(p.isRunning)
        // start() tries again (and fails again the same way here)
        p.start().get(30, TimeUnit.SECONDS)
        assertTrue(RoboSupport.idleUntil { p.status.state == PositioningState.FAILED && !p.isRunning })
    }

    @Test
    fun aBadSiteFailsTheStartFutureAndTheStatus() {
        val p = FpbpPositioning(app, FpbpPositioning.Site("{ \"format\": ", RoboSupport.openSite.dir)).also { positioning = it }
        val e = try {
            p.start().get(30, TimeUnit.SECONDS)
            null
        } catch (x: ExecutionException) {
            x.cause
        }
        assertTrue("$e", e is IllegalArgumentException)
        assertEquals(PositioningState.FAILED, p.status.state)
        assertTrue(p.status.failure!!, p.status.failure!!.contains("site.json"))
    }

    @Test
    fun locationSwitchedOffAfterStartIsNoticed() {
        // guards: LOCATION_OFF was checked once at start only
        shadowOf(app).grantPermissions(Manifest.permission.BLUETOOTH_SCAN, fine, coarse)
        val lm = app.getSystemService(Context.LOCATION_SERVICE) as LocationManager
        shadowOf(lm).setLocationEnabled(true)
        val p = start()
        assertFalse(Problem.LOCATION_OFF in p.status.problems)
        shadowOf(lm).setLocationEnabled(false)
        app.sendBroadcast(Intent(LocationManager.MODE_CHANGED_ACTION))
        assertTrue(p.status.toString(), RoboSupport.idleUntil { Problem.LOCATION_OFF in p.status.problems })
        shadowOf(lm).setLocationEnabled(true)
        app.sendBroadcast(Intent(LocationManager.PROVIDERS_CHANGED_ACTION))
        assertTrue(p.status.toString(), RoboSupport.idleUntil { Problem.LOCATION_OFF !in p.status.problems })
    }

    @Test
    fun lifecycleCallsDoNotWaitForABusyControlThread() {
        // guards: start/stop/pause/resume waited for the control thread (up to 30 s)
        val p = start()
        val held = CountDownLatch(1)
        val gate = CountDownLatch(1)
        // a direct-executor status listener runs on the control thread: hold it there
        p.addStatusListener({ it.run() }) { s ->
            if (s.state == PositioningState.PAUSED) {
                held.countDown()
                gate.await(60, TimeUnit.SECONDS)
            }
        }
        val paused = p.pause()
        assertTrue(held.await(30, TimeUnit.SECONDS))
        val resumed = p.resume()
        val moved = p.setPosition(10.0, 6.0, 0)
        val stopped = p.stop()
        val closed = p.closeAsync()
        assertEquals("a call waited for the held control thread", 1L, gate.count)
        assertFalse(stopped.isDone)
        gate.countDown()
        paused.get(30, TimeUnit.SECONDS)
        resumed.get(30, TimeUnit.SECONDS)
        moved.get(30, TimeUnit.SECONDS)
        stopped.get(30, TimeUnit.SECONDS)
        closed.get(30, TimeUnit.SECONDS)
        assertFalse(p.isRunning)
        val late = try {
            p.start().get(30, TimeUnit.SECONDS)
            null
        } catch (x: ExecutionException) {
            x.cause
        }
        assertTrue("start after close: $late", late is IllegalStateException)
    }

    @Test
    fun aRefusedPositionIsAStatus() {
        val p = start()
        val e = try {
            p.setPosition(500.0, 500.0, 0).get(30, TimeUnit.SECONDS)
            null
        } catch (x: ExecutionException) {
            x.cause
        }
        assertTrue("$e", e is IllegalArgumentException)
        assertTrue(p.status.toString(), Problem.POSITION_REFUSED in p.status.problems)
        p.setPosition(10.0, 6.0, 0).get(30, TimeUnit.SECONDS)
        assertFalse(p.status.toString(), Problem.POSITION_REFUSED in p.status.problems)
    }

    @Test
    fun aForgottenPositioningReleasesItsEngineAndThreads() {
        // guards: no Cleaner: a dropped instance kept its engine, sensors and threads
        val manager = app.getSystemService(Context.SENSOR_SERVICE) as SensorManager
        val sensors = shadowOf(manager)
        sensors.addSensor(ShadowSensor.newInstance(Sensor.TYPE_ACCELEROMETER))
        val control = startAndDrop()
        assertTrue(RoboSupport.idleUntil { sensors.listeners.isNotEmpty() || !control.isAlive })
        var n = 0
        while (control.isAlive && n++ < 200) {
            System.gc()
            Thread.sleep(50)
        }
        assertFalse("the control thread of a dropped FpbpPositioning still runs", control.isAlive)
        assertTrue("sensors still registered", sensors.listeners.isEmpty())
    }

    /** Starts an instance and returns its control thread, keeping no reference to the instance. */
    private fun startAndDrop(): Thread {
        val p = FpbpPositioning(app, RoboSupport.openSite)
        p.start().get(30, TimeUnit.SECONDS)
        return p.controlThread
    }
}
