package io.fpbp.robo

import io.fpbp.android.configWithDevice
import org.json.JSONObject
import org.junit.Assert.assertEquals
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.annotation.Config

/** The phone model reaches the engine config (`device`) unless the app names one. */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class ConfigDeviceRoboTest {
    @Test
    fun thePhoneModelIsAddedUnlessTheConfigNamesOne() {
        assertEquals("SM-G930F", JSONObject(configWithDevice("", "SM-G930F")).getString("device"))
        val withSeed = JSONObject(configWithDevice("{\"seed\": 7}", " Pixel 7\n"))
        assertEquals("Pixel 7", withSeed.getString("device"))
        assertEquals(7, withSeed.getInt("seed"))
        val named = "{\"device\": \"mine\"}"
        assertEquals(named, configWithDevice(named, "SM-G930F"))
        assertEquals("{\"seed\": 7}", configWithDevice("{\"seed\": 7}", null))
        assertEquals("{\"seed\": 7}", configWithDevice("{\"seed\": 7}", " "))
        // not a JSON object: left for the engine to report
        assertEquals("[1]", configWithDevice("[1]", "SM-G930F"))
        assertEquals("{oops", configWithDevice("{oops", "SM-G930F"))
        assertEquals(64, JSONObject(configWithDevice("", "m".repeat(100))).getString("device").length)
    }
}
