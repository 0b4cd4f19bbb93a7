package io.fpbp.android

import android.app.Activity
import android.app.Application
import android.content.Context
import android.content.Intent
import android.content.pm.PackageManager
import android.location.LocationManager
import android.os.Build
import android.os.Bundle
import android.os.Handler
import android.os.HandlerThread
import android.os.Looper
import android.os.SystemClock
import io.fpbp.BeaconFilter
import io.fpbp.Clock
import io.fpbp.EngineStats
import io.fpbp.FpbpDefaults
import io.fpbp.FpbpEngine
import io.fpbp.InitialPosition
import io.fpbp.Pose
import io.fpbp.PoseDispatcher
import io.fpbp.PoseListener
import io.fpbp.PoseRequest
import io.fpbp.PoseSubscription
import io.fpbp.Problem
import io.fpbp.Radio
import io.fpbp.RadioPermissions
import io.fpbp.SiteBundle
import io.fpbp.Status
import io.fpbp.StatusListener
import io.fpbp.StatusTracker
import io.fpbp.TaskScheduler
import kotlinx.coroutines.channels.awaitClose
import kotlinx.coroutines.flow.Flow
import kotlinx.coroutines.flow.callbackFlow
import kotlinx.coroutines.flow.conflate
import org.json.JSONObject
import java.util.concurrent.CopyOnWriteArrayList
import java.util.concurrent.Executor
import java.util.concurrent.Executors
import java.util.concurrent.TimeUnit

/**
 * Indoor positioning for an app: owns the engine, its two tasks, BLE
 * scanning, the sensors (and WiFi when asked), the lifecycle and delivery.
 *
 * ```
 * val positioning = FpbpPositioning(context, FpbpPositioning.Site(siteJson, siteDir))
 * positioning.addStatusListener(mainExecutor) { status -> statusLine.text = status.describe() }
 * scope.launch { positioning.poses().collect { pose -> show(pose) } }
 * positioning.start()   // after RadioPermissions.required(...) were requested
 * ```
 *
 * Holds only the application context: an Activity may create and drop
 * listeners across configuration changes without leaking itself (remove
 * them in `onDestroy`). [start], [stop], [pause], [resume],
 * [refreshPermissions] and [setPosition] may be called from any thread; the
 * work runs on the library's control thread. Poses and statuses are
 * delivered on the executor (or looper) each listener chose.
 */
class FpbpPositioning @JvmOverloads constructor(
    context: Context,
    private val site: Site,
    private val options: Options = Options(),
) : AutoCloseable {
    /**
     * A site: the text of site.json and the directory its plan paths are
     * relative to, with the radio map's JSON ([radioMapJson], `fpbp calibrate
     * --radio-map`; null = the site's path-loss models); or a site bundle
     * ([fromBundle]: site, plans and radio map in one file, read in place).
     */
    data class Site @JvmOverloads constructor(
        val json: String,
        val dir: String,
        val radioMapJson: String? = null,
        val bundle: SiteBundle? = null,
    ) {
        init {
            require(bundle == null || radioMapJson == null) { "a bundle carries its own radio map" }
        }

        companion object {
            /** The site of a bundle (`fpbp bundle`); its radio map reaches the engine. */
            @JvmStatic
            fun fromBundle(bundle: SiteBundle): Site = Site(bundle.siteJson, "", null, bundle)

            /** The site of the bundle file [file], mapped read-only. */
            @JvmStatic
            fun fromBundle(file: java.io.File): Site = fromBundle(SiteBundle.fromFile(file))
        }

        /** Starts [engine] on this site with its radio map (what [FpbpPositioning.start] does). */
        fun startEngine(engine: String, configJson: String, init: InitialPosition?): FpbpEngine =
            if (bundle != null) {
                FpbpEngine.startBundle(bundle, engine, configJson, init)
            } else {
                FpbpEngine.start(json, dir, engine, configJson, init, radioMapJson)
            }
    }

    /**
     * @property engine engine name ([FpbpDefaults.ENGINE] by default).
     * @property configJson engine config (empty = defaults).
     * @property radios radios positioning listens to; their permissions are checked.
     * @property ownBle the library scans BLE itself (false: the app feeds [onBleScan]).
     * @property ownSensors the library registers the sensors itself (false: the app feeds [onSensor]).
     * @property ownWifi the library listens to WiFi scans itself when [radios] has WIFI.
     * @property initialPosition a start position, or null (the engine finds its own).
     * @property followAppForeground switch BLE scan mode and sensor batching with the app's
     *   visibility (Application.ActivityLifecycleCallbacks), unless the foreground service runs.
     */
    data class Options(
        val engine: String = FpbpDefaults.ENGINE,
        val configJson: String = "",
        val radios: Set<Radio> = setOf(Radio.BLE),
        val ownBle: Boolean = true,
        val ownSensors: Boolean = true,
        val ownWifi: Boolean = true,
        val initialPosition: InitialPosition? = null,
        val followAppForeground: Boolean = true,
    )

    /** Receives every input the engine is fed (the sample app records them). */
    interface InputObserver {
        fun onSensor(type: Int, tNs: Long, values: DoubleArray) {}
        fun onBle(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) {}
        fun onWifi(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) {}
        fun onSetPosition(tNs: Long, at: InitialPosition) {}
    }

    companion object {
        /** Period of the delivery heartbeat and status checks, ms. */
        const val TICK_MS: Long = 100

        /** How long no activity of the app is started before the sources switch to background mode, ms. */
        const val BACKGROUND_DELAY_MS: Long = 1000

        /** Status checks (beacon heard, lost) every this many ticks (1 s). */
        const val STATUS_TICKS: Int = 10

        /** Runtime permissions [radios] need on this phone that are not granted. */
        @JvmStatic
        fun missingPermissions(context: Context, radios: Set<Radio>): List<String> =
            RadioPermissions.required(Build.VERSION.SDK_INT, radios).filter {
                context.checkSelfPermission(it) != PackageManager.PERMISSION_GRANTED
            }

        /** Beacon ids listed in a site.json (for the scan filters). */
        @JvmStatic
        fun beaconIds(siteJson: String): List<String> {
            val arr = JSONObject(siteJson).optJSONArray("beacons") ?: return emptyList()
            return (0 until arr.length()).mapNotNull { arr.optJSONObject(it)?.optString("id")?.takeIf { id -> id.isNotEmpty() } }
        }
    }

    private val app: Context = context.applicationContext

    /** The clock of SensorEvent.timestamp and ScanResult.getTimestampNanos(). */
    val clock: Clock = Clock { SystemClock.elapsedRealtimeNanos() }

    private val control = HandlerThread("fpbp-control").also { it.start() }
    private val handler = Handler(control.looper)
    private val dispatcher = PoseDispatcher(clock)
    private val tracker = StatusTracker(clock)
    private val statusListeners = CopyOnWriteArrayList<Pair<Executor, StatusListener>>()

    @Volatile private var engine: FpbpEngine? = null
    private var tasks: TaskScheduler? = null
    private var ble: BleSource? = null
    private var sensors: SensorSource? = null
    private var wifi: WifiSource? = null
    private var ticker: java.util.concurrent.ScheduledExecutorService? = null
    private var input: java.util.concurrent.ExecutorService? = null
    private var ticks = 0
    private var foreground = true
    private var serviceMode = false
    private var startedActivities = 0
    private var lifecycleRegistered = false
    @Volatile private var closed = false

    /** Observer of every input fed to the engine, or null. */
    @Volatile var inputObserver: InputObserver? = null

    /** The status now. */
    val status: Status get() = tracker.status

    /** Whether [start] ran and [stop] did not since. */
    val isRunning: Boolean get() = engine != null

    /** The engine's counters (JSON), or null when stopped. Never waits for a task. */
    fun statsJson(): String? = engine?.let { e -> runCatching { e.statsJson() }.getOrNull() }

    /**
     * The engine's counters and online estimates (the phone's RSSI offset,
     * the step scale), typed; null when stopped. Never waits for a task.
     */
    fun stats(): EngineStats? = engine?.let { e -> runCatching { e.stats() }.getOrNull() }

    /** The latest pose, null before a fix or when stopped. Never waits for a running task. */
    fun currentPose(): Pose? = engine?.let { e -> runCatching { e.pose() }.getOrNull() }

    /** The last BLE-only position (x_B), when the engine has one. */
    fun currentBlePosition(): Pose? = engine?.let { e -> runCatching { e.blePosition() }.getOrNull() }

    /** BLE scan starts made so far (diagnostics). */
    val bleScanStarts: Int get() = ble?.starts ?: 0

    private fun onControl(block: () -> Unit) {
        if (Looper.myLooper() == control.looper) block() else handler.post(block)
    }

    /** Runs [block] on the control thread and waits for it (start/stop are synchronous for callers). */
    private fun <T> onControlSync(block: () -> T): T {
        if (Looper.myLooper() == control.looper) return block()
        val result = java.util.concurrent.FutureTask(block)
        handler.post(result)
        return try {
            result.get(30, TimeUnit.SECONDS)
        } catch (e: java.util.concurrent.ExecutionException) {
            throw e.cause ?: e
        }
    }

    /**
     * Starts the engine, its tasks and the library's sources. Throws
     * [IllegalArgumentException] for a bad site, config or engine name.
     * Sources whose permissions are missing do not start: the status says
     * [Problem.PERMISSION_MISSING]; call [refreshPermissions] once granted.
     */
    fun start() = onControlSync {
        check(!closed) { "FpbpPositioning is closed" }
        if (engine != null) return@onControlSync
        val e = site.startEngine(options.engine, options.configJson, options.initialPosition)
        engine = e
        input = Executors.newSingleThreadExecutor { r -> Thread(r, "fpbp-input").apply { isDaemon = true } }
        tasks = TaskScheduler(e, clock, null) { dispatcher.offer(currentPose()) }
        tracker.started()
        if (options.followAppForeground) registerLifecycle()
        startSources()
        ticks = 0
        ticker = Executors.newSingleThreadScheduledExecutor { r -> Thread(r, "fpbp-tick").apply { isDaemon = true } }.also {
            it.scheduleWithFixedDelay({ tick() }, TICK_MS, TICK_MS, TimeUnit.MILLISECONDS)
        }
        publishStatus()
    }

    /** Stops everything and frees the engine; [start] may be called again. */
    fun stop() = onControlSync {
        stopSources()
        ticker?.shutdownNow()
        ticker = null
        tasks?.close()
        tasks = null
        input?.shutdown()
        input?.awaitTermination(5, TimeUnit.SECONDS)
        input = null
        engine?.close()
        engine = null
        unregisterLifecycle()
        tracker.stopped()
        publishStatus()
    }

    /** Stops the sources and the tasks but keeps the engine and its state. */
    fun pause() = onControlSync {
        if (engine == null) return@onControlSync
        stopSources()
        tasks?.close()
        tasks = null
        tracker.paused(true)
        publishStatus()
    }

    /** Undoes [pause]. */
    fun resume() = onControlSync {
        val e = engine ?: return@onControlSync
        if (tasks != null) return@onControlSync
        tasks = TaskScheduler(e, clock, null) { dispatcher.offer(currentPose()) }
        tracker.paused(false)
        startSources()
        publishStatus()
    }

    /** Re-checks the permissions (after the app's permission dialog) and starts what was waiting for them. */
    fun refreshPermissions() = onControl {
        if (engine == null || tasks == null) return@onControl
        startSources()
        publishStatus()
    }

    /**
     * Moves the user to ([xM], [yM]) on [floor] now (a tap, a QR code) without
     * a restart. Throws [UnsupportedOperationException] when the engine cannot
     * take a position, [IllegalArgumentException] for a floor the site lacks,
     * [IllegalStateException] when not started.
     */
    @JvmOverloads
    fun setPosition(xM: Double, yM: Double, floor: Int, headingRad: Double? = null) {
        val e = engine ?: throw IllegalStateException("FpbpPositioning is not started")
        val at = InitialPosition(xM, yM, floor, headingRad)
        val t = clock.nowNs()
        e.setPosition(t, at)
        inputObserver?.onSetPosition(t, at)
        dispatcher.offer(currentPose())
    }

    /** Registers [listener] for poses at [request], run on [executor]. */
    @JvmOverloads
    fun addPoseListener(request: PoseRequest = PoseRequest.DEFAULT, executor: Executor, listener: PoseListener): PoseSubscription =
        dispatcher.add(request, executor, listener).also { dispatcher.offer(currentPose()) }

    /** Registers [listener] for poses at [request], run on [looper] (e.g. the main looper). */
    fun addPoseListener(request: PoseRequest, looper: Looper, listener: PoseListener): PoseSubscription {
        val h = Handler(looper)
        return addPoseListener(request, { r -> h.post(r) }, listener)
    }

    /** Pose listeners registered now (tests check that none leak). */
    val poseListenerCount: Int get() = dispatcher.size

    /** Poses at [request] as a cold, conflated [Flow]. */
    @JvmOverloads
    fun poses(request: PoseRequest = PoseRequest.DEFAULT): Flow<Pose> = dispatcher.flow(request)

    /** Registers a status listener (called at once with the current status, then on every change). */
    fun addStatusListener(executor: Executor, listener: StatusListener): AutoCloseable {
        val entry = executor to listener
        statusListeners.add(entry)
        val now = tracker.status
        executor.execute { listener.onStatus(now) }
        return AutoCloseable { statusListeners.remove(entry) }
    }

    /** Status listeners registered now. */
    val statusListenerCount: Int get() = statusListeners.size

    /** The status as a cold, conflated [Flow] (the current one first). */
    fun statuses(): Flow<Status> = callbackFlow {
        val reg = addStatusListener({ it.run() }) { trySend(it) }
        awaitClose { reg.close() }
    }.conflate()

    /** App-fed sensor sample (when [Options.ownSensors] is false, or in addition). */
    fun onSensor(type: Int, tNs: Long, values: DoubleArray) = feed { it.onSensor(type, tNs, values); inputObserver?.onSensor(type, tNs, values) }

    /** App-fed BLE advertisement. */
    fun onBleScan(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) =
        feed { it.onBleScan(tNs, beaconId, rssiDbm, txPowerDbm); inputObserver?.onBle(tNs, beaconId, rssiDbm, txPowerDbm) }

    /** App-fed WiFi scan. */
    fun onWifiScan(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) =
        feed { it.onWifiScan(tNs, bssids, rssiDbm, freqMhz, seenTNs); inputObserver?.onWifi(tNs, bssids, rssiDbm, freqMhz, seenTNs) }

    private inline fun feed(block: (FpbpEngine) -> Unit) {
        val e = engine ?: return
        try {
            block(e)
        } catch (_: IllegalStateException) {
            // stopped while the sample was in flight
        }
    }

    /**
     * Foreground-service mode: keeps positioning when the app leaves the
     * screen (service type `location`; start it while the app is visible,
     * Android 14 refuses otherwise). The service holds this object until
     * [stopForegroundService] or [stop].
     */
    fun startForegroundService(title: String = "Indoor positioning") {
        FpbpPositioningService.attach(this)
        val intent = Intent(app, FpbpPositioningService::class.java).putExtra(FpbpPositioningService.EXTRA_TITLE, title)
        if (Build.VERSION.SDK_INT >= 26) app.startForegroundService(intent) else app.startService(intent)
    }

    /** Ends the foreground-service mode (positioning keeps running while the app is visible). */
    fun stopForegroundService() {
        app.stopService(Intent(app, FpbpPositioningService::class.java))
    }

    internal fun setServiceMode(on: Boolean) = onControl {
        serviceMode = on
        applyForeground()
    }

    /** Foreground (low-latency scans, no sensor batching) or background mode, when not following the app. */
    fun setForeground(fg: Boolean) = onControl {
        foreground = fg
        applyForeground()
    }

    private fun effectiveForeground() = foreground || serviceMode

    private fun applyForeground() {
        val fg = effectiveForeground()
        ble?.setForeground(fg)
        wifi?.setForeground(fg)
        val s = sensors
        if (s != null && s.isRegistered) tracker.sensorsMissing(s.start(fg))
    }

    private fun startSources() {
        val missing = missingPermissions(app, options.radios)
        tracker.permissionsMissing(missing)
        val fg = effectiveForeground()
        if (options.ownSensors && sensors == null) {
            val s = SensorSource(app) { type, t, v -> feed { e -> e.onSensor(type, t, v); inputObserver?.onSensor(type, t, v) } }
            sensors = s
            tracker.sensorsMissing(s.start(fg))
        }
        if (missing.isNotEmpty()) return
        tracker.set(Problem.LOCATION_OFF, Build.VERSION.SDK_INT >= 28 && !locationEnabled())
        if (options.ownBle && Radio.BLE in options.radios && ble == null) {
            val filters = BeaconFilter.forBeacons(beaconIds(site.json))
            ble = BleSource(app, handler, clock, filters, tracker, ::publishStatus) { t, id, rssi, tx ->
                input?.execute { onBleScan(t, id, rssi, tx) }
            }.also { it.start(fg) }
        }
        if (options.ownWifi && Radio.WIFI in options.radios && wifi == null) {
            wifi = WifiSource(app, handler, clock, tracker, ::publishStatus) { t, b, r, f, s ->
                input?.execute { onWifiScan(t, b, r, f, s) }
            }.also { it.start(fg) }
        }
    }

    private fun stopSources() {
        ble?.stop()
        ble = null
        wifi?.stop()
        wifi = null
        sensors?.stop()
        sensors = null
    }

    private fun locationEnabled(): Boolean {
        val lm = app.getSystemService(Context.LOCATION_SERVICE) as LocationManager? ?: return true
        return if (Build.VERSION.SDK_INT >= 28) lm.isLocationEnabled else true
    }

    private fun tick() {
        val pose = currentPose()
        dispatcher.offer(pose)
        if (++ticks % STATUS_TICKS != 0) return
        val stats = stats() ?: return
        tracker.tick(stats.bleObservations - stats.unknownBeacons, pose)
        publishStatus()
    }

    private fun publishStatus() {
        val s = tracker.update() ?: return
        for ((executor, listener) in statusListeners) executor.execute { listener.onStatus(s) }
    }

    private val mainHandler = Handler(Looper.getMainLooper())
    private val toBackground = Runnable { if (startedActivities == 0) setForeground(false) }

    private val lifecycle = object : Application.ActivityLifecycleCallbacks {
        override fun onActivityStarted(activity: Activity) {
            startedActivities++
            if (startedActivities == 1) setForeground(true)
        }

        override fun onActivityStopped(activity: Activity) {
            startedActivities = (startedActivities - 1).coerceAtLeast(0)
            // A rotation stops one activity and starts the next: wait before
            // switching modes, so it costs no scan restart.
            if (startedActivities == 0) mainHandler.postDelayed(toBackground, BACKGROUND_DELAY_MS)
        }

        override fun onActivityCreated(activity: Activity, savedInstanceState: Bundle?) = Unit
        override fun onActivityResumed(activity: Activity) = Unit
        override fun onActivityPaused(activity: Activity) = Unit
        override fun onActivitySaveInstanceState(activity: Activity, outState: Bundle) = Unit
        override fun onActivityDestroyed(activity: Activity) = Unit
    }

    private fun registerLifecycle() {
        val a = app as? Application ?: return
        if (!lifecycleRegistered) {
            a.registerActivityLifecycleCallbacks(lifecycle)
            lifecycleRegistered = true
        }
    }

    private fun unregisterLifecycle() {
        mainHandler.removeCallbacks(toBackground)
        val a = app as? Application ?: return
        if (lifecycleRegistered) {
            a.unregisterActivityLifecycleCallbacks(lifecycle)
            lifecycleRegistered = false
        }
    }

    /** [stop], then ends the control thread; the object cannot be started again. */
    override fun close() {
        if (closed) return
        stop()
        stopForegroundServiceIfAttached()
        closed = true
        dispatcher.clear()
        statusListeners.clear()
        control.quitSafely()
    }

    private fun stopForegroundServiceIfAttached() {
        if (FpbpPositioningService.attached() === this) stopForegroundService()
    }
}
