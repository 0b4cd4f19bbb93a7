package io.fpbp.robo

import android.Manifest
import android.app.Application
import android.content.Intent
import io.fpbp.NativeLogReader
import io.fpbp.TestSupport
import io.fpbp.android.DeviceModel
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpSurvey
import io.fpbp.sample.MainActivity
import io.fpbp.sample.SurveyActivity
import org.junit.After
import org.junit.Assert.assertEquals
import org.junit.Assert.assertNull
import org.junit.Assert.assertTrue
import org.junit.Before
import org.junit.Rule
import org.junit.Test
import org.junit.rules.TemporaryFolder
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.RuntimeEnvironment
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.shadows.ShadowBuild
import java.io.File
import java.util.concurrent.TimeUnit

/**
 * Issue 60, item 1: one name of the phone model everywhere. The survey
 * recorder (the library's and the sample's survey screen), the sample's log
 * recorder and the engine config all say `Google Pixel 7`, and a radio map's
 * offsets for that name (or, from older surveys, for `Pixel 7` alone) reach
 * the engine started through the facade (EngineStats.deviceBleOffsetDb).
 * Before the fix the facade said `Pixel 7` while the sample's surveys said
 * `Google Pixel 7`: the offsets never applied.
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class DeviceModelTest {
    @get:Rule
    val tmp = TemporaryFolder()

    private val app: Application get() = RuntimeEnvironment.getApplication()
    private val started = mutableListOf<FpbpPositioning>()

    @Before
    fun phone() {
        ShadowBuild.setManufacturer("Google")
        ShadowBuild.setModel("Pixel 7")
    }

    @After
    fun closeAll() {
        for (p in started) p.closeAsync().get(30, TimeUnit.SECONDS)
    }

    @Test
    fun theNameIsManufacturerAndModel() {
        assertEquals("Google Pixel 7", DeviceModel.canonical())
        assertEquals("samsung SM-G930F", DeviceModel.canonical(" samsung ", "SM-G930F\n"))
        assertEquals("SM-G930F", DeviceModel.canonical(null, "SM-G930F"))
        assertEquals("SM-G930F", DeviceModel.canonical(" ", "SM-G930F"))
        assertNull(DeviceModel.canonical("Google", " "))
        assertNull(DeviceModel.canonical("Google", null))
        val long = DeviceModel.canonical("m".repeat(40), "x".repeat(40))!!
        assertEquals(DeviceModel.MAX_CHARS, long.length)
        // never half a surrogate pair at the cut
        val emoji = DeviceModel.canonical("a".repeat(62), "\uD83D\uDE00")!!
        assertEquals("a".repeat(62), emoji)
    }

    @Test
    fun surveysLogsAndTheEngineNameThePhoneAlike() {
        shadowOf(app).grantPermissions(
            Manifest.permission.BLUETOOTH_SCAN,
            Manifest.permission.ACCESS_FINE_LOCATION,
            Manifest.permission.ACCESS_COARSE_LOCATION,
        )
        val name = "Google Pixel 7"
        // the facade's engine config
        val p = positioning(FpbpPositioning.Site(TestSupport.openSiteJson, TestSupport.repo.path))
        assertEquals(name, p.device)
        // an app's config that names a model wins, and is what the facade reports
        val own = FpbpPositioning(app, RoboSupport.openSite, FpbpPositioning.Options(configJson = """{"device": "Lab phone"}"""))
        assertEquals("Lab phone", own.device)
        own.close()
        // the library's survey recorder, without a device of the app's
        val survey = FpbpSurvey(app, FpbpSurvey.Options(radios = emptySet()))
        val file = File(tmp.root, "survey.log")
        survey.start(file)
        survey.stop()
        survey.close()
        assertEquals(name, meta(file)["device"])
        // the sample's survey screen
        val demo = File(TestSupport.repo, "maps/demo")
        val screen = Robolectric.buildActivity(
            SurveyActivity::class.java,
            Intent(app, SurveyActivity::class.java).putExtra(SurveyActivity.EXTRA_SITE_DIR, demo.path),
        ).setup()
        screen.get().toggleRecording()
        screen.get().toggleRecording()
        val surveyed = checkNotNull(screen.get().lastFile) { screen.get().statusText }
        assertEquals(name, meta(surveyed)["device"])
        screen.pause().stop().destroy()
        // the sample's log recorder (what `fpbp eval` reads the model from)
        val main = Robolectric.buildActivity(
            MainActivity::class.java,
            Intent(app, MainActivity::class.java).putExtra(MainActivity.EXTRA_SITE_DIR, demo.path),
        ).setup()
        val a = main.get()
        assertTrue(a.statusText, RoboSupport.idleUntil { a.positioning?.isRunning == true })
        assertEquals(name, a.positioning!!.device)
        a.toggleRecording()
        a.toggleRecording()
        val log = checkNotNull(a.lastLog)
        assertEquals(name, meta(log)["device"])
        main.pause().stop().destroy()
    }

    @Test
    fun theRadioMapsOffsetsOfThePhoneReachTheEngine() {
        val p = positioning(siteWithOffsets("Google Pixel 7" to -6.5, "samsung SM-G930F" to 4.0))
        val s = checkNotNull(p.stats())
        assertEquals(-6.5, s.deviceBleOffsetDb!!, 0.0)
        assertEquals(2.5, s.deviceWifiOffsetDb!!, 0.0)
    }

    @Test
    fun aMapOfOlderSurveysThatNamedTheModelAloneStillApplies() {
        val p = positioning(siteWithOffsets("Pixel 7" to -3.0, "SM-G930F" to 4.0))
        assertEquals(-3.0, p.stats()!!.deviceBleOffsetDb!!, 0.0)
        // another phone's entry is never taken
        ShadowBuild.setManufacturer("OnePlus")
        ShadowBuild.setModel("CPH2449")
        val other = positioning(siteWithOffsets("Pixel 7" to -3.0, "SM-G930F" to 4.0))
        assertEquals("OnePlus CPH2449", other.device)
        assertNull(other.stats()!!.deviceBleOffsetDb)
        assertNull(other.stats()!!.deviceWifiOffsetDb)
    }

    private fun positioning(site: FpbpPositioning.Site): FpbpPositioning =
        FpbpPositioning(app, site, FpbpPositioning.Options(engine = "tcpf")).also {
            started.add(it)
            it.start().get(30, TimeUnit.SECONDS)
        }

    /** The open site with a radio map holding only phone models' offsets (BLE = the given, WiFi = it + 9 dB). */
    private fun siteWithOffsets(vararg models: Pair<String, Double>): FpbpPositioning.Site {
        val offsets = models.joinToString(",") { (m, db) -> "\"$m\": {\"ble_db\": $db, \"wifi_db\": ${db + 9.0}, \"walks\": 3}" }
        val map = """{"format": "fpbp-radio-map", "version": 4, "site": "open", "transmitters": [], "device_offsets": {$offsets}}"""
        return FpbpPositioning.Site(TestSupport.openSiteJson, TestSupport.repo.path, radioMapJson = map)
    }

    private fun meta(f: File): Map<String, String> = f.bufferedReader().use { NativeLogReader.read(it) }.meta
}
