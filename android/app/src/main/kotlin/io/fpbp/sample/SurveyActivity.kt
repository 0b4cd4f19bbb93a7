package io.fpbp.sample

import android.app.Activity
import android.content.Context
import android.content.Intent
import android.graphics.BitmapFactory
import android.os.Build
import android.os.Bundle
import android.os.Handler
import android.os.Looper
import android.view.WindowManager
import android.widget.Button
import android.widget.LinearLayout
import android.widget.TextView
import io.fpbp.Radio
import io.fpbp.android.FpbpPositioning
import io.fpbp.android.FpbpSurvey
import org.json.JSONObject
import java.io.File
import java.text.SimpleDateFormat
import java.util.Date
import java.util.Locale

/**
 * The survey screen (plain framework APIs): records a survey walk for
 * `fpbp calibrate --wifi --radio-map` with [FpbpSurvey], no engine running.
 * Shows the plan with the waypoint marks and the walked track; a tap on
 * the plan while recording marks where the walker stands (a TRUTH row);
 * start / stop; the counts of marks, BLE advertisements, WiFi scans and
 * sensor samples, and the time since the last mark (over 20 s the readings
 * between two marks are not placed: docs/survey.md); shares the file.
 * The site comes from [EXTRA_SITE_DIR] or the demo site in the assets.
 * The survey survives configuration changes.
 */
class SurveyActivity : Activity() {
    companion object {
        /** Intent extra: a folder with site.json (and its plans); default: the demo site. */
        const val EXTRA_SITE_DIR = MainActivity.EXTRA_SITE_DIR

        const val REQUEST_PERMISSIONS = 2

        /** The radios a survey records. */
        val RADIOS = setOf(Radio.BLE, Radio.WIFI)

        /** Refresh period of the counts line, ms. */
        const val REFRESH_MS = 1000L

        /** Copies the asset folder [asset] to [to] (the demo site). */
        fun copyAssetDir(context: Context, asset: String, to: File) {
            val children = context.assets.list(asset) ?: emptyArray()
            if (children.isEmpty()) {
                to.parentFile?.mkdirs()
                context.assets.open(asset).use { input -> to.outputStream().use { input.copyTo(it) } }
                return
            }
            to.mkdirs()
            for (c in children) copyAssetDir(context, "$asset/$c", File(to, c))
        }
    }

    private class Retained(val survey: FpbpSurvey, val lastFile: File?, val floor: Int)

    private lateinit var planView: FloorPlanView
    private lateinit var statusView: TextView
    private lateinit var countsView: TextView
    private lateinit var floorButton: Button
    private lateinit var recordButton: Button
    private lateinit var shareButton: Button
    private val ui = Handler(Looper.getMainLooper())

    /** The survey recorder (null when the site could not be loaded). */
    var survey: FpbpSurvey? = null
        private set

    /** The last file recorded (shared by the share button). */
    var lastFile: File? = null
        private set

    private lateinit var siteDir: File
    private var siteJson = ""
    private var floorIds: List<Int> = emptyList()

    /** The floor whose plan is shown (marks go on it). */
    val shownFloor: Int get() = planView.floorId

    /** The status line's text. */
    val statusText: String get() = statusView.text.toString()

    /** The counts line's text. */
    val countsText: String get() = countsView.text.toString()

    /** The plan view (tests tap it through [FloorPlanView.onTap]). */
    val plan: FloorPlanView get() = planView

    private val refresh = object : Runnable {
        override fun run() {
            showCounts()
            ui.postDelayed(this, REFRESH_MS)
        }
    }

    override fun onCreate(savedInstanceState: Bundle?) {
        super.onCreate(savedInstanceState)
        // the walk is recorded with the screen on: the sources run in foreground mode
        window.addFlags(WindowManager.LayoutParams.FLAG_KEEP_SCREEN_ON)
        buildUi()
        @Suppress("DEPRECATION")
        val retained = lastNonConfigurationInstance as? Retained
        try {
            loadSite(retained?.floor)
        } catch (e: Exception) {
            statusView.text = "cannot load the site: ${e.message}"
            return
        }
        survey = retained?.survey ?: FpbpSurvey(
            this,
            FpbpSurvey.Options(radios = RADIOS, beaconIds = FpbpPositioning.beaconIds(siteJson)),
        )
        lastFile = retained?.lastFile
        shareButton.isEnabled = lastFile != null
        showCounts()
        ui.post(refresh)
    }

    private fun buildUi() {
        planView = FloorPlanView(this)
        statusView = TextView(this).apply { setPadding(16, 8, 16, 0) }
        countsView = TextView(this).apply { setPadding(16, 0, 16, 8) }
        floorButton = Button(this).apply { setOnClickListener { nextFloor() } }
        recordButton = Button(this).apply {
            text = "Start survey"
            setOnClickListener { toggleRecording() }
        }
        shareButton = Button(this).apply {
            text = "Share survey"
            isEnabled = false
            setOnClickListener { share() }
        }
        val buttons = LinearLayout(this).apply {
            orientation = LinearLayout.HORIZONTAL
            addView(floorButton)
            addView(recordButton)
            addView(shareButton)
        }
        setContentView(
            LinearLayout(this).apply {
                orientation = LinearLayout.VERTICAL
                addView(statusView)
                addView(countsView)
                addView(buttons)
                addView(planView, LinearLayout.LayoutParams(LinearLayout.LayoutParams.MATCH_PARENT, 0, 1f))
            },
        )
        planView.onTap = { x, y -> onTap(x, y) }
    }

    private fun loadSite(floor: Int?) {
        val given = intent?.getStringExtra(EXTRA_SITE_DIR)
        siteDir = if (given != null) {
            File(given)
        } else {
            File(filesDir, "site").also { if (!File(it, "site.json").isFile) copyAssetDir(this, "demo", it) }
        }
        siteJson = File(siteDir, "site.json").readText()
        val floors = JSONObject(siteJson).getJSONArray("floors")
        floorIds = (0 until floors.length()).map { floors.getJSONObject(it).getInt("id") }
        showFloor(floor?.takeIf { it in floorIds } ?: floorIds.first())
    }

    private fun showFloor(id: Int) {
        val floors = JSONObject(siteJson).getJSONArray("floors")
        val floor = (0 until floors.length()).map { floors.getJSONObject(it) }.first { it.getInt("id") == id }
        val plan = floor.optString("plan", "")
        val r = floor.optDouble("pixels_per_meter", 1.0)
        val bitmap = if (plan.isNotEmpty()) BitmapFactory.decodeFile(File(siteDir, plan).path) else null
        planView.setPlan(id, bitmap, r)
        planView.setMarks(survey?.marks() ?: emptyList())
        floorButton.text = "Floor $id"
    }

    private fun nextFloor() {
        if (floorIds.isEmpty()) return
        showFloor(floorIds[(floorIds.indexOf(planView.floorId) + 1) % floorIds.size])
    }

    /** A tap on the plan while recording: the walker stands there now. */
    private fun onTap(xM: Double, yM: Double) {
        val s = survey ?: return
        if (!s.isRecording) {
            statusView.text = "start the survey, then tap where you stand"
            return
        }
        s.mark(xM, yM, planView.floorId)
        planView.setMarks(s.marks())
        showCounts()
    }

    /** The Start / Stop button: starts a survey into a new file in [LogFileProvider.logDir], or stops and saves it. */
    fun toggleRecording() {
        val s = survey ?: return
        if (s.isRecording) {
            val f = s.stop()
            lastFile = f
            recordButton.text = "Start survey"
            shareButton.isEnabled = f != null
            statusView.text = "saved ${f?.name}" + (s.failure?.let { " ($it)" } ?: "")
            showCounts()
            return
        }
        val dir = LogFileProvider.logDir(this).apply { mkdirs() }
        val name = "survey-" + SimpleDateFormat("yyyyMMdd-HHmmss", Locale.US).format(Date()) + ".log"
        // FpbpSurvey adds `device` (DeviceModel.canonical(): the name the engine is given)
        val meta = mapOf(
            "android_api" to Build.VERSION.SDK_INT.toString(),
            "site" to JSONObject(siteJson).optString("name"),
            "kind" to "survey",
            "app" to "io.fpbp.sample",
        )
        try {
            s.start(File(dir, name), meta)
        } catch (e: Exception) {
            statusView.text = "cannot record: ${e.message}"
            return
        }
        recordButton.text = "Stop survey"
        planView.setMarks(emptyList())
        val missing = FpbpPositioning.missingPermissions(this, RADIOS)
        if (missing.isNotEmpty()) requestPermissions(missing.toTypedArray(), REQUEST_PERMISSIONS)
        showCounts()
    }

    override fun onRequestPermissionsResult(requestCode: Int, permissions: Array<out String>, grantResults: IntArray) {
        super.onRequestPermissionsResult(requestCode, permissions, grantResults)
        if (requestCode == REQUEST_PERMISSIONS) survey?.refreshPermissions()
    }

    private fun showCounts() {
        val s = survey ?: return
        val c = s.counts()
        countsView.text = c.describe()
        if (!s.isRecording) {
            if (statusView.text.isEmpty()) statusView.text = "tap Start survey, then tap the plan where you stand at every turn, door and stop"
            return
        }
        val last = s.marks().lastOrNull()
        val since = last?.let { (s.clock.nowNs() - it.tNs) / 1_000_000_000L }
        val markLine = when {
            last == null -> "no mark yet: tap where you stand"
            since!! > 20 -> "last mark $since s ago: mark now (over 20 s the readings in between are lost)"
            else -> "last mark $since s ago"
        }
        statusView.text = "recording ${s.currentFile?.name}; $markLine; ${s.describeProblems()}"
    }

    private fun share() {
        val f = lastFile ?: return
        val send = Intent(Intent.ACTION_SEND).apply {
            type = "text/plain"
            putExtra(Intent.EXTRA_STREAM, LogFileProvider.uriFor(f))
            putExtra(Intent.EXTRA_SUBJECT, f.name)
            addFlags(Intent.FLAG_GRANT_READ_URI_PERMISSION)
        }
        startActivity(Intent.createChooser(send, "Share ${f.name}"))
    }

    @Deprecated("framework API without AndroidX")
    override fun onRetainNonConfigurationInstance(): Any? = survey?.let { Retained(it, lastFile, planView.floorId) }

    override fun onDestroy() {
        ui.removeCallbacks(refresh)
        if (!isChangingConfigurations) survey?.close()
        survey = null
        super.onDestroy()
    }
}
