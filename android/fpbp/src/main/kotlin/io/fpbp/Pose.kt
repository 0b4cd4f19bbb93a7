package io.fpbp

/** What a [Pose] rests on (rust/core `PoseSource`). */
enum class PoseSource(val code: Int) {
    /** Radio only (BLE/WiFi positioning without motion). */
    RADIO(0),

    /** Motion sensors from a start or a set position, no radio correction lately. */
    DEAD_RECKONING(1),

    /** Radio and motion (and the map) fused. */
    FUSED(2),
    ;

    companion object {
        /** The source of [code]; [FUSED] for a code this library does not know. */
        @JvmStatic
        fun fromCode(code: Int): PoseSource = entries.firstOrNull { it.code == code } ?: FUSED
    }
}

/**
 * An engine's position estimate.
 *
 * @property tNs time of the estimate, elapsedRealtime nanoseconds (the clock of
 *   `SensorEvent.timestamp` and `ScanResult.getTimestampNanos()`).
 * @property xM position in the site's map frame (MCS) of [floor], metres (x right).
 * @property yM metres, y up.
 * @property floor floor id as in site.json.
 * @property floorProb probability that [floor] is right, in [0, 1].
 * @property headingRad walking heading in the MCS, radians, atan2(dy, dx).
 * @property bearingDeg the same heading as a bearing from true north, degrees
 *   clockwise in [0, 360) (through the site's `map_from_enu_rad`).
 * @property accuracyM radius within which the user is believed to be (about 68 %), metres.
 * @property latDeg WGS-84 latitude through the site's georef; null when the site has none.
 * @property lonDeg WGS-84 longitude; null when the site has no georef.
 * @property source what the estimate rests on.
 */
data class Pose(
    val tNs: Long,
    val xM: Double,
    val yM: Double,
    val floor: Int,
    val headingRad: Double,
    val accuracyM: Double,
    val floorProb: Double = 1.0,
    val source: PoseSource = PoseSource.FUSED,
    val latDeg: Double? = null,
    val lonDeg: Double? = null,
    val bearingDeg: Double = Double.NaN,
) {
    /** Age of the estimate at [nowNs] (same clock as [tNs]), ns. */
    fun ageNs(nowNs: Long): Long = nowNs - tNs

    /** Age of the estimate by [clock], ns. */
    fun ageNs(clock: Clock): Long = ageNs(clock.nowNs())

    /** Equal in every field but the time (delivery: "the pose changed"). */
    fun sameEstimate(other: Pose?): Boolean =
        other != null && xM == other.xM && yM == other.yM && floor == other.floor &&
            headingRad == other.headingRad && accuracyM == other.accuracyM &&
            floorProb == other.floorProb && source == other.source

    companion object {
        /** Builds a pose from [NativeBridge.getPose]'s array and time. */
        @JvmStatic
        fun fromNative(tNs: Long, v: DoubleArray): Pose {
            val lat = v[NativeBridge.POSE_LAT_DEG]
            val lon = v[NativeBridge.POSE_LON_DEG]
            val geo = lat.isFinite() && lon.isFinite()
            return Pose(
                tNs = tNs,
                xM = v[NativeBridge.POSE_X_M],
                yM = v[NativeBridge.POSE_Y_M],
                floor = v[NativeBridge.POSE_FLOOR].toInt(),
                headingRad = v[NativeBridge.POSE_HEADING_RAD],
                accuracyM = v[NativeBridge.POSE_ACCURACY_M],
                floorProb = v[NativeBridge.POSE_FLOOR_PROB],
                source = PoseSource.fromCode(v[NativeBridge.POSE_SOURCE].toInt()),
                latDeg = if (geo) lat else null,
                lonDeg = if (geo) lon else null,
                bearingDeg = v[NativeBridge.POSE_BEARING_DEG],
            )
        }
    }
}

/**
 * A position handed to the engine (a tap on the map, a QR code): at start, or
 * later through [FpbpEngine.setPosition].
 *
 * @property headingRad walking heading in the MCS when known, radians.
 */
data class InitialPosition(
    val xM: Double,
    val yM: Double,
    val floor: Int,
    val headingRad: Double? = null,
) {
    internal fun toNative(): DoubleArray =
        doubleArrayOf(xM, yM, floor.toDouble(), headingRad ?: Double.NaN)
}
