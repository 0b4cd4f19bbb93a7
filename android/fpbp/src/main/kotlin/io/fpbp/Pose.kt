package io.fpbp

/**
 * An engine's position estimate.
 *
 * @property tNs time of the estimate, elapsedRealtime nanoseconds.
 * @property xM position in the site's map frame (MCS) of [floor], metres (x right).
 * @property yM metres, y up.
 * @property floor floor id as in site.json.
 * @property headingRad walking heading in the MCS, radians, atan2(dy, dx).
 * @property accuracyM radius within which the user is believed to be (about 68 %), metres.
 */
data class Pose(
    val tNs: Long,
    val xM: Double,
    val yM: Double,
    val floor: Int,
    val headingRad: Double,
    val accuracyM: Double,
) {
    companion object {
        /** Builds a pose from [NativeBridge.getPose]'s return value and array; null for [NativeBridge.NO_POSE]. */
        fun fromNative(tNs: Long, v: DoubleArray): Pose? =
            if (tNs == NativeBridge.NO_POSE) null else Pose(tNs, v[0], v[1], v[2].toInt(), v[3], v[4])
    }
}

/**
 * A start position handed to the engine (a tap on the map, a QR code).
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
