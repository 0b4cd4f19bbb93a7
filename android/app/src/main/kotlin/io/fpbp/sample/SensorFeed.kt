package io.fpbp.sample

import android.hardware.Sensor
import android.hardware.SensorEvent
import android.hardware.SensorEventListener
import android.hardware.SensorManager
import android.os.Handler
import android.os.HandlerThread

/**
 * Listens to the sensors fpbp uses at `SENSOR_DELAY_GAME` on a background
 * thread and hands each sample (Android type, `SensorEvent.timestamp`, values
 * widened to double) to [sink].
 */
class SensorFeed(private val manager: SensorManager, private val sink: (type: Int, tNs: Long, values: DoubleArray) -> Unit) :
    SensorEventListener {
    private val thread = HandlerThread("fpbp-sensors")

    /** The sensor types fpbp uses. */
    val types = intArrayOf(
        Sensor.TYPE_ACCELEROMETER,
        Sensor.TYPE_GYROSCOPE,
        Sensor.TYPE_MAGNETIC_FIELD,
        Sensor.TYPE_ROTATION_VECTOR,
        Sensor.TYPE_GAME_ROTATION_VECTOR,
        Sensor.TYPE_PRESSURE,
    )

    /** Registers every available sensor; returns the types the phone lacks. */
    fun start(): List<Int> {
        thread.start()
        val handler = Handler(thread.looper)
        val missing = ArrayList<Int>()
        for (type in types) {
            val s = manager.getDefaultSensor(type)
            if (s == null) missing.add(type) else manager.registerListener(this, s, SensorManager.SENSOR_DELAY_GAME, handler)
        }
        return missing
    }

    fun stop() {
        manager.unregisterListener(this)
        thread.quitSafely()
    }

    override fun onSensorChanged(event: SensorEvent) {
        val v = event.values
        sink(event.sensor.type, event.timestamp, DoubleArray(v.size) { v[it].toDouble() })
    }

    override fun onAccuracyChanged(sensor: Sensor, accuracy: Int) = Unit
}
