package io.fpbp.robo

import android.Manifest
import android.bluetooth.BluetoothManager
import android.bluetooth.le.ScanCallback
import android.bluetooth.le.ScanRecord
import android.bluetooth.le.ScanResult
import android.bluetooth.le.ScanSettings
import android.content.Context
import android.content.Intent
import android.hardware.Sensor
import android.hardware.SensorManager
import android.net.wifi.WifiManager
import io.fpbp.LogEvent
import io.fpbp.ManualClock
import io.fpbp.NativeLog
import io.fpbp.NativeLogReader
import io.fpbp.Radio
import io.fpbp.SurveyMark
import io.fpbp.TestSupport
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpSurvey
import io.fpbp.sample.SurveyActivity
import org.json.JSONObject
import org.junit.Assert.assertEquals
import org.junit.Assert.assertTrue
import org.junit.Before
import org.junit.Rule
import org.junit.Test
import org.junit.rules.TemporaryFolder
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import org.robolectric.shadows.SensorEventBuilder
import org.robolectric.shadows.ShadowBluetoothLeScanner
import org.robolectric.shadows.ShadowSensor
import java.io.File
import java.util.Random
import java.util.concurrent.TimeUnit
import java.util.zip.GZIPInputStream
import kotlin.math.hypot
import kotlin.math.log10
import kotlin.math.max
import kotlin.math.roundToInt

/**
 * A survey recorded through the library's recorder ([FpbpSurvey]) on the
 * Android framework, with no engine: three walks of the demo site (the
 * shipped simulated logs host-tests/logs/demo-walk-{1,2,4}: their sensor
 * samples go through the sensor shadow, their iBeacon advertisements
 * through the BLE scanner shadow as real iBeacon frames, WiFi scans of
 * five synthetic access points through the WiFi shadow every 4 s, and
 * their ground truth every 4 s as waypoint marks). Each file is read back
 * and must hold exactly what was fed; then `fpbp calibrate --site
 * maps/demo/site.json --logs THE_3_FILES --split all --wifi --radio-map`
 * (the binary in -Dfpbp.bin, built by run.sh) must take the files as they
 * are, place the access points near where they are, and write a radio
 * map with WiFi grids.
 *
 * Guards: the recorder's format (v2 header, WIFI lines the Rust reader
 * takes, TRUTH rows), that no source's events are lost or duplicated, that
 * marks carry the time of their tap (calibrate places every reading
 * between two marks by their times), and that the survey is what
 * calibrate needs: with two of the walks it exits 0 but fits no access
 * point (`ble.calibration.min_paths` 3), which the distance check fails.
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class SurveyRecordingTest {
    @get:Rule
    val tmp = TemporaryFolder()

    private val app: android.app.Application get() = org.robolectric.RuntimeEnvironment.getApplication()
    private val bluetooth get() = app.getSystemService(Context.BLUETOOTH_SERVICE) as BluetoothManager
    private val scanner get() = shadowOf(bluetooth.adapter.bluetoothLeScanner) as ShadowBluetoothLeScanner
    private val sensorManager get() = app.getSystemService(Context.SENSOR_SERVICE) as SensorManager
    private val wifi get() = app.getSystemService(Context.WIFI_SERVICE) as WifiManager

    private val demoSite = File(TestSupport.repo, "maps/demo/site.json")

    /** Synthetic access points (BSSID, x, y on the demo floor; at beacon positions, so off the walls). */
    private val aps = listOf(
        Triple("02:00:00:01:00:10", 10.5, 10.5),
        Triple("02:00:00:02:00:20", 31.5, 24.5),
        Triple("02:00:00:03:00:30", 52.5, 10.5),
        Triple("02:00:00:04:00:40", 17.5, 38.5),
        Triple("02:00:00:05:00:50", 45.5, 38.5),
    )

    /** What one walk fed the recorder. */
    private data class Fed(
        val byKind: Map<String, Int>,
        val ble: Int,
        val bleIds: Set<String>,
        val scans: Int,
        val results: Int,
        val marks: List<SurveyMark>,
    )

    @Before
    fun setUp() {
        shadowOf(app).grantPermissions(
            Manifest.permission.BLUETOOTH_SCAN,
            Manifest.permission.ACCESS_FINE_LOCATION,
            Manifest.permission.ACCESS_COARSE_LOCATION,
            Manifest.permission.NEARBY_WIFI_DEVICES,
        )
        shadowOf(bluetooth.adapter).setEnabled(true)
        shadowOf(wifi).setWifiState(WifiManager.WIFI_STATE_ENABLED)
        // empty: the survey's own startScan must not broadcast (only the test's scans count)
        shadowOf(wifi).setScanResults(emptyList())
        val sensors = shadowOf(sensorManager)
        // the sensors of the demo logs (no game rotation vector)
        val types = intArrayOf(
            Sensor.TYPE_ACCELEROMETER, Sensor.TYPE_GYROSCOPE, Sensor.TYPE_MAGNETIC_FIELD, Sensor.TYPE_ROTATION_VECTOR, Sensor.TYPE_PRESSURE,
        )
        for (t in types) sensors.addSensor(ShadowSensor.newInstance(t))
    }

    private fun outDir(): File =
        System.getProperty("fpbp.survey.dir")?.takeIf { it.isNotEmpty() }?.let { File(it).apply { mkdirs() } } ?: tmp.newFolder("survey")

    @Test
    fun threeWalksAreRecordedExactlyAndCalibrateTakesThem() {
        val siteJson = demoSite.readText()
        val clock = ManualClock(0)
        val survey = FpbpSurvey(
            app,
            FpbpSurvey.Options(radios = setOf(Radio.BLE, Radio.WIFI), beaconIds = FpbpPositioning.beaconIds(siteJson)),
            clock,
        )
        val dir = outDir()
        val files = ArrayList<File>()
        survey.use { s ->
            for ((k, walk) in listOf("demo-walk-1", "demo-walk-2", "demo-walk-4").withIndex()) {
                val file = File(dir, "survey-${k + 1}.log")
                val fed = walk(s, clock, walk, file, seed = 100L + k)
                checkFile(file, fed, s)
                files.add(file)
            }
        }
        calibrate(files)
    }

    /** Feeds one shipped walk through the shadows into [s] recording [file]. */
    private fun walk(s: FpbpSurvey, clock: ManualClock, name: String, file: File, seed: Long): Fed {
        val events = GZIPInputStream(File(TestSupport.repo, "host-tests/logs/$name.log.gz").inputStream()).bufferedReader().use {
            NativeLogReader.read(it)
        }.events
        val truth = events.filterIsInstance<LogEvent.Truth>()
        assertTrue("$name has too little truth", truth.size > 10)
        clock.set(events.first().tNs)
        // no results pending: the survey's own startScan would broadcast them (a scan the test did not make)
        shadowOf(wifi).setScanResults(emptyList())
        s.start(file, mapOf("site" to "fpbp demo site", "walk" to name))
        assertTrue("no BLE scan started: ${s.describeProblems()}", RoboSupport.idleUntil { scanner.scanCallbacks.isNotEmpty() })
        val cb: ScanCallback = scanner.scanCallbacks.single()
        // the site's beacons as hardware filters (54 demo beacons: one filter on their UUID)
        assertEquals(1, scanner.activeScans.single().scanFilters().size)
        val rng = Random(seed)
        val byKind = sortedMapOf<String, Int>()
        var ble = 0
        val bleIds = sortedSetOf<String>()
        var scans = 0
        var results = 0
        val marks = ArrayList<SurveyMark>()
        var nextMarkNs = Long.MIN_VALUE
        var nextScanNs = events.first().tNs + 2_000_000_000L
        for (e in events) {
            clock.set(e.tNs)
            if (e.tNs >= nextScanNs) {
                results += wifiScan(s, e.tNs, truth, rng, ++scans)
                nextScanNs += 4_000_000_000L
            }
            when (e) {
                is LogEvent.Sensor -> {
                    val sensor = sensorManager.getDefaultSensor(e.sensorType) ?: continue
                    val v = FloatArray(e.values.size) { e.values[it].toFloat() }
                    shadowOf(sensorManager).sendSensorEventToListeners(
                        SensorEventBuilder.newBuilder().setSensor(sensor).setValues(v).setTimestamp(e.tNs).build(),
                    )
                    val kind = NativeLog.kindOf(e.sensorType)!!
                    byKind[kind] = (byKind[kind] ?: 0) + 1
                }
                is LogEvent.Ble -> {
                    cb.onScanResult(ScanSettings.CALLBACK_TYPE_ALL_MATCHES, advert(e))
                    ble++
                    bleIds.add(e.beaconId)
                }
                is LogEvent.Truth -> if (e.tNs >= nextMarkNs || e === truth.last()) {
                    // the walker taps where they stand (the clock is the tap's time)
                    val m = s.mark(e.xM, e.yM, e.floor ?: 0)
                    assertEquals("a mark carries the time of its tap", e.tNs, m.tNs)
                    marks.add(m)
                    nextMarkNs = e.tNs + 4_000_000_000L
                }
                else -> Unit
            }
        }
        val sent = byKind.values.sum().toLong()
        assertTrue(
            "the recorder did not get every event: ${s.counts()}",
            RoboSupport.idleUntil(30_000) {
                s.counts().let { it.sensorSamples == sent && it.bleAdverts == ble.toLong() && it.marks == marks.size.toLong() }
            },
        )
        assertEquals(file, s.stop())
        return Fed(byKind, ble, bleIds, scans, results, marks)
    }

    /** One WiFi scan at [tNs] of the synthetic APs heard from the walker's position; returns its results. */
    private fun wifiScan(s: FpbpSurvey, tNs: Long, truth: List<LogEvent.Truth>, rng: Random, k: Int): Int {
        val list = aps.map { (bssid, x, y) ->
            // each result last seen 0-2 s before the scan, where the walker was then
            val seenNs = tNs - (rng.nextDouble() * 2e9).toLong()
            val (px, py) = positionAt(truth, seenNs)
            val d = max(hypot(px - x, py - y), 1.0)
            val rssi = (-38.0 - 26.0 * log10(d) + 3.0 * rng.nextGaussian()).roundToInt()
            android.net.wifi.ScanResult().apply {
                BSSID = bssid.uppercase() // phones differ in case; the file holds lower case
                level = rssi
                frequency = 2412 + 5 * (bssid[10] - '0')
                timestamp = seenNs / 1000 // microseconds since boot
            }
        }
        shadowOf(wifi).setScanResults(list)
        app.sendBroadcast(Intent(WifiManager.SCAN_RESULTS_AVAILABLE_ACTION))
        // 30 s, as the walk's end: the writer thread is the only one that counts, and a loaded machine may stall it
        assertTrue(
            "WiFi scan $k not recorded: ${s.counts()}; problems: ${s.describeProblems()}; failure: ${s.failure}",
            RoboSupport.idleUntil(30_000) { s.counts().wifiScans == k.toLong() },
        )
        return list.size
    }

    /** The walker's position at [tNs]: the dense simulated truth, linearly interpolated. */
    private fun positionAt(truth: List<LogEvent.Truth>, tNs: Long): Pair<Double, Double> {
        val i = truth.indexOfFirst { it.tNs >= tNs }
        if (i <= 0) return truth.first().let { it.xM to it.yM }
        val (a, b) = truth[i - 1] to truth[i]
        val f = (tNs - a.tNs).toDouble() / (b.tNs - a.tNs)
        return (a.xM + f * (b.xM - a.xM)) to (a.yM + f * (b.yM - a.yM))
    }

    /** A BLE scan result carrying [e]'s iBeacon frame (flags + Apple manufacturer data). */
    private fun advert(e: LogEvent.Ble): ScanResult {
        val p = e.beaconId.split(':')
        val uuid = p[1].replace("-", "").chunked(2).map { it.toInt(16).toByte() }
        val major = p[2].toInt()
        val minor = p[3].toInt()
        val tx = (e.txPowerDbm ?: -59.0).toInt()
        val bytes = byteArrayOf(2, 1, 6, 0x1A, 0xFF.toByte(), 0x4C, 0x00, 0x02, 0x15) + uuid.toByteArray() +
            byteArrayOf((major shr 8).toByte(), major.toByte(), (minor shr 8).toByte(), minor.toByte(), tx.toByte())
        val device = bluetooth.adapter.getRemoteDevice("C0:00:00:00:%02X:%02X".format(major and 0xFF, minor and 0xFF))
        return ScanResult(
            device, 0x11, 1, 0, ScanResult.SID_NOT_PRESENT, ScanResult.TX_POWER_NOT_PRESENT, e.rssiDbm.toInt(),
            ScanResult.PERIODIC_INTERVAL_NOT_PRESENT, ScanRecord.parseFromBytes(bytes), e.tNs,
        )
    }

    /** The file read back holds exactly what was fed, and the recorder's counts say so. */
    private fun checkFile(file: File, fed: Fed, s: FpbpSurvey) {
        val log = file.bufferedReader().use { NativeLogReader.read(it) }
        assertEquals(2, log.version)
        assertEquals("fpbp-survey", log.meta["recorder"])
        // the phone model, for `fpbp calibrate`'s per-model offsets: the name the engine is given
        assertEquals(io.fpbp.android.DeviceModel.canonical(), log.meta["device"])
        assertTrue(log.meta["device"]!!, log.meta["device"]!!.endsWith(android.os.Build.MODEL))
        val ev = log.events
        val byKind = ev.filterIsInstance<LogEvent.Sensor>().groupingBy { NativeLog.kindOf(it.sensorType)!! }.eachCount().toSortedMap()
        assertEquals("sensor samples per kind", fed.byKind, byKind)
        val ble = ev.filterIsInstance<LogEvent.Ble>()
        assertEquals("BLE advertisements", fed.ble, ble.size)
        assertEquals("beacon ids parsed from the iBeacon frames", fed.bleIds, ble.map { it.beaconId }.toSortedSet())
        val scans = ev.filterIsInstance<LogEvent.Wifi>()
        assertEquals("WiFi scans", fed.scans, scans.size)
        assertEquals("WiFi results", fed.results, scans.sumOf { it.results.size })
        assertEquals(aps.map { it.first }.toSet(), scans.flatMap { sc -> sc.results.map { it.bssid } }.toSet())
        assertTrue("a result last seen after its scan", scans.all { sc -> sc.results.all { it.seenTNs <= sc.tNs } })
        val marks = ev.filterIsInstance<LogEvent.Truth>().map { SurveyMark(it.tNs, it.xM, it.yM, it.floor!!) }
        assertEquals("waypoint marks (time, position, floor)", fed.marks, marks)
        assertEquals(fed.marks, s.marks())
        val c = s.counts()
        assertEquals(fed.marks.size.toLong(), c.marks)
        assertEquals(fed.ble.toLong(), c.bleAdverts)
        assertEquals(fed.scans.toLong(), c.wifiScans)
        assertEquals(fed.results.toLong(), c.wifiResults)
        assertEquals(fed.byKind.values.sum().toLong(), c.sensorSamples)
        assertEquals(0L, c.skipped + c.dropped)
        assertEquals("marks every 4 s leave no gap calibrate drops", 0L, c.longGaps)
        println("survey ${file.name}: ${c.describe()}")
    }

    /** `fpbp calibrate --wifi --radio-map` on the files: accepted, APs placed near the truth, WiFi grids in the map. */
    private fun calibrate(files: List<File>) {
        val bin = System.getProperty("fpbp.bin")?.let(::File)
        require(bin != null && bin.canExecute()) {
            "fpbp.bin (target/release/fpbp) not built: run host-tests/jvm/run.sh or cargo build --release -p fpbp-cli"
        }
        val work = tmp.newFolder("calibrate")
        val site = File(work, "site.json")
        val map = File(work, "radio-map.json")
        val cmd = listOf(bin.path, "calibrate", "--site", demoSite.path, "--logs") + files.map { it.path } +
            listOf("--split", "all", "--out", site.path, "--wifi", "--radio-map", map.path)
        val p = ProcessBuilder(cmd).redirectErrorStream(true).start()
        val out = p.inputStream.bufferedReader().readText()
        assertTrue("calibrate did not finish", p.waitFor(300, TimeUnit.SECONDS))
        val summary = out.lines().filter { l -> listOf("wrote", "WiFi", "radio map").any { l.startsWith(it) } || l.contains("paths,") }
        println(summary.joinToString("\n"))
        assertEquals("fpbp calibrate refused the survey:\n$out", 0, p.exitValue())
        assertTrue("a survey file was skipped:\n$out", !out.contains("skipped"))
        // every synthetic AP fitted and placed within 5 m of where it is (two walks: calibrate exits 0
        // and fits none, `ble.calibration.min_paths` is 3)
        val placed = JSONObject(site.readText()).optJSONArray("access_points") ?: org.json.JSONArray()
        val byId = (0 until placed.length()).map { placed.getJSONObject(it) }.associateBy { it.getString("id") }
        for ((bssid, x, y) in aps) {
            val a = checkNotNull(byId[bssid]) { "AP $bssid not calibrated:\n$out" }
            val err = hypot(a.getDouble("x_m") - x, a.getDouble("y_m") - y)
            // the format takes the figure only: calibrate's output holds "%" signs
            assertTrue("AP $bssid placed ${"%.1f".format(err)} m from where it is:\n$out", err < 5.0)
        }
        // the radio map has WiFi transmitters with grids
        val tx = JSONObject(map.readText()).getJSONArray("transmitters")
        val wifiGrids = (0 until tx.length()).map { tx.getJSONObject(it) }
            .filter { it.getString("kind") == "wifi" && it.getJSONArray("grids").length() > 0 }
            .map { it.getString("id") }.toSet()
        assertEquals("WiFi transmitters with grids in the radio map:\n$out", aps.map { it.first }.toSet(), wifiGrids)
    }

    /**
     * Guards the bound: with a queue of one event, a flood of sensor samples
     * is partly dropped, and every sample is either in the file or counted
     * as dropped; marks made during the flood are all written.
     */
    @Test
    fun aFullQueueDropsAndCountsEventsButNeverAMark() {
        val clock = ManualClock(0)
        val s = FpbpSurvey(app, FpbpSurvey.Options(radios = emptySet(), queueCapacity = 1), clock)
        val file = File(tmp.newFolder("flood"), "flood.log")
        s.use {
            s.start(file)
            val acc = sensorManager.getDefaultSensor(Sensor.TYPE_ACCELEROMETER)!!
            val sent = 5_000
            for (k in 1..sent) {
                clock.set(k * 1_000_000L)
                shadowOf(sensorManager).sendSensorEventToListeners(
                    SensorEventBuilder.newBuilder().setSensor(acc).setValues(floatArrayOf(0.1f, 0.2f, 9.8f)).setTimestamp(k * 1_000_000L).build(),
                )
                if (k % 1_000 == 0) s.mark(k / 1_000.0, 1.0, 0)
            }
            s.stop()
            val c = s.counts()
            val log = file.bufferedReader().use { NativeLogReader.read(it) }
            assertEquals(c.sensorSamples.toInt(), log.events.count { it is LogEvent.Sensor })
            assertEquals("written + dropped = sent ($c)", sent.toLong(), c.sensorSamples + c.dropped)
            assertEquals(5, log.events.count { it is LogEvent.Truth })
            assertEquals(5L, c.marks)
            println("queue of 1: $sent samples sent, ${c.sensorSamples} written, ${c.dropped} dropped")
        }
    }

    /** The sample app's survey screen: taps on the plan while recording become marks; no engine runs. */
    @Test
    fun surveyScreenTurnsTapsIntoMarks() {
        val controller = Robolectric.buildActivity(
            SurveyActivity::class.java,
            Intent(app, SurveyActivity::class.java).putExtra(SurveyActivity.EXTRA_SITE_DIR, demoSite.parentFile!!.path),
        ).setup()
        val a = controller.get()
        val s = checkNotNull(a.survey) { "no survey: ${a.statusText}" }
        a.plan.onTap!!.invoke(5.0, 5.0) // not recording: no mark
        a.toggleRecording()
        assertTrue(a.statusText, s.isRecording)
        a.plan.onTap!!.invoke(27.85, 9.65)
        a.plan.onTap!!.invoke(22.7, 19.3)
        assertEquals(2, a.plan.marksDrawn)
        controller.recreate() // rotation: the survey carries on
        val b = controller.get()
        assertTrue(b.survey === s && s.isRecording)
        b.plan.onTap!!.invoke(31.8, 20.0)
        b.toggleRecording()
        val file = checkNotNull(b.lastFile) { "no file after stop: ${b.statusText}" }
        val marks = file.bufferedReader().use { NativeLogReader.read(it) }.events.filterIsInstance<LogEvent.Truth>()
        assertEquals(listOf(27.85 to 9.65, 22.7 to 19.3, 31.8 to 20.0), marks.map { it.xM to it.yM })
        assertTrue(marks.all { it.floor == 0 })
        assertTrue(b.countsText, b.countsText.startsWith("marks 3 "))
        controller.pause().stop().destroy()
        assertTrue("sensor listeners left after the screen closed", shadowOf(sensorManager).listeners.isEmpty())
    }
}
