package io.fpbp.sample

import io.fpbp.NativeLogWriter
import java.io.File
import java.util.concurrent.Executors
import java.util.concurrent.TimeUnit

/**
 * Records everything the engine is fed as a native v1 log (docs/formats.md)
 * that `fpbp replay` reads. Writes happen on one background thread, so the
 * sensor and BLE threads never wait for storage.
 */
class LogRecorder(val file: File, meta: Map<String, String>) : AutoCloseable {
    private val io = Executors.newSingleThreadExecutor { r -> Thread(r, "fpbp-recorder") }
    private val writer = NativeLogWriter(file.bufferedWriter(), meta)

    fun sensor(type: Int, tNs: Long, values: DoubleArray) = io.execute { writer.sensor(tNs, type, values) }

    fun ble(tNs: Long, beaconId: String, rssiDbm: Double, txPowerDbm: Double?) =
        io.execute { writer.ble(tNs, beaconId, rssiDbm, txPowerDbm) }

    /** A ground-truth mark (the user tapped where they stand). */
    fun truth(tNs: Long, xM: Double, yM: Double, floor: Int) = io.execute { writer.truth(tNs, xM, yM, floor) }

    override fun close() {
        io.execute { writer.close() }
        io.shutdown()
        io.awaitTermination(5, TimeUnit.SECONDS)
    }
}
