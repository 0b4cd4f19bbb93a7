package io.fpbp.android

import android.os.Build

/**
 * The phone model's name, the one key of a phone model everywhere: the
 * engine config's `device` ([FpbpPositioning]), a survey's and a recorded
 * log's `#meta device=` ([FpbpSurvey], the sample app), and so the radio
 * map's `device_offsets` that `fpbp calibrate` learns from those surveys
 * and `fpbp eval` applies to a log.
 *
 * The name is `Build.MANUFACTURER` and `Build.MODEL`, each without control
 * characters and trimmed, joined by one space (`Google Pixel 7`, `samsung
 * SM-G930F`), at most [MAX_CHARS] characters. Surveys recorded by
 * [FpbpSurvey] before this name carried `Build.MODEL` alone; the engine's
 * lookup also finds such a map's entry (docs/formats.md, `device_offsets`).
 */
object DeviceModel {
    /** Longest name, characters (the radio map's limit). */
    const val MAX_CHARS: Int = 64

    /** This phone's name, null when Android gives no model. */
    @JvmStatic
    fun canonical(): String? = canonical(Build.MANUFACTURER, Build.MODEL)

    /** The name of [model] made by [manufacturer]; null when [model] is blank. */
    @JvmStatic
    fun canonical(manufacturer: String?, model: String?): String? {
        val m = clean(model)
        if (m.isEmpty()) return null
        val name = listOf(clean(manufacturer), m).filter { it.isNotEmpty() }.joinToString(" ")
        if (name.length <= MAX_CHARS) return name
        // never end on half a surrogate pair
        val cut = if (Character.isHighSurrogate(name[MAX_CHARS - 1])) MAX_CHARS - 1 else MAX_CHARS
        return name.take(cut).trimEnd()
    }

    private fun clean(s: String?): String = s?.filterNot { it.isISOControl() }?.trim().orEmpty()
}
