package io.fpbp.sample

import android.Manifest
import android.app.Activity
import android.content.pm.PackageManager
import android.graphics.BitmapFactory
import android.hardware.SensorManager
import android.os.Build
import android.os.Bundle
import android.os.SystemClock
import android.widget.Button
import android.widget.LinearLayout
import android.widget.TextView
import io.fpbp.Clock
import io.fpbp.FpbpEngine
import io.fpbp.InitialPosition
import io.fpbp.TaskScheduler
import org.json.JSONObject
import java.io.File
import java.text.SimpleDateFormat
import java.util.Date
import java.util.Locale

/**
 * The sample app: plain framework APIs, no AndroidX. Copies the demo site
 * (assets/demo) to app storage, starts the `fpbp` engine, feeds it BLE scans
 * and sensor samples, runs the GML and fusion tasks on their executors, shows
 * the plan with the live pose, and records a native log on demand. A tap on
 * the plan restarts the engine from there (and is recorded as a truth mark
 * while recording).
 */
class MainActivity : Activity() {
    private lateinit var planView: FloorPlanView
    private lateinit var status: TextView
    private lateinit var recordButton: Button

    private var engine: FpbpEngine? = null
    private var tasks: TaskScheduler? = null
    private var ble: BleScanner? = null
    private var sensors: SensorFeed? = null
    @Volatile private var recorder: LogRecorder? = null

    private lateinit var siteDir: File
    private var siteJson = ""
    private var floorId = 0

    /** The clock of SensorEvent.timestamp and ScanResult.getTimestampNanos(). */
    private val clock = Clock { SystemClock.elapsedRealtimeNanos() }

    override fun onCreate(savedInstanceState: Bundle?) {
        super.onCreate(savedInstanceState)
        planView = FloorPlanView(this)
        status = TextView(this).apply { setPadding(16, 8, 16, 8) }
        recordButton = Button(this).apply {
            text = "Record log"
            setOnClickListener { toggleRecording() }
        }
        setContentView(
            LinearLayout(this).apply {
                orientation = LinearLayout.VERTICAL
                addView(status)
                addView(recordButton)
                addView(planView, LinearLayout.LayoutParams(LinearLayout.LayoutParams.MATCH_PARENT, 0, 1f))
            },
        )
        planView.onTap = { x, y -> onTap(x, y) }
        siteDir = File(filesDir, "site")
        try {
            copyAssetDir("demo", siteDir)
            siteJson = File(siteDir, "site.json").readText()
            showPlan()
        } catch (e: Exception) {
            status.text = "cannot load the demo site: ${e.message}"
            return
        }
        requestNeededPermissions()
    }

    private fun neededPermissions(): List<String> =
        if (Build.VERSION.SDK_INT >= Build.VERSION_CODES.S) {
            listOf(Manifest.permission.BLUETOOTH_SCAN)
        } else {
            listOf(Manifest.permission.ACCESS_FINE_LOCATION)
        }

    private fun requestNeededPermissions() {
        val missing = neededPermissions().filter { checkSelfPermission(it) != PackageManager.PERMISSION_GRANTED }
        if (missing.isEmpty()) startAll(null) else requestPermissions(missing.toTypedArray(), REQUEST_PERMISSIONS)
    }

    override fun onRequestPermissionsResult(requestCode: Int, permissions: Array<out String>, grantResults: IntArray) {
        super.onRequestPermissionsResult(requestCode, permissions, grantResults)
        if (requestCode != REQUEST_PERMISSIONS) return
        if (grantResults.isNotEmpty() && grantResults.all { it == PackageManager.PERMISSION_GRANTED }) {
            startAll(null)
        } else {
            status.text = "BLE scanning needs the permission: positioning runs on sensors only"
            startAll(null, withBle = false)
        }
    }

    private fun startAll(init: InitialPosition?, withBle: Boolean = true) {
        stopAll()
        val e = try {
            FpbpEngine.start(siteJson, siteDir.path, ENGINE, "", init)
        } catch (ex: IllegalArgumentException) {
            status.text = "engine did not start: ${ex.message}"
            return
        }
        engine = e
        tasks = TaskScheduler(e, clock) { _ -> planView.post { refresh() } }
        sensors = SensorFeed(getSystemService(SENSOR_SERVICE) as SensorManager) { type, t, v ->
            e.onSensor(type, t, v)
            recorder?.sensor(type, t, v)
        }.also { it.start() }
        if (withBle) {
            ble = BleScanner(this) { t, id, rssi, tx ->
                e.onBleScan(t, id, rssi, tx)
                recorder?.ble(t, id, rssi, tx)
            }.also { if (!it.start()) status.text = "Bluetooth is off: positioning runs on sensors only" }
        }
    }

    private fun stopAll() {
        ble?.stop()
        ble = null
        sensors?.stop()
        sensors = null
        tasks?.close()
        tasks = null
        engine?.close()
        engine = null
    }

    private fun refresh() {
        val e = engine ?: return
        if (e.isClosed) return
        val pose = e.pose()
        planView.setPose(pose, e.blePosition())
        status.text = pose?.let { "x %.1f m  y %.1f m  floor %d  ±%.1f m".format(it.xM, it.yM, it.floor, it.accuracyM) }
            ?: "waiting for a first fix (walk a few steps near the beacons)"
    }

    private fun onTap(xM: Double, yM: Double) {
        recorder?.truth(clock.nowNs(), xM, yM, floorId)
        startAll(InitialPosition(xM, yM, floorId), withBle = ble != null)
    }

    private fun toggleRecording() {
        val r = recorder
        if (r != null) {
            recorder = null
            r.close()
            recordButton.text = "Record log"
            status.text = "saved ${r.file.path}"
            return
        }
        val dir = File(getExternalFilesDir(null) ?: filesDir, "logs").apply { mkdirs() }
        val name = "fpbp-" + SimpleDateFormat("yyyyMMdd-HHmmss", Locale.US).format(Date()) + ".log"
        val meta = mapOf(
            "device" to "${Build.MANUFACTURER} ${Build.MODEL}",
            "android_api" to Build.VERSION.SDK_INT.toString(),
            "site" to (JSONObject(siteJson).optString("name")),
            "app" to "io.fpbp.sample",
        )
        recorder = LogRecorder(File(dir, name), meta)
        recordButton.text = "Stop recording"
    }

    private fun showPlan() {
        val floor = JSONObject(siteJson).getJSONArray("floors").getJSONObject(0)
        floorId = floor.getInt("id")
        val plan = floor.optString("plan", "")
        val r = floor.optDouble("pixels_per_meter", 1.0)
        if (plan.isNotEmpty()) planView.setPlan(BitmapFactory.decodeFile(File(siteDir, plan).path), r)
    }

    private fun copyAssetDir(asset: String, to: File) {
        val children = assets.list(asset) ?: emptyArray()
        if (children.isEmpty()) {
            to.parentFile?.mkdirs()
            assets.open(asset).use { input -> to.outputStream().use { input.copyTo(it) } }
            return
        }
        to.mkdirs()
        for (c in children) copyAssetDir("$asset/$c", File(to, c))
    }

    override fun onDestroy() {
        recorder?.close()
        recorder = null
        stopAll()
        super.onDestroy()
    }

    private companion object {
        const val ENGINE = "fpbp"
        const val REQUEST_PERMISSIONS = 1
    }
}
