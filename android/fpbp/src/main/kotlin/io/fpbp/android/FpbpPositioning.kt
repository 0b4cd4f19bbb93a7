package io.fpbp.android

import android.app.Activity
import android.app.Application
import android.content.BroadcastReceiver
import android.content.Context
import android.content.Intent
import android.content.IntentFilter
import android.content.pm.PackageManager
import android.location.Location
import android.location.LocationManager
import android.os.Build
import android.os.Bundle
import android.os.Handler
import android.os.HandlerThread
import android.os.Looper
import android.os.SystemClock
import android.util.Log
import io.fpbp.BeaconFilter
import io.fpbp.Clock
import io.fpbp.EngineStats
import io.fpbp.FpbpDefaults
import io.fpbp.FpbpEngine
import io.fpbp.FpbpNativeException
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
import io.fpbp.Reaper
import io.fpbp.SiteGeo
import io.fpbp.Status
import io.fpbp.StatusListener
import io.fpbp.StatusTracker
import io.fpbp.TaskScheduler
import kotlinx.coroutines.channels.awaitClose
import kotlinx.coroutines.flow.Flow
import kotlinx.coroutines.flow.callbackFlow
import kotlinx.coroutines.flow.conflate
import kotlinx.coroutines.future.await
import org.json.JSONObject
import java.util.Collections
import java.util.WeakHashMap
import java.util.concurrent.CompletableFuture
import java.util.concurrent.CompletionException
import java.util.concurrent.CopyOnWriteArrayList
import java.util.concurrent.Executor
import java.util.concurrent.ExecutorService
import java.util.concurrent.Executors
import java.util.concurrent.RejectedExecutionException
import java.util.concurrent.ScheduledExecutorService
import java.util.concurrent.TimeUnit
import java.util.concurrent.atomic.AtomicInteger
import java.util.concurrent.atomic.AtomicLong
import java.util.concurrent.atomic.AtomicReference

/**
 * Indoor positioning for an app: owns the engine, its two tasks, BLE
 * scanning, the sensors (and WiFi when asked), the lifecycle and delivery.
 *
 * ```
 * val positioning = FpbpPositioning(context, FpbpPositioning.Site(siteJson, siteDir))
 * positioning.addStatusListener(mainExecutor) { status -> statusLine.text = status.describe() }
 * scope.launch { positioning.poses().collect { pose -> show(pose) } }
 * positioning.start()   // after RadioPermissions.required(...) were requested; returns at once
 * ```
 *
 * Holds only the application context: an Activity may create and drop
 * listeners across configuration changes without leaking itself (remove
 * them in `onDestroy`). [start], [stop], [pause], [resume], [close],
 * [refreshPermissions] and [setPosition] may be called from any thread and
 * never block: the work runs on the library's control thread, each returns a
 * [CompletableFuture] (Kotlin: the `await*` suspend functions; Java: the
 * future or the [CompletionCallback] overloads), and every failure also
 * becomes a [Status] ([io.fpbp.PositioningState.FAILED],
 * [Problem.POSITION_REFUSED], ...). Poses and statuses are delivered on the
 * executor (or looper) each listener chose.
 *
 * An instance the app forgets to [close] is released when the garbage
 * collector finds it unreachable ([Reaper]: the engine is stopped, the
 * sources and threads end).
 */
class FpbpPositioning @JvmOverloads constructor(
    context: Context,
    site: Site,
    options: Options = Options(),
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

    /** The end of an asynchronous call, for Java callers: [error] is null on success. */
    fun interface CompletionCallback {
        fun onComplete(error: Throwable?)
    }

    companion object {
        /** Period of the delivery heartbeat and status checks, ms. */
        const val TICK_MS: Long = 100

        /** How long no activity of the app is started before the sources switch to background mode, ms. */
        const val BACKGROUND_DELAY_MS: Long = 1000

        /** Status checks (beacon heard, lost) every this many ticks (1 s). */
        const val STATUS_TICKS: Int = 10

        /**
         * Largest accuracy (68 % radius, metres) a WGS-84 position handed to
         * [setPositionWgs84] may have. The engines take a position as a
         * point; a fix less certain than a room (an indoor GNSS fix is often
         * 20-50 m) would pull the estimate away from a better one, so it is
         * refused ([Problem.POSITION_REFUSED]).
         */
        const val MAX_SET_POSITION_ACCURACY_M: Double = 10.0

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

    // Everything that runs (threads, receivers, callbacks) refers to the
    // core, never to this object, so an instance the app drops becomes
    // unreachable and the reaper closes the core.
    private val core = PositioningCore(context.applicationContext, site, options)
    private val cleanable = Reaper.register(this, core::closeAsyncIgnoringResult)

    /** The clock of SensorEvent.timestamp and ScanResult.getTimestampNanos(). */
    val clock: Clock get() = core.clock

    /** The site's map <-> WGS-84 conversion, null when site.json has no `georef`. */
    val geo: SiteGeo? get() = core.geo

    /**
     * Observer of every input fed to the engine, or null. An observer that
     * throws is removed (and counted in [listenerFaults]).
     */
    var inputObserver: InputObserver?
        get() = core.inputObserver
        set(value) {
            core.inputObserver = value
        }

    /** The status now. */
    val status: Status get() = core.tracker.status

    /** Whether the engine runs: [start] completed and [stop] (or a failure) did not come since. */
    val isRunning: Boolean get() = core.engine != null

    /** The engine's counters (JSON), or null when stopped. Never waits for a task. */
    fun statsJson(): String? = core.statsJson()

    /**
     * The engine's counters and online estimates (the phone's RSSI offset,
     * the step scale), typed; null when stopped. Never waits for a task.
     */
    fun stats(): EngineStats? = core.stats()

    /** The latest pose, null before a fix or when stopped. Never waits for a running task. */
    fun currentPose(): Pose? = core.currentPose()

    /** The last BLE-only position (x_B), when the engine has one. */
    fun currentBlePosition(): Pose? = core.currentBlePosition()

    /** BLE scan starts made so far (diagnostics). */
    val bleScanStarts: Int get() = core.bleScanStarts

    /**
     * The phone model's name the engine is given as its config's `device`
     * (which phone model's offsets of a radio map apply): the one
     * [Options.configJson] names, else [DeviceModel.canonical]; null when
     * there is none. Record it with a log (`#meta device=`) so that `fpbp
     * eval` of the log applies the offsets the engine did.
     */
    val device: String? get() = core.device

    /**
     * How many times a callback of the app failed so far: a pose or status
     * listener, an [InputObserver] or a [CompletionCallback] threw, or its
     * executor refused the delivery. Each is contained (positioning goes on,
     * the other listeners are served); the first is logged (tag `fpbp`) and
     * named in the status ([Problem.LISTENER_FAULT]).
     */
    val listenerFaults: Long get() = core.listenerFaults

    /** Whether the sources run in foreground mode now (tests, diagnostics). */
    internal val foregroundMode: Boolean get() = core.foregroundMode

    /** Heartbeat ticks since the start (tests: the ticker is alive). */
    internal val ticks: Int get() = core.tickCount

    /** The control thread (tests: it ends when the instance is closed or released). */
    internal val controlThread: Thread get() = core.control

    /**
     * Starts the engine, its tasks and the library's sources on the control
     * thread; returns at once. The future completes when positioning runs,
     * or exceptionally with the reason ([IllegalArgumentException] for a bad
     * site, config or engine name; [IllegalStateException] after [close]),
     * which the status also shows ([io.fpbp.PositioningState.FAILED] with
     * [Status.failure]). Sources whose permissions are missing do not start:
     * the status says [Problem.PERMISSION_MISSING]; call [refreshPermissions]
     * once granted. Starting a running instance does nothing.
     */
    fun start(): CompletableFuture<Void?> = core.start()

    /** [start], then [callback] on [executor] (Java). */
    fun start(executor: Executor, callback: CompletionCallback) = core.notify(start(), executor, callback)

    /** [start], suspending until positioning runs; throws what [start]'s future completes with. */
    suspend fun awaitStart() {
        start().awaitUnwrapped()
    }

    /** Stops everything and frees the engine; [start] may be called again. Returns at once. */
    fun stop(): CompletableFuture<Void?> = core.stop()

    /** [stop], then [callback] on [executor] (Java). */
    fun stop(executor: Executor, callback: CompletionCallback) = core.notify(stop(), executor, callback)

    /** [stop], suspending until stopped. */
    suspend fun awaitStop() {
        stop().awaitUnwrapped()
    }

    /** Stops the sources and the tasks but keeps the engine and its state. Returns at once. */
    fun pause(): CompletableFuture<Void?> = core.pause()

    /** [pause], then [callback] on [executor] (Java). */
    fun pause(executor: Executor, callback: CompletionCallback) = core.notify(pause(), executor, callback)

    /** [pause], suspending until paused. */
    suspend fun awaitPause() {
        pause().awaitUnwrapped()
    }

    /** Undoes [pause]. Returns at once. */
    fun resume(): CompletableFuture<Void?> = core.resume()

    /** [resume], then [callback] on [executor] (Java). */
    fun resume(executor: Executor, callback: CompletionCallback) = core.notify(resume(), executor, callback)

    /** [resume], suspending until resumed. */
    suspend fun awaitResume() {
        resume().awaitUnwrapped()
    }

    /** Re-checks the permissions (after the app's permission dialog) and starts what was waiting for them. */
    fun refreshPermissions() = core.refreshPermissions()

    /**
     * Moves the user to ([xM], [yM]) on [floor] now (a tap, a QR code)
     * without a restart; runs on the control thread and returns at once. The
     * future completes exceptionally with [UnsupportedOperationException]
     * when the engine cannot take a position, [IllegalArgumentException] for
     * a point off the site's floors, [IllegalStateException] when not
     * started; the status then has [Problem.POSITION_REFUSED] with the reason
     * (cleared by the next accepted position).
     *
     * @param headingRad walking heading in the map frame (radians, atan2(dy, dx)), null = unknown.
     */
    @JvmOverloads
    fun setPosition(xM: Double, yM: Double, floor: Int, headingRad: Double? = null): CompletableFuture<Void?> =
        core.setPosition(InitialPosition(xM, yM, floor, headingRad))

    /**
     * [setPosition] from WGS-84 through the site's georef ([geo]): latitude
     * and longitude in degrees, [floor] as in site.json, [accuracyM] the
     * position's 68 % radius in metres (at most [MAX_SET_POSITION_ACCURACY_M];
     * the engine takes the point itself), [bearingDeg] the walking direction
     * from true north, degrees clockwise (null = unknown). Refused
     * ([Problem.POSITION_REFUSED], future completed with
     * [IllegalArgumentException]) when the site has no georef, the accuracy
     * is not in [0, [MAX_SET_POSITION_ACCURACY_M]] or the point is off the
     * site's floors.
     */
    @JvmOverloads
    fun setPositionWgs84(
        latDeg: Double,
        lonDeg: Double,
        floor: Int,
        accuracyM: Double,
        bearingDeg: Double? = null,
    ): CompletableFuture<Void?> = core.setPositionWgs84(latDeg, lonDeg, floor, accuracyM, bearingDeg)

    /**
     * [setPositionWgs84] from an `android.location.Location` (latitude,
     * longitude, accuracy and, when it has one, bearing) on [floor]. A
     * location without accuracy is refused.
     */
    fun setPosition(location: Location, floor: Int): CompletableFuture<Void?> = setPositionWgs84(
        location.latitude,
        location.longitude,
        floor,
        if (location.hasAccuracy()) location.accuracy.toDouble() else Double.NaN,
        if (location.hasBearing()) location.bearing.toDouble() else null,
    )

    /** Registers [listener] for poses at [request], run on [executor]. */
    @JvmOverloads
    fun addPoseListener(request: PoseRequest = PoseRequest.DEFAULT, executor: Executor, listener: PoseListener): PoseSubscription =
        core.dispatcher.add(request, executor, listener).also { core.dispatcher.offer(core.currentPose()) }

    /** Registers [listener] for poses at [request], run on [looper] (e.g. the main looper). */
    fun addPoseListener(request: PoseRequest, looper: Looper, listener: PoseListener): PoseSubscription {
        val h = Handler(looper)
        return addPoseListener(request, { r -> h.post(r) }, listener)
    }

    /** Pose listeners registered now (tests check that none leak). */
    val poseListenerCount: Int get() = core.dispatcher.size

    /** Poses at [request] as a cold, conflated [Flow]. */
    @JvmOverloads
    fun poses(request: PoseRequest = PoseRequest.DEFAULT): Flow<Pose> = core.dispatcher.flow(request)

    /** Registers a status listener (called at once with the current status, then on every change). */
    fun addStatusListener(executor: Executor, listener: StatusListener): AutoCloseable = core.addStatusListener(executor, listener)

    /** Status listeners registered now. */
    val statusListenerCount: Int get() = core.statusListeners.size

    /** The status as a cold, conflated [Flow] (the current one first). */
    fun statuses(): Flow<Status> = callbackFlow {
        val reg = core.addStatusListener({ it.run() }) { trySend(it) }
        awaitClose { reg.close() }
    }.conflate()

    /** App-fed sensor sample (when [Options.ownSensors] is false, or in addition). Never throws. */
    fun onSensor(type: Int, tNs: Long, values: DoubleArray) = core.feedSensor(type, tNs, values)

    /** App-fed BLE advertisement. Never throws. */
    fun onBleScan(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) =
        core.feedBle(tNs, beaconId, rssiDbm, txPowerDbm)

    /** App-fed WiFi scan. Never throws. */
    fun onWifiScan(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) =
        core.feedWifi(tNs, bssids, rssiDbm, freqMhz, seenTNs)

    /**
     * Foreground-service mode: keeps positioning when the app leaves the
     * screen (service type `location`; start it while the app is visible).
     * Without ACCESS_FINE_LOCATION the service is not started, and a start
     * Android refuses (`ForegroundServiceStartNotAllowedException` from the
     * background on 12+) is caught: both become
     * [Problem.FOREGROUND_SERVICE_REFUSED] with the reason. The service holds
     * this object weakly until [stopForegroundService] or [stop].
     */
    @JvmOverloads
    fun startForegroundService(title: String = "Indoor positioning") = core.startForegroundService(title)

    /** Ends the foreground-service mode (positioning keeps running while the app is visible). */
    fun stopForegroundService() = core.stopForegroundService()

    /** Foreground (low-latency scans, no sensor batching) or background mode, when not following the app. */
    fun setForeground(fg: Boolean) = core.setForeground(fg)

    /**
     * [stop], then ends the control thread; the object cannot be started
     * again. Returns at once; the future of [closeAsync] completes when
     * everything is released. Status listeners get the final STOPPED.
     */
    override fun close() {
        closeAsync()
    }

    /** [close], with a future that completes when the engine, sources and threads are released. */
    fun closeAsync(): CompletableFuture<Void?> {
        cleanable.clean()
        return core.closeAsync()
    }

    /** [close], suspending until everything is released. */
    suspend fun awaitClose() {
        closeAsync().awaitUnwrapped()
    }
}

private suspend fun CompletableFuture<Void?>.awaitUnwrapped() {
    try {
        await()
    } catch (e: CompletionException) {
        throw unwrap(e)
    }
}

private fun unwrap(t: Throwable): Throwable = if (t is CompletionException && t.cause != null) t.cause!! else t

private fun describe(t: Throwable): String = "${t.javaClass.simpleName}: ${t.message}"

/** The log tag of the library's Android layer. */
private const val TAG = "fpbp"

/**
 * The state and threads of one [FpbpPositioning]. Nothing in here refers to
 * the facade, so the facade can become unreachable while this runs; the
 * foreground service holds it weakly ([ForegroundClient]).
 */
private class PositioningCore(
    private val app: Context,
    private val site: FpbpPositioning.Site,
    private val options: FpbpPositioning.Options,
) : ForegroundClient {
    companion object {
        private val ids = AtomicInteger()
    }

    val clock: Clock = Clock { SystemClock.elapsedRealtimeNanos() }

    val control = HandlerThread("fpbp-control-${ids.incrementAndGet()}").also { it.start() }
    private val handler = Handler(control.looper)
    val dispatcher = PoseDispatcher(clock) { t -> listenerFault("pose listener", t) }
    val tracker = StatusTracker(clock)
    val statusListeners = CopyOnWriteArrayList<Pair<Executor, StatusListener>>()

    val geo: SiteGeo? by lazy { siteGeo(site.json) }

    @Volatile var engine: FpbpEngine? = null
    private var tasks: TaskScheduler? = null
    private var ble: BleSource? = null
    private var sensors: SensorSource? = null
    private var wifi: WifiSource? = null
    private var ticker: ScheduledExecutorService? = null
    private var input: ExecutorService? = null
    @Volatile private var ticks = 0
    @Volatile private var foreground = true
    @Volatile private var serviceMode = false
    private var lifecycleRegistered = false
    private var locationReceiverRegistered = false

    /** The engine whose failure was already reported (one report per engine). */
    private val failedEngine = AtomicReference<FpbpEngine?>(null)
    private val closing = AtomicReference<CompletableFuture<Void?>?>(null)

    @Volatile var inputObserver: FpbpPositioning.InputObserver? = null

    /** The engine config: the app's, with `device` = this phone's model unless it names one. */
    private val config = configWithDevice(options.configJson, DeviceModel.canonical())

    val device: String? = deviceOf(config)

    private val faults = AtomicLong()

    val listenerFaults: Long get() = faults.get()

    val foregroundMode: Boolean get() = effectiveForeground()

    val tickCount: Int get() = ticks

    /**
     * The app's callback [what] failed with [t] (it threw, or its executor
     * refused it): counted, the first one logged and named in the status
     * ([Problem.LISTENER_FAULT]). From any thread; never throws.
     */
    fun listenerFault(what: String, t: Throwable) {
        if (faults.incrementAndGet() == 1L) {
            try {
                Log.w(TAG, "$what failed; positioning goes on (further faults are counted in listenerFaults)", t)
            } catch (_: RuntimeException) {
                // no log on this platform
            }
        }
        if (tracker.setFirst(Problem.LISTENER_FAULT, "$what: ${describe(t)}")) handler.post { publishStatus() }
    }

    /**
     * Runs [call] (an app's callback) on [executor]; a throw of either is a
     * [listenerFault], never the caller's: the caller may be the control,
     * tick, task or input thread.
     */
    private fun deliver(what: String, executor: Executor, call: () -> Unit) {
        try {
            executor.execute {
                try {
                    call()
                } catch (e: Exception) {
                    listenerFault(what, e)
                }
            }
        } catch (e: Exception) {
            listenerFault(what, e)
        }
    }

    /** Calls [callback] on [executor] when [future] completes (the Java overloads of the lifecycle calls). */
    fun notify(future: CompletableFuture<Void?>, executor: Executor, callback: FpbpPositioning.CompletionCallback) {
        future.whenComplete { _, error -> deliver("completion callback", executor) { callback.onComplete(error?.let(::unwrap)) } }
    }

    val bleScanStarts: Int get() = ble?.starts ?: 0

    fun statsJson(): String? = engine?.let { e -> runCatching { e.statsJson() }.getOrNull() }

    fun stats(): EngineStats? = engine?.let { e -> runCatching { e.stats() }.getOrNull() }

    fun currentPose(): Pose? = engine?.let { e -> runCatching { e.pose() }.getOrNull() }

    fun currentBlePosition(): Pose? = engine?.let { e -> runCatching { e.blePosition() }.getOrNull() }

    private fun onControl(block: () -> Unit) {
        if (Looper.myLooper() == control.looper) block() else handler.post(block)
    }

    /** Runs [block] on the control thread; the future completes with its result or throw. Never waits. */
    private fun onControlAsync(block: () -> Unit): CompletableFuture<Void?> {
        val f = CompletableFuture<Void?>()
        val r = Runnable {
            try {
                block()
                f.complete(null)
            } catch (t: Throwable) {
                f.completeExceptionally(t)
            }
        }
        if (Looper.myLooper() == control.looper) {
            r.run()
        } else if (!handler.post(r)) {
            f.completeExceptionally(IllegalStateException("FpbpPositioning is closed"))
        }
        return f
    }

    fun start() = onControlAsync {
        check(closing.get() == null) { "FpbpPositioning is closed" }
        if (engine != null) return@onControlAsync
        try {
            val e = site.startEngine(options.engine, config, options.initialPosition)
            engine = e
            input = Executors.newSingleThreadExecutor { r -> Thread(r, "fpbp-input").apply { isDaemon = true } }
            tasks = newTasks(e)
            tracker.started()
            if (options.followAppForeground) registerLifecycle()
            registerLocationReceiver()
            startSources()
            ticks = 0
            ticker = Executors.newSingleThreadScheduledExecutor { r -> Thread(r, "fpbp-tick").apply { isDaemon = true } }.also {
                it.scheduleWithFixedDelay(::tick, FpbpPositioning.TICK_MS, FpbpPositioning.TICK_MS, TimeUnit.MILLISECONDS)
            }
            publishStatus()
        } catch (t: RuntimeException) {
            fail(t)
            throw t
        }
    }

    private fun newTasks(e: FpbpEngine) = TaskScheduler(e, clock, null) { dispatcher.offer(currentPose()) }.also {
        it.onError = { t -> engineFailed(e, t) }
    }

    fun stop() = onControlAsync { teardown() }

    /**
     * Stops everything (on the control thread) and, when [publish], publishes
     * STOPPED. The foreground service ends with it: it leaves the foreground,
     * its notification is removed, and it stops.
     */
    private fun teardown(publish: Boolean = true) {
        if (FpbpPositioningService.attached() === this) {
            FpbpPositioningService.release(this)
            stopForegroundService()
        }
        serviceMode = false
        stopSources()
        ticker?.shutdownNow()
        ticker = null
        tasks?.close()
        tasks = null
        input?.shutdown()
        input?.awaitTermination(5, TimeUnit.SECONDS)
        input = null
        try {
            engine?.close()
        } catch (_: RuntimeException) {
            // a failed engine may refuse its stop: its handle is gone either way
        }
        engine = null
        unregisterLocationReceiver()
        unregisterLifecycle()
        tracker.stopped()
        if (publish) publishStatus()
    }

    /** On the control thread: stops everything and shows [t] as the failure. */
    private fun fail(t: Throwable) {
        teardown(publish = false)
        tracker.failed(describe(t))
        publishStatus()
    }

    /** From any thread: [e] threw an internal error; it is stopped and the status says FAILED. */
    private fun engineFailed(e: FpbpEngine, t: Throwable) {
        if (failedEngine.getAndSet(e) === e) return
        handler.post { if (engine === e) fail(t) }
    }

    fun pause() = onControlAsync {
        if (engine == null) return@onControlAsync
        stopSources()
        tasks?.close()
        tasks = null
        tracker.paused(true)
        publishStatus()
    }

    fun resume() = onControlAsync {
        val e = engine ?: return@onControlAsync
        if (tasks != null) return@onControlAsync
        tasks = newTasks(e)
        tracker.paused(false)
        startSources()
        publishStatus()
    }

    fun refreshPermissions() = onControl {
        if (engine == null || tasks == null) return@onControl
        startSources()
        publishStatus()
    }

    fun setPosition(at: InitialPosition) = onControlAsync {
        val e = engine
        try {
            if (e == null) throw IllegalStateException("FpbpPositioning is not started")
            val t = clock.nowNs()
            e.setPosition(t, at)
            tracker.set(Problem.POSITION_REFUSED, false)
            observe { it.onSetPosition(t, at) }
            dispatcher.offer(currentPose())
            publishStatus()
        } catch (x: FpbpNativeException) {
            if (e != null) engineFailed(e, x)
            throw x
        } catch (x: RuntimeException) {
            refused(x)
            throw x
        }
    }

    fun setPositionWgs84(latDeg: Double, lonDeg: Double, floor: Int, accuracyM: Double, bearingDeg: Double?): CompletableFuture<Void?> {
        val g = geo
        val why = when {
            g == null -> "the site has no georef: WGS-84 positions cannot be placed on its map"
            !(accuracyM >= 0.0 && accuracyM <= FpbpPositioning.MAX_SET_POSITION_ACCURACY_M) ->
                "accuracy $accuracyM m is not in [0, ${FpbpPositioning.MAX_SET_POSITION_ACCURACY_M}] m"
            !(latDeg in -90.0..90.0 && lonDeg in -180.0..180.0) -> "lat/lon ($latDeg, $lonDeg) is not a WGS-84 position"
            bearingDeg != null && !bearingDeg.isFinite() -> "bearing $bearingDeg is not finite"
            else -> null
        }
        if (why != null || g == null) {
            val x = IllegalArgumentException(why)
            onControl { refused(x) }
            return CompletableFuture<Void?>().apply { completeExceptionally(x) }
        }
        val p = g.toMap(latDeg, lonDeg)
        return setPosition(InitialPosition(p.xM, p.yM, floor, bearingDeg?.let { g.headingRad(it) }))
    }

    private fun refused(x: RuntimeException) {
        tracker.set(Problem.POSITION_REFUSED, describe(x))
        publishStatus()
    }

    fun addStatusListener(executor: Executor, listener: StatusListener): AutoCloseable {
        val entry = executor to listener
        statusListeners.add(entry)
        val now = tracker.status
        deliver("status listener", executor) { listener.onStatus(now) }
        return AutoCloseable { statusListeners.remove(entry) }
    }

    fun feedSensor(type: Int, tNs: Long, values: DoubleArray) =
        feed({ it.onSensor(type, tNs, values) }) { it.onSensor(type, tNs, values) }

    fun feedBle(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) =
        feed({ it.onBleScan(tNs, beaconId, rssiDbm, txPowerDbm) }) { it.onBle(tNs, beaconId, rssiDbm, txPowerDbm) }

    fun feedWifi(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) =
        feed({ it.onWifiScan(tNs, bssids, rssiDbm, freqMhz, seenTNs) }) { it.onWifi(tNs, bssids, rssiDbm, freqMhz, seenTNs) }

    /**
     * Hands one input to the engine, then to the observer. Runs on the
     * sensor, input or app thread and never throws there (an exception on a
     * sensor or executor thread ends the process): an engine that fails
     * (FpbpNativeException after a panic) is stopped and reported as FAILED;
     * one stopped while the sample was in flight is ignored.
     */
    private inline fun feed(toEngine: (FpbpEngine) -> Unit, toObserver: (FpbpPositioning.InputObserver) -> Unit) {
        val e = engine ?: return
        try {
            toEngine(e)
        } catch (t: RuntimeException) {
            if (!e.isClosed && engine === e) engineFailed(e, t)
            return
        }
        observe(toObserver)
    }

    private inline fun observe(call: (FpbpPositioning.InputObserver) -> Unit) {
        val o = inputObserver ?: return
        try {
            call(o)
        } catch (e: Exception) {
            // the app's observer failed: it is removed, positioning goes on
            if (inputObserver === o) inputObserver = null
            listenerFault("input observer", e)
        }
    }

    /** Hands [r] to the input thread; dropped once it is shut down. */
    private fun toInput(r: Runnable) {
        try {
            input?.execute(r)
        } catch (_: RejectedExecutionException) {
            // stopping
        }
    }

    fun startForegroundService(title: String) {
        if (app.checkSelfPermission(RadioPermissions.ACCESS_FINE_LOCATION) != PackageManager.PERMISSION_GRANTED) {
            foregroundRefused(FpbpPositioningService.NO_PERMISSION)
            return
        }
        FpbpPositioningService.attach(this)
        val intent = Intent(app, FpbpPositioningService::class.java).putExtra(FpbpPositioningService.EXTRA_TITLE, title)
        try {
            if (Build.VERSION.SDK_INT >= 26) app.startForegroundService(intent) else app.startService(intent)
            onControl {
                tracker.set(Problem.FOREGROUND_SERVICE_REFUSED, false)
                publishStatus()
            }
        } catch (e: IllegalStateException) {
            // ForegroundServiceStartNotAllowedException (12+, from the background) is one
            FpbpPositioningService.detach(this)
            foregroundRefused(describe(e))
        } catch (e: SecurityException) {
            FpbpPositioningService.detach(this)
            foregroundRefused(describe(e))
        }
    }

    fun stopForegroundService() {
        app.stopService(Intent(app, FpbpPositioningService::class.java))
    }

    override fun setServiceMode(on: Boolean) = onControl {
        serviceMode = on
        applyForeground()
    }

    override fun foregroundRefused(message: String) = onControl {
        tracker.set(Problem.FOREGROUND_SERVICE_REFUSED, message)
        publishStatus()
    }

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
        val missing = FpbpPositioning.missingPermissions(app, options.radios)
        tracker.permissionsMissing(missing)
        val fg = effectiveForeground()
        if (options.ownSensors && sensors == null) {
            val s = SensorSource(app) { type, t, v -> feedSensor(type, t, v) }
            sensors = s
            tracker.sensorsMissing(s.start(fg))
        }
        if (missing.isNotEmpty()) return
        checkLocation()
        if (options.ownBle && Radio.BLE in options.radios && ble == null) {
            val filters = BeaconFilter.forBeacons(FpbpPositioning.beaconIds(site.json))
            ble = BleSource(app, handler, clock, filters, tracker, ::publishStatus) { t, id, rssi, tx ->
                toInput { feedBle(t, id, rssi, tx) }
            }.also { it.start(fg) }
        }
        if (options.ownWifi && Radio.WIFI in options.radios && wifi == null) {
            wifi = WifiSource(app, handler, clock, tracker, ::publishStatus) { t, b, r, f, s ->
                toInput { feedWifi(t, b, r, f, s) }
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

    /** [Problem.LOCATION_OFF] from the location switch now (radios with their permissions only). */
    private fun checkLocation() {
        val relevant = engine != null && FpbpPositioning.missingPermissions(app, options.radios).isEmpty() && options.radios.isNotEmpty()
        tracker.set(Problem.LOCATION_OFF, relevant && !locationEnabled())
    }

    private fun locationEnabled(): Boolean {
        val lm = app.getSystemService(Context.LOCATION_SERVICE) as LocationManager? ?: return true
        if (Build.VERSION.SDK_INT >= 28) return lm.isLocationEnabled
        return try {
            lm.isProviderEnabled(LocationManager.GPS_PROVIDER) || lm.isProviderEnabled(LocationManager.NETWORK_PROVIDER)
        } catch (_: RuntimeException) {
            true
        }
    }

    /** Location switched on or off while running (MODE_CHANGED_ACTION, PROVIDERS_CHANGED_ACTION). */
    private val locationReceiver = object : BroadcastReceiver() {
        override fun onReceive(context: Context, intent: Intent) {
            handler.post {
                checkLocation()
                publishStatus()
            }
        }
    }

    private fun registerLocationReceiver() {
        if (locationReceiverRegistered) return
        val filter = IntentFilter(LocationManager.MODE_CHANGED_ACTION).apply { addAction(LocationManager.PROVIDERS_CHANGED_ACTION) }
        registerReceiverCompat(app, locationReceiver, filter)
        locationReceiverRegistered = true
    }

    private fun unregisterLocationReceiver() {
        if (!locationReceiverRegistered) return
        app.unregisterReceiver(locationReceiver)
        locationReceiverRegistered = false
    }

    /**
     * The heartbeat (tick thread). It must never throw: a scheduled task that
     * throws is never run again, and with it the heartbeat deliveries and the
     * status checks (beacon heard, LOST) would stop silently.
     */
    private fun tick() {
        try {
            val pose = currentPose()
            dispatcher.offer(pose)
            if (++ticks % FpbpPositioning.STATUS_TICKS != 0) return
            val stats = stats() ?: return
            tracker.tick(stats.bleObservations - stats.unknownBeacons, pose)
            publishStatus()
        } catch (e: RuntimeException) {
            Log.e(TAG, "heartbeat failed; it goes on", e)
        }
    }

    /** The status to every status listener when it changed; any thread, never throws for a listener. */
    private fun publishStatus() {
        val s = tracker.update() ?: return
        for ((executor, listener) in statusListeners) deliver("status listener", executor) { listener.onStatus(s) }
    }

    private val mainHandler = Handler(Looper.getMainLooper())

    /**
     * The app's activities known to be started (between onStart and onStop),
     * weakly. Positioning usually starts under a visible activity whose
     * onStart came before the callbacks were registered: such an activity
     * joins the set on its next resume or pause (a started activity is
     * paused before it stops), so navigating from it to another activity (B
     * starts, then it stops) keeps the foreground mode.
     */
    private val startedActivities: MutableSet<Activity> = Collections.newSetFromMap(WeakHashMap())

    private val toBackground = Runnable {
        if (synchronized(startedActivities) { startedActivities.isEmpty() }) setForeground(false)
    }

    private fun activityStarted(activity: Activity) {
        val first = synchronized(startedActivities) { startedActivities.add(activity) && startedActivities.size == 1 }
        if (first) {
            mainHandler.removeCallbacks(toBackground)
            setForeground(true)
        }
    }

    private fun activityStopped(activity: Activity) {
        val none = synchronized(startedActivities) {
            startedActivities.remove(activity)
            startedActivities.isEmpty()
        }
        // A rotation stops one activity and starts the next: wait before
        // switching modes, so it costs no scan restart.
        if (none) {
            mainHandler.removeCallbacks(toBackground)
            mainHandler.postDelayed(toBackground, FpbpPositioning.BACKGROUND_DELAY_MS)
        }
    }

    private val lifecycle = object : Application.ActivityLifecycleCallbacks {
        override fun onActivityStarted(activity: Activity) = activityStarted(activity)

        // resumed or paused: started, maybe before positioning was
        override fun onActivityResumed(activity: Activity) = activityStarted(activity)

        override fun onActivityPaused(activity: Activity) = activityStarted(activity)

        override fun onActivityStopped(activity: Activity) = activityStopped(activity)

        override fun onActivityCreated(activity: Activity, savedInstanceState: Bundle?) = Unit
        override fun onActivitySaveInstanceState(activity: Activity, outState: Bundle) = Unit
        override fun onActivityDestroyed(activity: Activity) {
            synchronized(startedActivities) { startedActivities.remove(activity) }
        }
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
        synchronized(startedActivities) { startedActivities.clear() }
    }

    /** Stops, ends the foreground service if it holds this, ends the control thread. Idempotent, never waits. */
    fun closeAsync(): CompletableFuture<Void?> {
        val mine = CompletableFuture<Void?>()
        if (!closing.compareAndSet(null, mine)) return closing.get()!!
        if (FpbpPositioningService.attached() === this) stopForegroundService()
        val done = onControlAsync {
            try {
                teardown()
            } finally {
                dispatcher.clear()
                statusListeners.clear()
                control.quitSafely()
            }
        }
        done.whenComplete { _, t -> if (t != null) mine.completeExceptionally(t) else mine.complete(null) }
        return mine
    }

    /** The reaper's action: [closeAsync] without a result. */
    fun closeAsyncIgnoringResult() {
        closeAsync()
    }
}

/**
 * [configJson] with `device` set to [model] (the phone model: a radio map
 * whose survey recorded walks with it corrects the readings by that
 * model's offsets), unless it names one already; unchanged when [model]
 * is blank or the config is not a JSON object (the engine then reports
 * the config's error).
 */
internal fun configWithDevice(configJson: String, model: String?): String {
    val name = model?.filterNot { it.isISOControl() }?.trim()?.take(64)
    if (name.isNullOrEmpty()) return configJson
    val o = try {
        JSONObject(configJson.ifBlank { "{}" })
    } catch (e: org.json.JSONException) {
        return configJson
    }
    if (o.has("device")) return configJson
    return o.put("device", name).toString()
}

/** The `device` of [configJson], null when it names none or is not a JSON object. */
internal fun deviceOf(configJson: String): String? = try {
    JSONObject(configJson.ifBlank { "{}" }).optString("device").ifEmpty { null }
} catch (_: org.json.JSONException) {
    null
}

/** The site's georef from site.json (`georef`, `map_from_enu_rad`), null without one. */
internal fun siteGeo(siteJson: String): SiteGeo? {
    val o = JSONObject(siteJson)
    val g = o.optJSONObject("georef") ?: return null
    return SiteGeo(
        g.getDouble("lat_deg"),
        g.getDouble("lon_deg"),
        g.getDouble("x_m"),
        g.getDouble("y_m"),
        o.optDouble("map_from_enu_rad", 0.0),
    )
}
