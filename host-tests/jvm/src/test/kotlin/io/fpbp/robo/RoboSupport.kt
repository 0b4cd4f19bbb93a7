package io.fpbp.robo

import android.os.Looper
import io.fpbp.TestSupport
import io.fpbp.android.FpbpPositioning
import org.robolectric.Shadows.shadowOf
import java.util.concurrent.TimeUnit

/** Helpers of the Robolectric tests. */
object RoboSupport {
    /** The open host-test site (four `mac:` beacons, no plan file). */
    val openSite = FpbpPositioning.Site(TestSupport.openSiteJson, TestSupport.repo.path)

    /** Runs the main looper's due tasks until [done] or [timeoutMs] of wall time. */
    fun idleUntil(timeoutMs: Long = 10_000, done: () -> Boolean): Boolean {
        val end = System.nanoTime() + TimeUnit.MILLISECONDS.toNanos(timeoutMs)
        while (System.nanoTime() < end) {
            shadowOf(Looper.getMainLooper()).idle()
            if (done()) return true
            Thread.sleep(10)
        }
        shadowOf(Looper.getMainLooper()).idle()
        return done()
    }
}

/** Base of the tests that run one [FpbpPositioning] on the open site: started by [start], closed after each test. */
abstract class OpenSitePositioningTest {
    protected val app: android.app.Application get() = org.robolectric.RuntimeEnvironment.getApplication()
    protected var positioning: FpbpPositioning? = null

    @org.junit.After
    fun closePositioning() {
        positioning?.closeAsync()?.get(30, TimeUnit.SECONDS)
    }

    protected fun start(options: FpbpPositioning.Options = FpbpPositioning.Options()): FpbpPositioning =
        FpbpPositioning(app, RoboSupport.openSite, options).also {
            positioning = it
            it.start().get(30, TimeUnit.SECONDS)
        }
}
