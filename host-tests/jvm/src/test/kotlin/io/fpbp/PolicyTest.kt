package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertFalse
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows

/** The plain-JVM policies of the Android layer: permissions, start limits, scan filters, status. */
class PolicyTest {
    @Test
    fun permissionsPerApiLevel() {
        val fine = RadioPermissions.ACCESS_FINE_LOCATION
        // Android 12+ ignores a request of FINE without COARSE: both, in one request (guards issue 37)
        val coarse = RadioPermissions.ACCESS_COARSE_LOCATION
        assertEquals(listOf(fine), RadioPermissions.required(26, setOf(Radio.BLE)))
        assertEquals(listOf(fine), RadioPermissions.required(30, setOf(Radio.BLE)))
        assertEquals(listOf(RadioPermissions.BLUETOOTH_SCAN, fine, coarse), RadioPermissions.required(31, setOf(Radio.BLE)))
        assertEquals(listOf(fine, coarse), RadioPermissions.required(32, setOf(Radio.WIFI)))
        assertEquals(listOf(fine, coarse, RadioPermissions.NEARBY_WIFI_DEVICES), RadioPermissions.required(33, setOf(Radio.WIFI)))
        assertEquals(
            listOf(RadioPermissions.BLUETOOTH_SCAN, fine, coarse, RadioPermissions.NEARBY_WIFI_DEVICES),
            RadioPermissions.required(35, setOf(Radio.BLE, Radio.WIFI)),
        )
        assertEquals(emptyList<String>(), RadioPermissions.required(35, emptySet()))
        assertEquals(listOf(RadioPermissions.POST_NOTIFICATIONS), RadioPermissions.notification(33))
    }

    @Test
    fun startLimiterHoldsFivePerThirtySeconds() {
        val clock = ManualClock(1_000_000_000)
        val l = StartLimiter.ble(clock)
        // starts at 1, 2, 3, 4, 5 s
        for (k in 1..5) {
            clock.set(k * 1_000_000_000L)
            assertTrue(l.tryStart(), "start $k")
        }
        assertFalse(l.tryStart())
        assertEquals(26_000, l.waitMs(), "the first start leaves the window at 31 s")
        clock.set(30_999_000_000)
        assertFalse(l.tryStart())
        assertEquals(1, l.waitMs())
        clock.set(31_000_000_000)
        assertTrue(l.tryStart())
        assertFalse(l.tryStart(), "the other four are still in the window")
        assertEquals(1_000, l.waitMs())
        val w = StartLimiter.wifiForeground(clock)
        repeat(4) { assertTrue(w.tryStart()) }
        assertFalse(w.tryStart())
    }

    @Test
    fun scanFiltersOfTheSiteBeacons() {
        val f = BeaconFilter.forBeacons(
            listOf(
                "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:2",
                "eddystone:00112233445566778899:AABBCCDDEEFF",
                "mac:aa:bb:cc:dd:ee:ff",
                "nonsense",
            ),
        )
        assertEquals(3, f.size)
        val ib = f[0] as BeaconFilter.Manufacturer
        assertEquals(0x004C, ib.companyId)
        assertEquals(22, ib.data.size)
        assertEquals(listOf<Byte>(0x02, 0x15, 0xFD.toByte()), ib.data.take(3))
        assertEquals(listOf<Byte>(0, 1, 0, 2), ib.data.takeLast(4))
        val ed = f[1] as BeaconFilter.ServiceData
        assertEquals(0xFEAA, ed.uuid16)
        assertEquals(0.toByte(), ed.mask[1], "tx power is not matched")
        assertEquals(BeaconFilter.Address("AA:BB:CC:DD:EE:FF"), f[2])
        // many beacons of one UUID: one family filter instead of one per beacon
        val many = (1..100).map { "ibeacon:FDA50693-A4E2-4FB1-AFCF-C6EB07647825:1:$it" }
        val fam = BeaconFilter.forBeacons(many)
        assertEquals(1, fam.size)
        assertEquals(0.toByte(), (fam[0] as BeaconFilter.Manufacturer).mask.last())
    }

    @Test
    fun statusFollowsTheFacts() {
        val clock = ManualClock(0)
        val s = StatusTracker(clock)
        assertEquals(PositioningState.STOPPED, s.update()!!.state)
        s.started()
        assertEquals(PositioningState.WAITING_FOR_FIX, s.update()!!.state)
        assertEquals(null, s.update(), "unchanged status reported twice")
        s.permissionsMissing(listOf(RadioPermissions.BLUETOOTH_SCAN))
        val st = s.update()!!
        assertTrue(Problem.PERMISSION_MISSING in st.problems)
        assertTrue(st.describe().contains("BLUETOOTH_SCAN"), st.describe())
        s.permissionsMissing(emptyList())
        clock.set(11_000_000_000)
        s.tick(0, null)
        assertTrue(Problem.NO_BEACON_HEARD in s.update()!!.problems)
        val pose = Pose(11_000_000_000, 1.0, 2.0, 0, 0.0, 1.0)
        s.tick(5, pose)
        val ok = s.update()!!
        assertEquals(PositioningState.POSITIONING, ok.state)
        assertFalse(Problem.NO_BEACON_HEARD in ok.problems)
        clock.set(41_000_000_000)
        s.tick(5, pose)
        assertEquals(PositioningState.LOST, s.update()!!.state)
        s.paused(true)
        assertEquals(PositioningState.PAUSED, s.update()!!.state)
        s.stopped()
        assertEquals(Status(PositioningState.STOPPED), s.update())
    }

    @Test
    fun badRequestsAreRefused() {
        assertThrows<IllegalArgumentException> { PoseRequest(0) }
        assertThrows<IllegalArgumentException> { PoseRequest(1000, 2000) }
    }
}
