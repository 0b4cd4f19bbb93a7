package io.fpbp

import kotlin.math.PI
import kotlin.math.cos
import kotlin.math.sin

/** A WGS-84 position, degrees. */
data class LatLon(val latDeg: Double, val lonDeg: Double)

/** A point in the site's map frame (MCS), metres. */
data class MapPoint(val xM: Double, val yM: Double)

/**
 * Map (MCS) <-> WGS-84 through a site's georef, the same conversion as the
 * engine's pose lat/lon (rust/core/src/geo.rs): an equirectangular
 * projection at the georef's latitude with R = 6378137 m, then the rotation
 * `map_from_enu_rad` from east-north into the MCS. Accurate to centimetres
 * over a building (a few hundred metres from the georef point). Plain JVM.
 *
 * @property latDeg latitude of the georef point (site.json `georef.lat_deg`), degrees.
 * @property lonDeg longitude of the georef point (`georef.lon_deg`), degrees.
 * @property xM MCS x of the georef point (`georef.x_m`), metres.
 * @property yM MCS y of the georef point (`georef.y_m`), metres.
 * @property mapFromEnuRad rotation from east-north into the MCS, radians,
 *   counter-clockwise (site.json `map_from_enu_rad`, default 0).
 */
data class SiteGeo(
    val latDeg: Double,
    val lonDeg: Double,
    val xM: Double,
    val yM: Double,
    val mapFromEnuRad: Double = 0.0,
) {
    init {
        require(latDeg in -90.0..90.0) { "georef.lat_deg must be in [-90, 90], got $latDeg" }
        require(lonDeg in -180.0..180.0) { "georef.lon_deg must be in [-180, 180], got $lonDeg" }
        require(xM.isFinite() && yM.isFinite()) { "georef.x_m and y_m must be finite" }
        require(mapFromEnuRad.isFinite()) { "map_from_enu_rad must be finite" }
    }

    companion object {
        /** Earth radius of the projection, metres (WGS-84 a; rust/core `geo::EARTH_RADIUS_M`). */
        const val EARTH_RADIUS_M: Double = 6_378_137.0

        private const val M_PER_DEG = PI / 180.0 * EARTH_RADIUS_M

        /** Bearing from true north, degrees clockwise in [0, 360), of an MCS heading (radians). */
        @JvmStatic
        fun bearingDeg(headingRad: Double, mapFromEnuRad: Double): Double {
            val enuDeg = Math.toDegrees(headingRad - mapFromEnuRad)
            val b = (90.0 - enuDeg).mod(360.0)
            return if (b >= 360.0) 0.0 else b
        }
    }

    /** WGS-84 of the MCS point ([xM], [yM]). */
    fun toWgs84(xM: Double, yM: Double): LatLon {
        // east-north offset: rotate (p - georef) by -mapFromEnuRad
        val s = sin(-mapFromEnuRad)
        val c = cos(-mapFromEnuRad)
        val dx = xM - this.xM
        val dy = yM - this.yM
        val e = c * dx - s * dy
        val n = s * dx + c * dy
        return LatLon(latDeg + n / M_PER_DEG, lonDeg + e / (M_PER_DEG * cos(Math.toRadians(latDeg))))
    }

    /** WGS-84 of [p]. */
    fun toWgs84(p: MapPoint): LatLon = toWgs84(p.xM, p.yM)

    /** The MCS point of ([latDeg], [lonDeg]). */
    fun toMap(latDeg: Double, lonDeg: Double): MapPoint {
        val e = (lonDeg - this.lonDeg) * M_PER_DEG * cos(Math.toRadians(this.latDeg))
        val n = (latDeg - this.latDeg) * M_PER_DEG
        val s = sin(mapFromEnuRad)
        val c = cos(mapFromEnuRad)
        return MapPoint(xM + (c * e - s * n), yM + (s * e + c * n))
    }

    /** The MCS point of [p]. */
    fun toMap(p: LatLon): MapPoint = toMap(p.latDeg, p.lonDeg)

    /** MCS heading (radians, atan2(dy, dx)) of a bearing from true north (degrees clockwise). */
    fun headingRad(bearingDeg: Double): Double = Math.toRadians(90.0 - bearingDeg) + mapFromEnuRad

    /** Bearing from true north (degrees clockwise in [0, 360)) of an MCS heading. */
    fun bearingDeg(headingRad: Double): Double = bearingDeg(headingRad, mapFromEnuRad)
}
