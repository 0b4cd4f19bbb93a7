package io.fpbp.robo

import org.junit.runners.model.FrameworkMethod
import org.robolectric.RobolectricTestRunner
import org.robolectric.internal.bytecode.InstrumentationConfiguration

/**
 * Robolectric's runner with the JNI classes left to the JVM's class loader.
 *
 * A native library binds to one class loader per JVM. Robolectric loads the
 * app's classes in a sandbox class loader (one per SDK level), while the
 * plain JUnit 5 tests in the same JVM load [io.fpbp.NativeBridge] in the
 * application class loader; so `NativeBridge` (which loads libfpbp) and the
 * exception class libfpbp throws are not acquired by the sandbox. Everything
 * else of the library (the Android layer) runs instrumented on the Android
 * framework.
 */
class FpbpRobolectricRunner(testClass: Class<*>) : RobolectricTestRunner(testClass) {
    override fun createClassLoaderConfig(method: FrameworkMethod): InstrumentationConfiguration =
        InstrumentationConfiguration.Builder(super.createClassLoaderConfig(method))
            .doNotAcquireClass("io.fpbp.NativeBridge")
            .doNotAcquireClass("io.fpbp.FpbpNativeException")
            .build()
}
