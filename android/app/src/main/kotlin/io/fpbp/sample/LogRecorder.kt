package io.fpbp.sample

import io.fpbp.InitialPosition
import io.fpbp.NativeLogWriter
import io.fpbp.android.FpbpPositioning
import java.io.File
import java.util.concurrent.Executors
import java.util.concurrent.TimeUnit

/**
 * Records everything the engine is fed as a native v2 log (docs/logs.md)
 * that `fpbp replay` reads, through [FpbpPositioning.inputObserver]. Writes
 * happen on one background thread, so the sensor and BLE threads never wait
 * for storage. A set position is recorded as a truth mark. (A survey for
 * the radio map is recorded without an engine: [SurveyActivity].)
 */
class LogRecorder(val file: File, meta: Map<String, String>) : FpbpPositioning.InputObserver, AutoCloseable {
    private val io = Executors.newSingleThreadExecutor { r -> Thread(r, "fpbp-recorder") }
    private val writer = NativeLogWriter(file.bufferedWriter(), meta)

    override fun onSensor(type: Int, tNs: Long, values: DoubleArray) = io.execute { writer.sensor(tNs, type, values) }

    override fun onBle(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) =
        io.execute { writer.ble(tNs, beaconId, rssiDbm, txPowerDbm) }

    override fun onWifi(tNs: Long, bssids: Array<String?>, rssiDbm: DoubleArray, freqMhz: IntArray, seenTNs: LongArray) {
        io.execute { writer.wifi(tNs, bssids, rssiDbm, freqMhz, seenTNs) }
    }

    override fun onSetPosition(tNs: Long, at: InitialPosition) = io.execute { writer.truth(tNs, at.xM, at.yM, at.floor) }

    override fun close() {
        io.execute { writer.close() }
        io.shutdown()
        io.awaitTermination(5, TimeUnit.SECONDS)
    }
}
