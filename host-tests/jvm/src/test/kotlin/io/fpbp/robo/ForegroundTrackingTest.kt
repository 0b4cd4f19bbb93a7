package io.fpbp.robo

import android.app.Activity
import android.os.Looper
import io.fpbp.android.FpbpPositioning
import org.junit.Assert.assertFalse
import org.junit.Assert.assertTrue
import org.junit.Test
import org.junit.runner.RunWith
import org.robolectric.Robolectric
import org.robolectric.Shadows.shadowOf
import org.robolectric.annotation.Config
import java.time.Duration
import java.util.concurrent.TimeUnit

/**
 * Issue 60, item 2: positioning started under a visible activity follows
 * the app's visibility from there. Before the fix the count of started
 * activities began at 0, so the first navigation (B starts, then A stops)
 * brought it to 0 and dropped the sources into background mode while B was
 * on screen.
 */
@RunWith(FpbpRobolectricRunner::class)
@Config(manifest = Config.NONE, sdk = [35])
class ForegroundTrackingTest : OpenSitePositioningTest() {
    @Test
    fun navigatingAwayFromTheStartingActivityKeepsTheForeground() {
        val a = Robolectric.buildActivity(Activity::class.java).setup() // created, started, resumed
        val p = start()
        assertTrue(p.foregroundMode)
        // A -> B as Android runs it: A pauses, B starts and resumes, A stops
        a.pause()
        val b = Robolectric.buildActivity(Activity::class.java).create().start().resume()
        a.stop()
        settle(p)
        assertTrue("navigating from the starting activity dropped positioning into background mode", p.foregroundMode)
        // back to A: B pauses, A restarts and resumes, B stops
        b.pause()
        a.restart().resume()
        b.stop()
        settle(p)
        assertTrue("navigating back dropped positioning into background mode", p.foregroundMode)
        // the app leaves the screen: background mode after the delay
        a.pause().stop()
        settle(p)
        assertFalse("the app left the screen, positioning stayed in foreground mode", p.foregroundMode)
        // and back
        a.restart().resume()
        settle(p)
        assertTrue(p.foregroundMode)
    }

    @Test
    fun startedUnderAPausedActivityItFollowsItsResumeAndStop() {
        // under a dialog of another app (a permission request): started, paused
        val a = Robolectric.buildActivity(Activity::class.java).setup()
        a.pause()
        val p = start()
        a.resume()
        a.pause()
        val b = Robolectric.buildActivity(Activity::class.java).create().start().resume()
        a.stop()
        settle(p)
        assertTrue(p.foregroundMode)
        b.pause().stop()
        settle(p)
        assertFalse(p.foregroundMode)
    }

    @Test
    fun aTranslucentActivityClosingOverTheStartingOneKeepsTheForeground() {
        val a = Robolectric.buildActivity(Activity::class.java).setup()
        val p = start()
        // B over A without hiding it: A pauses (not stops), B starts and resumes
        a.pause()
        val b = Robolectric.buildActivity(Activity::class.java).create().start().resume()
        settle(p)
        assertTrue(p.foregroundMode)
        // B closes: B pauses, A resumes, B stops; A was never seen starting
        b.pause()
        a.resume()
        b.stop()
        settle(p)
        assertTrue("closing an activity over the starting one dropped positioning into background mode", p.foregroundMode)
        a.pause().stop()
        settle(p)
        assertFalse(p.foregroundMode)
    }

    /** Runs the main looper past the background delay, then waits for the control thread's work. */
    private fun settle(p: FpbpPositioning) {
        shadowOf(Looper.getMainLooper()).idleFor(Duration.ofMillis(FpbpPositioning.BACKGROUND_DELAY_MS + 500))
        // a round trip through the control thread, after the mode change it was handed
        p.resume().get(30, TimeUnit.SECONDS)
    }
}
