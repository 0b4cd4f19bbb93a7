package io.fpbp

/**
 * A hardware scan filter for one of the site's beacons, in plain data (the
 * Android layer turns it into a `ScanFilter`): Android delivers nothing
 * with the screen off to an unfiltered scan, so the library filters on the
 * site's beacons.
 */
sealed class BeaconFilter {
    /** Manufacturer-specific data: iBeacon (Apple 0x004C, 0x02 0x15, UUID, major, minor). */
    data class Manufacturer(val companyId: Int, val data: ByteArray, val mask: ByteArray) : BeaconFilter() {
        override fun equals(other: Any?) =
            other is Manufacturer && other.companyId == companyId && other.data.contentEquals(data) && other.mask.contentEquals(mask)
        override fun hashCode() = 31 * (31 * companyId + data.contentHashCode()) + mask.contentHashCode()
    }

    /** 16-bit service data: Eddystone-UID (0xFEAA, frame 0x00, tx, namespace, instance). */
    data class ServiceData(val uuid16: Int, val data: ByteArray, val mask: ByteArray) : BeaconFilter() {
        override fun equals(other: Any?) =
            other is ServiceData && other.uuid16 == uuid16 && other.data.contentEquals(data) && other.mask.contentEquals(mask)
        override fun hashCode() = 31 * (31 * uuid16 + data.contentHashCode()) + mask.contentHashCode()
    }

    /** A device address (`mac:` ids), upper case with colons. */
    data class Address(val mac: String) : BeaconFilter()

    companion object {
        /** Android caps hardware filters per app (often 16-32 slots); past this, one filter per beacon family. */
        const val MAX_FILTERS = 24

        private fun hexBytes(hex: String): ByteArray? {
            if (hex.length % 2 != 0 || hex.any { it.digitToIntOrNull(16) == null }) return null
            return ByteArray(hex.length / 2) { hex.substring(2 * it, 2 * it + 2).toInt(16).toByte() }
        }

        /**
         * Filters for the canonical beacon [ids] of a site (`ibeacon:UUID:major:minor`,
         * `eddystone:NS:INSTANCE`, `mac:AA:..`). More than [MAX_FILTERS]: one
         * filter per iBeacon UUID and per Eddystone namespace instead, plus
         * the addresses up to the cap. Unparsable ids are skipped.
         */
        @JvmStatic
        fun forBeacons(ids: Collection<String>): List<BeaconFilter> {
            val exact = ids.mapNotNull { exact(it) }.distinct()
            if (exact.size <= MAX_FILTERS) return exact
            val families = ids.mapNotNull { family(it) }.distinct()
            return families.take(MAX_FILTERS)
        }

        private fun exact(id: String): BeaconFilter? {
            val p = id.split(':')
            return when (p[0]) {
                "ibeacon" -> {
                    if (p.size != 4) return null
                    val uuid = hexBytes(p[1].replace("-", "")) ?: return null
                    val major = p[2].toIntOrNull()?.takeIf { it in 0..0xFFFF } ?: return null
                    val minor = p[3].toIntOrNull()?.takeIf { it in 0..0xFFFF } ?: return null
                    if (uuid.size != 16) return null
                    val data = byteArrayOf(0x02, 0x15) + uuid +
                        byteArrayOf((major shr 8).toByte(), major.toByte(), (minor shr 8).toByte(), minor.toByte())
                    Manufacturer(0x004C, data, ByteArray(data.size) { 0xFF.toByte() })
                }
                "eddystone" -> {
                    if (p.size != 3) return null
                    val ns = hexBytes(p[1]) ?: return null
                    val inst = hexBytes(p[2]) ?: return null
                    if (ns.size != 10 || inst.size != 6) return null
                    // frame type, tx power (any), namespace, instance
                    val data = byteArrayOf(0x00, 0x00) + ns + inst
                    val mask = byteArrayOf(0xFF.toByte(), 0x00) + ByteArray(16) { 0xFF.toByte() }
                    ServiceData(0xFEAA, data, mask)
                }
                "mac" -> if (p.size == 7) Address(p.drop(1).joinToString(":").uppercase()) else null
                else -> null
            }
        }

        private fun family(id: String): BeaconFilter? {
            val e = exact(id) ?: return null
            return when (e) {
                is Manufacturer -> {
                    val mask = ByteArray(e.data.size) { if (it < 18) 0xFF.toByte() else 0 }
                    Manufacturer(e.companyId, e.data.copyOf().also { d -> for (i in 18 until d.size) d[i] = 0 }, mask)
                }
                is ServiceData -> {
                    val mask = ByteArray(e.data.size) { if (it == 0 || it in 2 until 12) 0xFF.toByte() else 0 }
                    ServiceData(e.uuid16, e.data.copyOf().also { d -> for (i in 12 until d.size) d[i] = 0 }, mask)
                }
                is Address -> e
            }
        }
    }
}
