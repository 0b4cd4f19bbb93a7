package io.fpbp

/**
 * Test hooks of libfpbp (rust/jni `selftest.rs`), exported only when the
 * library is built with the `self-test` cargo feature, as run.sh does for the
 * host tests. The Android library is built without it: these functions are
 * not part of the shipped API and calling them there throws
 * [UnsatisfiedLinkError].
 */
object NativeSelfTest {
    init {
        // NativeBridge's init loads libfpbp and checks its pose layout.
        NativeBridge.poseLen()
    }

    /** Panics inside the native library on purpose (the panic must surface as [FpbpNativeException]). */
    @JvmStatic external fun selfTestPanic()

    /**
     * Starts a test double (not an engine) whose every task run waits at the
     * self-test gate while it is closed ([selfTestGate]); returns its handle.
     */
    @JvmStatic external fun selfTestStartBlocking(): Long

    /** Opens or closes the self-test gate. */
    @JvmStatic external fun selfTestGate(open: Boolean)

    /** Task runs waiting at the self-test gate now. */
    @JvmStatic external fun selfTestBlockedTasks(): Int
}
