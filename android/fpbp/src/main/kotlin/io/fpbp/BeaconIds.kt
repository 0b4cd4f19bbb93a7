package io.fpbp

/**
 * A beacon identity parsed from an advertisement.
 *
 * @property id canonical id as in site.json and rust/core's `ble::beacon_id`:
 *   `ibeacon:XXXXXXXX-XXXX-XXXX-XXXX-XXXXXXXXXXXX:major:minor` (uppercase UUID),
 *   `eddystone:NAMESPACE:INSTANCE` (uppercase hex, 20 + 12 digits) or
 *   `mac:AA:BB:CC:DD:EE:FF` (uppercase).
 * @property txPowerDbm advertised power at 1 m, dBm, when the frame carries one
 *   (Eddystone advertises power at 0 m: 41 dB is subtracted, as its spec says).
 */
data class BeaconFrame(val id: String, val txPowerDbm: Int?)

/** Beacon ids from raw BLE advertisement bytes (`ScanRecord.getBytes()`), no Android classes. */
object BeaconIds {
    private const val AD_MANUFACTURER = 0xFF
    private const val AD_SERVICE_DATA_16 = 0x16
    private const val APPLE = 0x004C
    private const val EDDYSTONE_UUID = 0xFEAA
    private const val EDDYSTONE_UID = 0x00

    /** Eddystone's tx power is at 0 m; at 1 m it is this much lower (Eddystone spec). */
    const val EDDYSTONE_0M_TO_1M_DB = 41

    /** The iBeacon or Eddystone-UID frame in [scanRecord], else `mac:` of [macAddress]. */
    @JvmStatic
    fun fromAdvertisement(scanRecord: ByteArray?, macAddress: String): BeaconFrame =
        scanRecord?.let { parse(it) } ?: BeaconFrame(macId(macAddress), null)

    /** `mac:AA:BB:CC:DD:EE:FF` from any MAC spelling (`-`, `:` or none). */
    @JvmStatic
    fun macId(mac: String): String {
        val hex = mac.filter { it != ':' && it != '-' }.uppercase()
        return "mac:" + hex.chunked(2).joinToString(":")
    }

    /** The first iBeacon or Eddystone-UID frame among the AD structures, or null. */
    @JvmStatic
    fun parse(record: ByteArray): BeaconFrame? {
        var i = 0
        while (i < record.size) {
            val len = record[i].toInt() and 0xFF
            if (len == 0 || i + 1 + len > record.size) return null
            val type = record[i + 1].toInt() and 0xFF
            val start = i + 2
            val end = i + 1 + len
            when (type) {
                AD_MANUFACTURER -> iBeacon(record, start, end)?.let { return it }
                AD_SERVICE_DATA_16 -> eddystone(record, start, end)?.let { return it }
            }
            i = end
        }
        return null
    }

    private fun u8(b: ByteArray, i: Int) = b[i].toInt() and 0xFF

    private fun hex(b: ByteArray, from: Int, to: Int): String =
        (from until to).joinToString("") { "%02X".format(u8(b, it)) }

    private fun iBeacon(b: ByteArray, start: Int, end: Int): BeaconFrame? {
        // company id (LE), 0x02, 0x15, uuid[16], major (BE), minor (BE), tx power (signed)
        if (end - start < 25) return null
        val company = u8(b, start) or (u8(b, start + 1) shl 8)
        if (company != APPLE || u8(b, start + 2) != 0x02 || u8(b, start + 3) != 0x15) return null
        val u = start + 4
        val uuid = listOf(hex(b, u, u + 4), hex(b, u + 4, u + 6), hex(b, u + 6, u + 8), hex(b, u + 8, u + 10), hex(b, u + 10, u + 16))
            .joinToString("-")
        val major = (u8(b, u + 16) shl 8) or u8(b, u + 17)
        val minor = (u8(b, u + 18) shl 8) or u8(b, u + 19)
        val tx = b[u + 20].toInt()
        return BeaconFrame("ibeacon:$uuid:$major:$minor", tx)
    }

    private fun eddystone(b: ByteArray, start: Int, end: Int): BeaconFrame? {
        // service uuid (LE), frame type, tx power at 0 m (signed), namespace[10], instance[6]
        if (end - start < 20) return null
        val uuid = u8(b, start) or (u8(b, start + 1) shl 8)
        if (uuid != EDDYSTONE_UUID || u8(b, start + 2) != EDDYSTONE_UID) return null
        val tx0 = b[start + 3].toInt()
        val ns = hex(b, start + 4, start + 14)
        val inst = hex(b, start + 14, start + 20)
        return BeaconFrame("eddystone:$ns:$inst", tx0 - EDDYSTONE_0M_TO_1M_DB)
    }
}
