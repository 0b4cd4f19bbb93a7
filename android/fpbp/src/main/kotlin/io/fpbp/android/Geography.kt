@file:JvmName("Geography")

package io.fpbp.android

import android.location.Location
import android.os.Bundle
import android.os.SystemClock
import io.fpbp.Pose
import io.fpbp.SiteGeo

/** Extras keys of [toLocation] (`Location.getExtras()`). */
object LocationExtras {
    /** Floor id as in site.json (Int). */
    const val FLOOR = "io.fpbp.floor"

    /** Probability that the floor is right, in [0, 1] (Double). */
    const val FLOOR_PROB = "io.fpbp.floor_prob"

    /** Map-frame x, metres (Double). */
    const val X_M = "io.fpbp.x_m"

    /** Map-frame y, metres (Double). */
    const val Y_M = "io.fpbp.y_m"

    /** What the pose rests on: `PoseSource.name` (String). */
    const val SOURCE = "io.fpbp.source"
}

/** Provider name of the locations [toLocation] makes. */
const val FPBP_PROVIDER = "fpbp"

/** The site's map <-> WGS-84 conversion from site.json's `georef` and `map_from_enu_rad`; null without a georef. */
fun FpbpPositioning.Site.geo(): SiteGeo? = siteGeo(json)

/**
 * This pose as an `android.location.Location` (provider [provider]):
 * latitude/longitude (the pose's, through the site's georef), accuracy
 * ([Pose.accuracyM], 68 % radius), bearing ([Pose.bearingDeg], when
 * finite), elapsed-realtime time ([Pose.tNs]) and wall-clock time (now
 * minus the pose's age), and in the extras ([LocationExtras]) the floor,
 * its probability, the map-frame x/y and the source. Null when the site has
 * no georef (the pose has no latitude).
 */
@JvmOverloads
fun Pose.toLocation(provider: String = FPBP_PROVIDER): Location? {
    val lat = latDeg ?: return null
    val lon = lonDeg ?: return null
    val l = Location(provider)
    l.latitude = lat
    l.longitude = lon
    if (accuracyM.isFinite() && accuracyM >= 0) l.accuracy = accuracyM.toFloat()
    if (bearingDeg.isFinite()) l.bearing = bearingDeg.toFloat()
    l.elapsedRealtimeNanos = tNs
    val ageMs = (SystemClock.elapsedRealtimeNanos() - tNs) / 1_000_000
    l.time = System.currentTimeMillis() - ageMs
    l.extras = Bundle().apply {
        putInt(LocationExtras.FLOOR, floor)
        putDouble(LocationExtras.FLOOR_PROB, floorProb)
        putDouble(LocationExtras.X_M, xM)
        putDouble(LocationExtras.Y_M, yM)
        putString(LocationExtras.SOURCE, source.name)
    }
    return l
}
