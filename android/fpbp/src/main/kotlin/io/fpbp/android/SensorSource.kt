package io.fpbp.android

import android.content.Context
import android.hardware.Sensor
import android.hardware.SensorEvent
import android.hardware.SensorEventListener
import android.hardware.SensorManager
import android.os.Handler
import android.os.HandlerThread

/**
 * The library's sensor input: the sensors fpbp uses, registered on a
 * background [HandlerThread] at [SAMPLING_PERIOD_US] (50 Hz, as
 * `SENSOR_DELAY_GAME`), with hardware batching of [maxReportLatencyUs]
 * (0 in the foreground; the background mode batches, so the phone's
 * application processor sleeps between batches). Each sample goes to [sink]
 * with `SensorEvent.timestamp` and values widened to double. [start] returns
 * the types the phone lacks (the status reports them).
 */
internal class SensorSource(
    context: Context,
    private val sink: (type: Int, tNs: Long, values: DoubleArray) -> Unit,
) : SensorEventListener {
    companion object {
        /** 50 Hz: the PDR's step detector needs >= 25 Hz; SENSOR_DELAY_GAME is 20 ms. */
        const val SAMPLING_PERIOD_US: Int = 20_000

        /** Background batching: samples arrive in bursts of up to 1 s (timestamps are kept). */
        const val BACKGROUND_LATENCY_US: Int = 1_000_000

        /** The sensor types fpbp uses; the first is required, the others improve heading and floors. */
        @JvmField
        val TYPES = intArrayOf(
            Sensor.TYPE_ACCELEROMETER,
            Sensor.TYPE_GYROSCOPE,
            Sensor.TYPE_MAGNETIC_FIELD,
            Sensor.TYPE_ROTATION_VECTOR,
            Sensor.TYPE_GAME_ROTATION_VECTOR,
            Sensor.TYPE_PRESSURE,
        )
    }

    private val manager = context.applicationContext.getSystemService(Context.SENSOR_SERVICE) as SensorManager?
    private var thread: HandlerThread? = null
    private var registered = false

    /** Whether listeners are registered now. */
    val isRegistered: Boolean get() = registered

    /** The listener registered with the SensorManager (tests check it is gone after stop). */
    val listener: SensorEventListener get() = this

    /** Registers every available sensor; returns the types the phone lacks. */
    fun start(foreground: Boolean): List<Int> {
        stop()
        val m = manager ?: return TYPES.toList()
        val t = HandlerThread("fpbp-sensors").also { it.start() }
        thread = t
        val handler = Handler(t.looper)
        val latency = if (foreground) 0 else BACKGROUND_LATENCY_US
        val missing = ArrayList<Int>()
        for (type in TYPES) {
            val s = m.getDefaultSensor(type)
            if (s == null) {
                missing.add(type)
            } else {
                m.registerListener(this, s, SAMPLING_PERIOD_US, latency, handler)
                registered = true
            }
        }
        return missing
    }

    /** Unregisters every sensor and ends the thread. */
    fun stop() {
        if (registered) manager?.unregisterListener(this)
        registered = false
        thread?.quitSafely()
        thread = null
    }

    override fun onSensorChanged(event: SensorEvent) {
        val v = event.values
        sink(event.sensor.type, event.timestamp, DoubleArray(v.size) { v[it].toDouble() })
    }

    override fun onAccuracyChanged(sensor: Sensor, accuracy: Int) = Unit
}
