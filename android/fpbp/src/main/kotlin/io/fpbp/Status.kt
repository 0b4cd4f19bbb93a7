package io.fpbp

/** What the positioning is doing. */
enum class PositioningState {
    /** Not started, or stopped. */
    STOPPED,

    /** Started; no pose yet (walk a few steps near the beacons, or set a position). */
    WAITING_FOR_FIX,

    /** A pose exists and radio input arrived lately. */
    POSITIONING,

    /** A pose exists but no known beacon was heard for [StatusTracker.lostAfterMs]: dead reckoning only. */
    LOST,

    /** Paused by the app: inputs and tasks stopped, the engine kept. */
    PAUSED,

    /**
     * The engine failed and was stopped: a start that threw (bad site, config
     * or engine name), an internal error of the native library (a panic
     * poisons that engine), or a task that threw. [Status.failure] says what;
     * [io.fpbp.android.FpbpPositioning.start] tries again.
     */
    FAILED,
}

/** Something that keeps the positioning from working as it should. */
enum class Problem {
    /** A runtime permission the chosen radios need is not granted ([Status.missingPermissions]). */
    PERMISSION_MISSING,

    /** Bluetooth is switched off. */
    BLUETOOTH_OFF,

    /** The phone has no Bluetooth LE. */
    BLUETOOTH_UNAVAILABLE,

    /** Location services are off: Android withholds WiFi (and before 12, BLE) scan results. */
    LOCATION_OFF,

    /** WiFi is off and scanning while off is not allowed. */
    WIFI_OFF,

    /** The BLE scanner reported an error ([Status.scanErrorCode]); the library retries. */
    SCAN_FAILED,

    /** A scan start waits for Android's start limit (5 BLE starts per 30 s, 4 WiFi scans per 2 min). */
    SCAN_THROTTLED,

    /** Started, but no beacon of the site was heard for [StatusTracker.noBeaconAfterMs]. */
    NO_BEACON_HEARD,

    /** A sensor the engine uses is missing on this phone ([Status.missingSensors]). */
    SENSOR_MISSING,

    /**
     * Android refused the foreground service ([Status.messages] says why:
     * location permission missing, or `ForegroundServiceStartNotAllowedException`
     * when asked from the background on 12+). Positioning goes on while the
     * app is visible.
     */
    FOREGROUND_SERVICE_REFUSED,

    /**
     * The engine refused the last `setPosition` ([Status.messages] says why:
     * a point off the site's floors, an engine that takes no position, a
     * position outside the site's georef). Cleared by the next accepted one.
     */
    POSITION_REFUSED,

    /**
     * A callback of the app failed: a listener (pose, status, input
     * observer, completion callback) threw, or its executor refused the
     * delivery. Positioning goes on; [Status.messages] names the first such
     * fault, `FpbpPositioning.listenerFaults` counts them all. Cleared by
     * `stop()`.
     */
    LISTENER_FAULT,
}

/**
 * The positioning's status: a state, the problems now, and their details.
 *
 * @property missingPermissions manifest names (`android.permission.*`) not granted.
 * @property missingSensors Android `Sensor.TYPE_*` codes the phone lacks.
 * @property scanErrorCode the last `ScanCallback.onScanFailed` code while [Problem.SCAN_FAILED].
 * @property failure what made the state [PositioningState.FAILED] (exception class and message), else null.
 * @property messages details of the problems that carry one
 *   ([Problem.FOREGROUND_SERVICE_REFUSED], [Problem.POSITION_REFUSED],
 *   [Problem.LISTENER_FAULT]).
 */
data class Status(
    val state: PositioningState,
    val problems: Set<Problem> = emptySet(),
    val missingPermissions: List<String> = emptyList(),
    val missingSensors: List<Int> = emptyList(),
    val scanErrorCode: Int? = null,
    val failure: String? = null,
    val messages: Map<Problem, String> = emptyMap(),
) {
    /** One line for a status bar. */
    fun describe(): String {
        val what = when (state) {
            PositioningState.STOPPED -> "stopped"
            PositioningState.WAITING_FOR_FIX -> "waiting for a first fix"
            PositioningState.POSITIONING -> "positioning"
            PositioningState.LOST -> "lost (no beacon heard lately: dead reckoning)"
            PositioningState.PAUSED -> "paused"
            PositioningState.FAILED -> "failed: $failure"
        }
        if (problems.isEmpty()) return what
        val details = problems.sorted().joinToString(", ") { p ->
            when (p) {
                Problem.PERMISSION_MISSING -> "missing permission " + missingPermissions.joinToString(" ") { it.substringAfterLast('.') }
                Problem.SENSOR_MISSING -> "missing sensor types $missingSensors"
                Problem.SCAN_FAILED -> "BLE scan failed (error $scanErrorCode)"
                Problem.FOREGROUND_SERVICE_REFUSED, Problem.POSITION_REFUSED, Problem.LISTENER_FAULT ->
                    p.name.lowercase().replace('_', ' ') + (messages[p]?.let { " ($it)" } ?: "")
                else -> p.name.lowercase().replace('_', ' ')
            }
        }
        return "$what; $details"
    }
}

/** Receives status changes on the executor it was registered with. */
fun interface StatusListener {
    fun onStatus(status: Status)
}

/**
 * Keeps the facts the status is made of and computes it; [update] returns
 * the new status when it changed, else null. Plain JVM; the Android sources
 * set the facts, a 1 s tick calls [tick] with the engine's counters.
 *
 * @property noBeaconAfterMs [Problem.NO_BEACON_HEARD] when no known beacon was heard for this long.
 * @property lostAfterMs [PositioningState.LOST] when a pose exists but no known beacon was heard for this long.
 */
class StatusTracker(
    private val clock: Clock,
    val noBeaconAfterMs: Long = DEFAULT_NO_BEACON_AFTER_MS,
    val lostAfterMs: Long = DEFAULT_LOST_AFTER_MS,
) {
    companion object {
        /** Default [noBeaconAfterMs]: ten BLE task periods of 1 s. */
        const val DEFAULT_NO_BEACON_AFTER_MS: Long = 10_000

        /** Default [lostAfterMs]: six times `fusion.ble_max_age_s` (5 s). */
        const val DEFAULT_LOST_AFTER_MS: Long = 30_000
    }

    private var running = false
    private var paused = false
    private var startedNs = 0L
    private var havePose = false
    private var lastBeaconNs: Long? = null
    private var knownBeacons = 0L
    private val problems = sortedSetOf<Problem>()
    private var missingPermissions = emptyList<String>()
    private var missingSensors = emptyList<Int>()
    private var scanError: Int? = null
    private var failure: String? = null
    private val messages = sortedMapOf<Problem, String>()
    private var last: Status? = null

    /** The current status. */
    @get:Synchronized
    val status: Status get() = compute()

    @Synchronized fun started() {
        failure = null
        running = true
        paused = false
        startedNs = clock.nowNs()
        lastBeaconNs = null
        havePose = false
    }

    @Synchronized fun stopped() {
        running = false
        paused = false
        problems.clear()
        missingPermissions = emptyList()
        missingSensors = emptyList()
        scanError = null
        messages.clear()
        failure = null
    }

    /**
     * The engine failed and was stopped: [PositioningState.FAILED] with
     * [message] until the next [started] or [stopped]. Call after [stopped].
     */
    @Synchronized fun failed(message: String) {
        failure = message
    }

    /** Sets [problem] with a [message] (shown by [Status.describe]), or clears it when [message] is null. */
    @Synchronized fun set(problem: Problem, message: String?) {
        if (message != null) messages[problem] = message else messages.remove(problem)
        set(problem, message != null)
    }

    /** Sets [problem] with [message] unless it is set already; true when it was not. */
    @Synchronized fun setFirst(problem: Problem, message: String): Boolean {
        if (problem in problems) return false
        set(problem, message)
        return true
    }

    @Synchronized fun paused(p: Boolean) {
        paused = p
        if (!p) startedNs = clock.nowNs()
    }

    /** Sets or clears [problem]. */
    @Synchronized fun set(problem: Problem, on: Boolean) {
        if (on) problems.add(problem) else problems.remove(problem)
        if (!on) messages.remove(problem)
        if (problem == Problem.SCAN_FAILED && !on) scanError = null
    }

    @Synchronized fun permissionsMissing(names: List<String>) {
        missingPermissions = names
        set(Problem.PERMISSION_MISSING, names.isNotEmpty())
    }

    @Synchronized fun sensorsMissing(types: List<Int>) {
        missingSensors = types
        set(Problem.SENSOR_MISSING, types.isNotEmpty())
    }

    @Synchronized fun scanFailed(code: Int) {
        scanError = code
        problems.add(Problem.SCAN_FAILED)
    }

    /**
     * One tick: [knownBeaconObservations] is the engine's count of BLE
     * observations of the site's beacons (`ble_observations - unknown_beacons`
     * of `stats`), [pose] the latest pose.
     */
    @Synchronized fun tick(knownBeaconObservations: Long, pose: Pose?) {
        val now = clock.nowNs()
        if (knownBeaconObservations > knownBeacons) lastBeaconNs = now
        knownBeacons = knownBeaconObservations
        if (pose != null) havePose = true
        val quietSince = lastBeaconNs ?: startedNs
        val quiet = running && !paused && now - quietSince >= noBeaconAfterMs * 1_000_000
        if (quiet) problems.add(Problem.NO_BEACON_HEARD) else problems.remove(Problem.NO_BEACON_HEARD)
    }

    /** The status if it changed since the last call, else null. */
    @Synchronized fun update(): Status? {
        val s = compute()
        if (s == last) return null
        last = s
        return s
    }

    private fun compute(): Status {
        val state = when {
            failure != null -> PositioningState.FAILED
            !running -> PositioningState.STOPPED
            paused -> PositioningState.PAUSED
            !havePose -> PositioningState.WAITING_FOR_FIX
            clock.nowNs() - (lastBeaconNs ?: startedNs) >= lostAfterMs * 1_000_000 -> PositioningState.LOST
            else -> PositioningState.POSITIONING
        }
        return Status(
            state, problems.toSet(), missingPermissions, missingSensors, scanError.takeIf { Problem.SCAN_FAILED in problems },
            failure, messages.filterKeys { it in problems },
        )
    }
}
