package io.fpbp.android

import android.app.Notification
import android.app.NotificationChannel
import android.app.NotificationManager
import android.app.Service
import android.content.Intent
import android.content.pm.PackageManager
import android.content.pm.ServiceInfo
import android.os.Build
import android.os.IBinder
import io.fpbp.RadioPermissions
import java.lang.ref.WeakReference

/**
 * The foreground service of [FpbpPositioning.startForegroundService]: keeps
 * the process and its positioning alive while the app is off screen, as
 * service type `location` (declared in the library's manifest with
 * FOREGROUND_SERVICE and FOREGROUND_SERVICE_LOCATION). Android 14+ refuses
 * a location foreground service without a granted location permission, so
 * the service stops itself in that case instead of crashing. Holds the
 * positioning weakly: the app owns it.
 */
class FpbpPositioningService : Service() {
    companion object {
        const val EXTRA_TITLE = "io.fpbp.android.TITLE"
        const val CHANNEL_ID = "fpbp-positioning"
        const val NOTIFICATION_ID = 0x0F9B

        @Volatile private var target: WeakReference<FpbpPositioning>? = null

        internal fun attach(p: FpbpPositioning) {
            target = WeakReference(p)
        }

        internal fun attached(): FpbpPositioning? = target?.get()

        /** Whether a service instance is in the foreground now (tests, diagnostics). */
        @Volatile
        @JvmStatic
        var isForeground: Boolean = false
            private set
    }

    override fun onBind(intent: Intent?): IBinder? = null

    override fun onStartCommand(intent: Intent?, flags: Int, startId: Int): Int {
        val granted = checkSelfPermission(RadioPermissions.ACCESS_FINE_LOCATION) == PackageManager.PERMISSION_GRANTED
        if (!granted) {
            // Android 14+ throws SecurityException for a location service without it.
            stopSelf(startId)
            return START_NOT_STICKY
        }
        val title = intent?.getStringExtra(EXTRA_TITLE) ?: "Indoor positioning"
        val notification = notification(title)
        if (Build.VERSION.SDK_INT >= 29) {
            startForeground(NOTIFICATION_ID, notification, ServiceInfo.FOREGROUND_SERVICE_TYPE_LOCATION)
        } else {
            startForeground(NOTIFICATION_ID, notification)
        }
        isForeground = true
        attached()?.setServiceMode(true)
        return START_NOT_STICKY
    }

    override fun onDestroy() {
        attached()?.setServiceMode(false)
        isForeground = false
        if (Build.VERSION.SDK_INT >= 24) stopForeground(STOP_FOREGROUND_REMOVE) else @Suppress("DEPRECATION") stopForeground(true)
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
