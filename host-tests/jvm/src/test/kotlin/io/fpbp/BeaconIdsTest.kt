package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertNull
import org.junit.jupiter.api.Test

class BeaconIdsTest {
    private fun bytes(vararg v: Int) = ByteArray(v.size) { v[it].toByte() }

    @Test
    fun parsesAnIBeaconFrame() {
        val rec = bytes(
            0x02, 0x01, 0x06, // flags
            0x1A, 0xFF, 0x4C, 0x00, 0x02, 0x15,
            0xFD, 0xA5, 0x06, 0x93, 0xA4, 0xE2, 0x4F, 0xB1, 0xAF, 0xCF, 0xC6, 0xEB, 0x07, 0x64, 0x78, 0x25,
            0x27, 0x59, 0xEF, 0xEA, 0xC5,
        )
        val f = BeaconIds.fromAdvertisement(rec, "00:11:22:33:44:55")
        assertEquals(BeaconFrame("ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:10073:61418", -59), f)
    }

    @Test
    fun parsesAnEddystoneUidFrameAndConvertsTxPowerTo1m() {
        val rec = bytes(
            0x03, 0x03, 0xAA, 0xFE,
            0x17, 0x16, 0xAA, 0xFE, 0x00, 0xEE,
            0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A,
            0xA1, 0xB2, 0xC3, 0xD4, 0xE5, 0xF6, 0x00, 0x00,
        )
        val f = BeaconIds.fromAdvertisement(rec, "00:11:22:33:44:55")
        assertEquals(BeaconFrame("eddystone:0102030405060708090A:A1B2C3D4E5F6", -18 - 41), f)
    }

    @Test
    fun otherFramesAndTruncatedRecordsFallBackToTheMac() {
        val other = bytes(0x02, 0x01, 0x06, 0x05, 0xFF, 0x06, 0x00, 0x01, 0x02)
        assertEquals(BeaconFrame("mac:AA:BB:CC:DD:EE:0F", null), BeaconIds.fromAdvertisement(other, "aa:bb:cc:dd:ee:0f"))
        val truncated = bytes(0x1A, 0xFF, 0x4C, 0x00, 0x02)
        assertNull(BeaconIds.parse(truncated))
        assertEquals("mac:AA:BB:CC:DD:EE:FF", BeaconIds.macId("aa-bb-cc-dd-ee-ff"))
    }
}
