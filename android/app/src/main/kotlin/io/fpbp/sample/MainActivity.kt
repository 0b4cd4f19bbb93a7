package io.fpbp.sample

import android.app.Activity
import android.content.Intent
import android.content.pm.PackageManager
import android.graphics.BitmapFactory
import android.os.Build
import android.os.Bundle
import android.os.Looper
import android.widget.Button
import android.widget.LinearLayout
import android.widget.TextView
import io.fpbp.FpbpDefaults
import io.fpbp.Pose
import io.fpbp.PoseRequest
import io.fpbp.PoseSubscription
import io.fpbp.Radio
import io.fpbp.RadioPermissions
import io.fpbp.Status
import io.fpbp.android.FpbpPositioning
import org.json.JSONObject
import java.io.File
import java.text.SimpleDateFormat
import java.util.Date
import java.util.Locale

/**
 * The sample app: plain framework APIs, no AndroidX. Loads a site (the demo
 * site from assets, or the folder named by the intent extra [EXTRA_SITE_DIR])
 * on a background thread, runs [FpbpPositioning] (which scans BLE, reads the sensors and runs the
 * engine), draws the floor the pose is on (or the one picked with the floor
 * button), shows the status line, sets the position with a tap, records a
 * native log and shares it. The positioning survives configuration changes
 * (onRetainNonConfigurationInstance); listeners are removed in onDestroy.
 */
class MainActivity : Activity() {
    companion object {
        /** The engine the sample runs: the library's default, changed in one place. */
        const val ENGINE = FpbpDefaults.ENGINE

        /** Intent extra: a folder with site.json (and its plans) to use instead of the demo site. */
        const val EXTRA_SITE_DIR = "io.fpbp.sample.SITE_DIR"

        const val REQUEST_PERMISSIONS = 1

        /** The radios the sample listens to. */
        val RADIOS = setOf(Radio.BLE)
    }

    private class Retained(val site: LoadedSite, val positioning: FpbpPositioning, val recorder: LogRecorder?, val manualFloor: Int?)

    /** A site read from disk: its folder, site.json's text and its floor ids. */
    private class LoadedSite(val dir: File, val json: String, val floorIds: List<Int>)

    private var site: LoadedSite? = null

    private lateinit var planView: FloorPlanView
    private lateinit var statusView: TextView
    private lateinit var poseView: TextView
    private lateinit var floorButton: Button
    private lateinit var recordButton: Button
    private lateinit var shareButton: Button

    /** The positioning (null when the site could not be loaded). */
    var positioning: FpbpPositioning? = null
        private set
    private var poseSub: PoseSubscription? = null
    private var statusSub: AutoCloseable? = null
    private var recorder: LogRecorder? = null

    /** The last recorded log. */
    var lastLog: File? = null
        private set

    private lateinit var siteDir: File
    private var siteJson = ""
    private var floorIds: List<Int> = emptyList()

    /** Floor picked with the floor button; null = follow the pose's floor. */
    private var manualFloor: Int? = null
    private var lastPose: Pose? = null

    /** The floor whose plan is shown. */
    val shownFloor: Int get() = planView.floorId

    /** The status line's text. */
    val statusText: String get() = statusView.text.toString()

    /** The pose line's text. */
    val poseText: String get() = poseView.text.toString()

    override fun onCreate(savedInstanceState: Bundle?) {
        super.onCreate(savedInstanceState)
        buildUi()
        @Suppress("DEPRECATION")
        val retained = lastNonConfigurationInstance as? Retained
        if (retained != null) {
            recorder = retained.recorder
            manualFloor = retained.manualFloor
            attach(retained.site, retained.positioning)
            return
        }
        statusView.text = "loading the site"
        // Copying the assets and reading site.json may take long on a large
        // site: off the main thread. start() returns at once; its failure
        // shows on the status line (state FAILED).
        val intentDir = intent?.getStringExtra(EXTRA_SITE_DIR)
        val siteRoot = File(filesDir, "site")
        Thread({
            val loaded = try {
                loadSite(intentDir, siteRoot)
            } catch (e: Exception) {
                runOnUiThread { statusView.text = "cannot load the site: ${e.message}" }
                return@Thread
            }
            val p = FpbpPositioning(
                applicationContext,
                FpbpPositioning.Site(loaded.json, loaded.dir.path),
                FpbpPositioning.Options(engine = ENGINE, radios = RADIOS),
            )
            p.start()
            runOnUiThread {
                if (isDestroyed) {
                    p.close()
                } else {
                    attach(loaded, p)
                    requestMissingPermissions()
                }
            }
        }, "fpbp-sample-load").start()
    }

    /** Shows [site] and follows [p] (on the main thread). */
    private fun attach(site: LoadedSite, p: FpbpPositioning) {
        this.site = site
        siteDir = site.dir
        siteJson = site.json
        floorIds = site.floorIds
        positioning = p
        recordButton.text = if (recorder != null) "Stop recording" else "Record log"
        statusSub = p.addStatusListener(mainExecutorCompat()) { showStatus(it) }
        poseSub = p.addPoseListener(PoseRequest.DEFAULT, Looper.getMainLooper()) { showPose(it) }
        showFloor(manualFloor ?: lastPose?.floor ?: floorIds.first())
    }

    private fun mainExecutorCompat(): java.util.concurrent.Executor =
        if (Build.VERSION.SDK_INT >= 28) mainExecutor else java.util.concurrent.Executor { r -> planView.post(r) }

    private fun buildUi() {
        planView = FloorPlanView(this)
        statusView = TextView(this).apply { setPadding(16, 8, 16, 0) }
        poseView = TextView(this).apply { setPadding(16, 0, 16, 8) }
        floorButton = Button(this).apply { setOnClickListener { nextFloor() } }
        recordButton = Button(this).apply {
            text = "Record log"
            setOnClickListener { toggleRecording() }
        }
        shareButton = Button(this).apply {
            text = "Share log"
            isEnabled = false
            setOnClickListener { shareLog() }
        }
        val buttons = LinearLayout(this).apply {
            orientation = LinearLayout.HORIZONTAL
            addView(floorButton)
            addView(recordButton)
            addView(shareButton)
            addView(surveyButton())
        }
        setContentView(
            LinearLayout(this).apply {
                orientation = LinearLayout.VERTICAL
                addView(statusView)
                addView(poseView)
                addView(buttons)
                addView(planView, LinearLayout.LayoutParams(LinearLayout.LayoutParams.MATCH_PARENT, 0, 1f))
            },
        )
        planView.onTap = { x, y -> onTap(x, y) }
    }

    /** Opens the survey screen (SurveyActivity) on the same site. */
    private fun surveyButton() = Button(this).apply {
        text = "Survey"
        setOnClickListener {
            val open = Intent(this@MainActivity, SurveyActivity::class.java)
            intent?.getStringExtra(EXTRA_SITE_DIR)?.let { open.putExtra(SurveyActivity.EXTRA_SITE_DIR, it) }
            startActivity(open)
        }
    }

    /** Reads the site (the demo site is first copied from the assets); runs off the main thread. */
    private fun loadSite(given: String?, demoRoot: File): LoadedSite {
        val dir = if (given != null) File(given) else demoRoot.also { copyAssetDir("demo", it) }
        val json = File(dir, "site.json").readText()
        val floors = JSONObject(json).getJSONArray("floors")
        return LoadedSite(dir, json, (0 until floors.length()).map { floors.getJSONObject(it).getInt("id") })
    }

    private fun showFloor(id: Int) {
        val floors = JSONObject(siteJson).getJSONArray("floors")
        val floor = (0 until floors.length()).map { floors.getJSONObject(it) }.first { it.getInt("id") == id }
        val plan = floor.optString("plan", "")
        val r = floor.optDouble("pixels_per_meter", 1.0)
        val bitmap = if (plan.isNotEmpty()) BitmapFactory.decodeFile(File(siteDir, plan).path) else null
        planView.setPlan(id, bitmap, r)
        planView.setPose(lastPose, positioning?.currentBlePosition())
        floorButton.text = "Floor $id" + if (manualFloor == null) " (auto)" else ""
    }

    /** Cycles auto -> each floor -> auto. */
    private fun nextFloor() {
        if (floorIds.isEmpty()) return // still loading
        val m = manualFloor
        manualFloor = when {
            m == null -> floorIds.first()
            floorIds.indexOf(m) == floorIds.lastIndex -> null
            else -> floorIds[floorIds.indexOf(m) + 1]
        }
        showFloor(manualFloor ?: lastPose?.floor ?: floorIds.first())
    }

    private fun showPose(pose: Pose) {
        lastPose = pose
        val want = manualFloor ?: pose.floor
        if (want != planView.floorId && want in floorIds) showFloor(want)
        planView.setPose(pose, positioning?.currentBlePosition())
        val geo = if (pose.latDeg != null) " %.6f, %.6f".format(Locale.US, pose.latDeg, pose.lonDeg) else ""
        // the phone's RSSI offset the engine learns while walking (tcpf): a
        // site engineer sees at a glance how this phone reads against the survey
        val offset = positioning?.stats()?.rssiOffsetDb?.let { "  phone RSSI %+.1f dB".format(Locale.US, it) } ?: ""
        poseView.text = "floor %d (%.0f %%)  x %.1f m  y %.1f m  ±%.1f m  bearing %.0f°  %s%s%s".format(
            Locale.US, pose.floor, 100 * pose.floorProb, pose.xM, pose.yM, pose.accuracyM, pose.bearingDeg,
            pose.source.name.lowercase().replace('_', ' '), geo, offset,
        )
    }

    private fun showStatus(s: Status) {
        val hint = when {
            s.missingPermissions.isNotEmpty() ->
                " — beacons cannot be heard without the permission; tap where you are to track by dead reckoning"
            else -> ""
        }
        statusView.text = s.describe() + hint
    }

    private fun requestMissingPermissions() {
        val missing = FpbpPositioning.missingPermissions(this, RADIOS) +
            RadioPermissions.notification(Build.VERSION.SDK_INT).filter { checkSelfPermission(it) != PackageManager.PERMISSION_GRANTED }
        if (missing.isNotEmpty()) requestPermissions(missing.toTypedArray(), REQUEST_PERMISSIONS)
    }

    override fun onRequestPermissionsResult(requestCode: Int, permissions: Array<out String>, grantResults: IntArray) {
        super.onRequestPermissionsResult(requestCode, permissions, grantResults)
        if (requestCode == REQUEST_PERMISSIONS) positioning?.refreshPermissions()
    }

    /** A tap sets the position; a refusal shows on the status line (Problem.POSITION_REFUSED). */
    private fun onTap(xM: Double, yM: Double) {
        positioning?.setPosition(xM, yM, planView.floorId)
    }

    /** Record log / Stop recording. */
    fun toggleRecording() {
        val p = positioning ?: return
        val r = recorder
        if (r != null) {
            p.inputObserver = null
            recorder = null
            r.close()
            lastLog = r.file
            recordButton.text = "Record log"
            shareButton.isEnabled = true
            statusView.text = "saved ${r.file.name}"
            return
        }
        val dir = LogFileProvider.logDir(this).apply { mkdirs() }
        val name = "fpbp-" + SimpleDateFormat("yyyyMMdd-HHmmss", Locale.US).format(Date()) + ".log"
        // the phone model the engine was given, so that `fpbp eval` applies its offsets as the engine did
        val meta = listOfNotNull(
            p.device?.let { "device" to it },
            "android_api" to Build.VERSION.SDK_INT.toString(),
            "site" to JSONObject(siteJson).optString("name"),
            "engine" to ENGINE,
            "app" to "io.fpbp.sample",
        ).toMap()
        recorder = LogRecorder(File(dir, name), meta).also { p.inputObserver = it }
        recordButton.text = "Stop recording"
    }

    /** Shares the last recorded log (ACTION_SEND with a read grant on its content URI). */
    private fun shareLog() {
        val f = lastLog ?: return
        val send = Intent(Intent.ACTION_SEND).apply {
            type = "text/plain"
            putExtra(Intent.EXTRA_STREAM, LogFileProvider.uriFor(f))
            putExtra(Intent.EXTRA_SUBJECT, f.name)
            addFlags(Intent.FLAG_GRANT_READ_URI_PERMISSION)
        }
        startActivity(Intent.createChooser(send, "Share ${f.name}"))
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

    @Deprecated("framework API without AndroidX")
    override fun onRetainNonConfigurationInstance(): Any? =
        positioning?.let { p -> site?.let { Retained(it, p, recorder, manualFloor) } }

    override fun onDestroy() {
        poseSub?.remove()
        poseSub = null
        statusSub?.close()
        statusSub = null
        if (!isChangingConfigurations) {
            positioning?.inputObserver = null
            recorder?.close()
            recorder = null
            positioning?.close()
        }
        positioning = null
        super.onDestroy()
    }
}
