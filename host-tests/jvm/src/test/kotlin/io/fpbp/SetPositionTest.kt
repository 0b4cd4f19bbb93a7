package io.fpbp

import org.junit.jupiter.api.Assertions.assertEquals
import org.junit.jupiter.api.Assertions.assertTrue
import org.junit.jupiter.api.Test
import org.junit.jupiter.api.assertThrows

/** setPosition through JNI: engines that take a position, and the ones that refuse. */
class SetPositionTest {
    private val takes = listOf("fpbp", "bp", "pdr", "gml", "trilat", "frbw", "ml", "wcentroid")
    private val refuses = listOf("ppsa", "prox-pf", "robust-ekf", "tc-ekf")

    @Test
    fun enginesThatTakeAPositionPublishItAtOnce() {
        for (name in takes.filter { it in TestSupport.engines }) {
            TestSupport.startOpen(name).use { e ->
                e.setPosition(5_000_000_000, InitialPosition(12.5, 3.5, 0, 0.0))
                val p = e.pose() ?: error("$name: no pose after setPosition")
                assertEquals(5_000_000_000, p.tNs, name)
                assertEquals(12.5, p.xM, name)
                assertEquals(3.5, p.yM, name)
                assertEquals(0, p.floor, name)
                val bad = assertThrows<IllegalArgumentException>(name) { e.setPosition(6_000_000_000, InitialPosition(1.0, 1.0, 9)) }
                assertTrue(bad.message!!.contains("floor 9"), bad.message)
                assertThrows<IllegalArgumentException>(name) { e.setPosition(6_000_000_000, InitialPosition(Double.NaN, 1.0, 0)) }
                assertEquals(5_000_000_000, e.pose()?.tNs, "$name: a refused position changed the pose")
            }
        }
    }

    @Test
    fun enginesWithoutOneRefuseClearly() {
        for (name in refuses.filter { it in TestSupport.engines }) {
            TestSupport.startOpen(name).use { e ->
                val x = assertThrows<UnsupportedOperationException>(name) { e.setPosition(1, InitialPosition(1.0, 1.0, 0)) }
                assertTrue(x.message!!.contains("`$name` does not support set_position"), x.message)
            }
        }
    }

    @Test
    fun fpbpDeadReckonsFromATapWithoutBeacons() {
        TestSupport.startOpen("fpbp").use { e ->
            e.setPosition(1_000_000_000, InitialPosition(10.0, 6.0, 0))
            assertEquals(PoseSource.DEAD_RECKONING, e.pose()?.source)
            assertThrows<IllegalArgumentException> { NativeBridge.setPosition(e.handle, 1, doubleArrayOf(1.0, 2.0)) }
            assertThrows<IllegalArgumentException> { NativeBridge.setPosition(e.handle, 1, null) }
        }
    }
}
