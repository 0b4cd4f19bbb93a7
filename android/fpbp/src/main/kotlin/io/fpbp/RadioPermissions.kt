package io.fpbp

/** The radios positioning listens to. */
enum class Radio { BLE, WIFI }

/**
 * Which runtime permissions the chosen radios need on an API level (plain
 * JVM: the Android layer checks them with `Context.checkSelfPermission`).
 *
 * - BLE, Android 12+ (31): `BLUETOOTH_SCAN` declared WITHOUT
 *   `usesPermissionFlags="neverForLocation"` (that flag lets Android strip
 *   beacon advertisements from results) plus `ACCESS_FINE_LOCATION` (beacons
 *   locate the user); Android 6-11: `ACCESS_FINE_LOCATION` (the manifest's
 *   `BLUETOOTH`/`BLUETOOTH_ADMIN`, up to API 30, are install-time).
 * - WiFi: `ACCESS_FINE_LOCATION` for scan results; Android 13+ (33) also
 *   `NEARBY_WIFI_DEVICES` (declared without `neverForLocation`).
 * - Android 12+ (31): `ACCESS_FINE_LOCATION` is asked together with
 *   `ACCESS_COARSE_LOCATION` in one request (a request of FINE alone is
 *   ignored on 12+); the user may then grant only the approximate one, and
 *   FINE stays in the missing list.
 * - Background positioning (foreground service of type `location`, started
 *   while the app is visible) needs no `ACCESS_BACKGROUND_LOCATION`; the
 *   service's install-time `FOREGROUND_SERVICE` and, on 14+ (34),
 *   `FOREGROUND_SERVICE_LOCATION` are in the library's manifest.
 * - Android 13+: `POST_NOTIFICATIONS` lets the service's notification show
 *   (the service runs without it, the notification is then hidden).
 */
object RadioPermissions {
    const val ACCESS_FINE_LOCATION = "android.permission.ACCESS_FINE_LOCATION"
    const val ACCESS_COARSE_LOCATION = "android.permission.ACCESS_COARSE_LOCATION"
    const val BLUETOOTH_SCAN = "android.permission.BLUETOOTH_SCAN"
    const val NEARBY_WIFI_DEVICES = "android.permission.NEARBY_WIFI_DEVICES"
    const val POST_NOTIFICATIONS = "android.permission.POST_NOTIFICATIONS"

    /** Runtime permissions [radios] need on [apiLevel], in request order. */
    @JvmStatic
    fun required(apiLevel: Int, radios: Set<Radio>): List<String> {
        val out = LinkedHashSet<String>()
        fun location() {
            out.add(ACCESS_FINE_LOCATION)
            if (apiLevel >= 31) out.add(ACCESS_COARSE_LOCATION)
        }
        if (Radio.BLE in radios) {
            if (apiLevel >= 31) out.add(BLUETOOTH_SCAN)
            location()
        }
        if (Radio.WIFI in radios) {
            location()
            if (apiLevel >= 33) out.add(NEARBY_WIFI_DEVICES)
        }
        return out.toList()
    }

    /** Runtime permissions the foreground-service notification wants on [apiLevel] (optional). */
    @JvmStatic
    fun notification(apiLevel: Int): List<String> = if (apiLevel >= 33) listOf(POST_NOTIFICATIONS) else emptyList()
}
