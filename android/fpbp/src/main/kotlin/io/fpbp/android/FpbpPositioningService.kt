package io.fpbp.android

import android.app.Notification
import android.app.NotificationChannel
import android.app.NotificationManager
import android.app.Service
import android.content.Intent
import android.content.pm.PackageManager
import android.content.pm.ServiceInfo
import android.os.Build
import android.os.Handler
import android.os.IBinder
import android.os.Looper
import io.fpbp.RadioPermissions
import java.lang.ref.WeakReference

/** What the foreground service tells the positioning it serves. */
internal interface ForegroundClient {
    /** The service is (or is no longer) in the foreground. */
    fun setServiceMode(on: Boolean)

    /** The service could not enter the foreground; [message] says why. */
    fun foregroundRefused(message: String)
}

/**
 * The foreground service of [FpbpPositioning.startForegroundService]: keeps
 * the process and its positioning alive while the app is off screen, as
 * service type `location` (declared in the library's manifest with
 * FOREGROUND_SERVICE and FOREGROUND_SERVICE_LOCATION).
 *
 * The `startForegroundService` contract: once started that way, the service
 * must call `startForeground` within seconds, even to stop at once, or
 * Android ends the app (`ForegroundServiceDidNotStartInTimeException`). The
 * facade does not start it without ACCESS_FINE_LOCATION; if the permission
 * is missing here all the same, the service still enters the foreground
 * with its notification, then stops, and reports the refusal. A refused
 * `startForeground` (`ForegroundServiceStartNotAllowedException` on 12+ from
 * the background, SecurityException on 14+ without the permission) is caught
 * and reported the same way ([io.fpbp.Problem.FOREGROUND_SERVICE_REFUSED]).
 * Holds the positioning weakly: the app owns it. It ends with the
 * positioning it serves: `stop()`, `close()` or an engine failure removes
 * its notification and stops it, and a start command that arrives after
 * that enters the foreground (the contract) and stops at once.
 */
class FpbpPositioningService : Service() {
    companion object {
        const val EXTRA_TITLE = "io.fpbp.android.TITLE"
        const val CHANNEL_ID = "fpbp-positioning"
        const val NOTIFICATION_ID = 0x0F9B

        /** The refusal reason when ACCESS_FINE_LOCATION is not granted. */
        internal const val NO_PERMISSION =
            "ACCESS_FINE_LOCATION not granted: Android refuses a location foreground service without it"

        @Volatile private var target: WeakReference<ForegroundClient>? = null

        internal fun attach(p: ForegroundClient) {
            target = WeakReference(p)
        }

        internal fun detach(p: ForegroundClient) {
            if (attached() === p) target = null
        }

        internal fun attached(): ForegroundClient? = target?.get()

        /** The service in the foreground now, if any. */
        @Volatile private var running: WeakReference<FpbpPositioningService>? = null

        /**
         * [p] stopped: it is detached, and the running service leaves the
         * foreground, removes its notification and stops (on the main thread).
         */
        internal fun release(p: ForegroundClient) {
            if (attached() !== p) return
            target = null
            val s = running?.get() ?: return
            Handler(Looper.getMainLooper()).post { s.end() }
        }

        /** Whether a service instance is in the foreground now (tests, diagnostics). */
        @Volatile
        @JvmStatic
        var isForeground: Boolean = false
            private set
    }

    override fun onBind(intent: Intent?): IBinder? = null

    override fun onStartCommand(intent: Intent?, flags: Int, startId: Int): Int {
        val granted = checkSelfPermission(RadioPermissions.ACCESS_FINE_LOCATION) == PackageManager.PERMISSION_GRANTED
        val title = intent?.getStringExtra(EXTRA_TITLE) ?: "Indoor positioning"
        // startForeground first, whatever follows: the contract of startForegroundService
        val refusal = try {
            if (Build.VERSION.SDK_INT >= 29) {
                startForeground(NOTIFICATION_ID, notification(title), ServiceInfo.FOREGROUND_SERVICE_TYPE_LOCATION)
            } else {
                startForeground(NOTIFICATION_ID, notification(title))
            }
            if (granted) null else NO_PERMISSION
        } catch (e: IllegalStateException) {
            // ForegroundServiceStartNotAllowedException (12+, from the background) is one
            "${e.javaClass.simpleName}: ${e.message}"
        } catch (e: SecurityException) {
            // 14+: a location service without the permission
            "${e.javaClass.simpleName}: ${e.message}"
        }
        if (refusal != null) {
            attached()?.foregroundRefused(refusal)
            removeForeground()
            stopSelf(startId)
            return START_NOT_STICKY
        }
        val client = attached()
        if (client == null) {
            // the positioning stopped before this command arrived: nothing to keep alive
            removeForeground()
            stopSelf(startId)
            return START_NOT_STICKY
        }
        running = WeakReference(this)
        isForeground = true
        client.setServiceMode(true)
        return START_NOT_STICKY
    }

    /** Leaves the foreground (notification removed) and stops: the positioning it served stopped. */
    private fun end() {
        if (running?.get() === this) running = null
        isForeground = false
        removeForeground()
        stopSelf()
    }

    private fun removeForeground() {
        if (Build.VERSION.SDK_INT >= 24) stopForeground(STOP_FOREGROUND_REMOVE) else @Suppress("DEPRECATION") stopForeground(true)
    }

    override fun onDestroy() {
        if (running?.get() === this) running = null
        attached()?.setServiceMode(false)
        isForeground = false
        removeForeground()
        super.onDestroy()
    }

    private fun notification(title: String): Notification {
        val b = if (Build.VERSION.SDK_INT >= 26) {
            val nm = getSystemService(NotificationManager::class.java)
            nm?.createNotificationChannel(NotificationChannel(CHANNEL_ID, "Indoor positioning", NotificationManager.IMPORTANCE_LOW))
            Notification.Builder(this, CHANNEL_ID)
        } else {
            @Suppress("DEPRECATION")
            Notification.Builder(this)
        }
        return b.setContentTitle(title)
            .setSmallIcon(android.R.drawable.ic_menu_mylocation)
            .setOngoing(true)
            .build()
    }
}
