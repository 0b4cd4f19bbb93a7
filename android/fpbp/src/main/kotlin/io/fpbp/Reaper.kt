package io.fpbp

import java.lang.ref.PhantomReference
import java.lang.ref.ReferenceQueue
import java.util.concurrent.ConcurrentHashMap
import java.util.concurrent.atomic.AtomicBoolean

/**
 * Runs a clean-up action once an object is no longer reachable, like
 * `java.lang.ref.Cleaner` (which Android has only from API 33; the library's
 * minSdk is 26): a [PhantomReference] per registered object, one
 * [ReferenceQueue] and one daemon thread (`fpbp-reaper`, started on first
 * use) that runs the action of each reference the garbage collector
 * enqueues. Plain JVM.
 *
 * The action must not reach the registered object (a lambda that captures
 * it keeps it alive forever); it runs on the reaper thread, so it must be
 * short and must not throw (a throw is swallowed). [Cleanable.clean] runs it
 * at once (an explicit `close`) and unregisters it: it runs at most once.
 */
object Reaper {
    private val queue = ReferenceQueue<Any>()

    /** Registered, not yet cleaned references (keeps them reachable until enqueued). */
    private val live: MutableSet<Ref> = ConcurrentHashMap.newKeySet()

    /** Handle of one registration. */
    interface Cleanable {
        /** Runs the action now if it has not run, and unregisters it. */
        fun clean()
    }

    private class Ref(referent: Any, action: Runnable) :
        PhantomReference<Any>(referent, queue),
        Cleanable {
        private var action: Runnable? = action
        private val done = AtomicBoolean(false)

        override fun clean() {
            if (!done.compareAndSet(false, true)) return
            live.remove(this)
            val a = action
            action = null
            try {
                a?.run()
            } catch (_: Throwable) {
                // an action's failure must not end the reaper thread
            }
        }
    }

    private val thread: Thread by lazy {
        Thread({
            while (true) {
                try {
                    (queue.remove() as? Ref)?.clean()
                } catch (_: InterruptedException) {
                    // daemon: keep serving
                }
            }
        }, "fpbp-reaper").apply {
            isDaemon = true
            start()
        }
    }

    /** Runs [action] once [obj] becomes unreachable (or at [Cleanable.clean]). */
    @JvmStatic
    fun register(obj: Any, action: Runnable): Cleanable {
        thread // started on first use
        val r = Ref(obj, action)
        live.add(r)
        return r
    }

    /** Registrations whose action has not run yet (tests, diagnostics). */
    @JvmStatic
    val pending: Int get() = live.size
}
