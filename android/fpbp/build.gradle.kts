// The fpbp Kotlin library: NativeBridge (external funs of libfpbp.so),
// FpbpEngine, GmlTask/FusionTask/TaskScheduler, LogClockDriver, native log
// reader/writer, beacon ids. Plain JVM (no Android classes), so the same
// sources compile and run on a desktop JVM (host-tests/jvm).
plugins {
    id("org.jetbrains.kotlin.jvm")
}

kotlin {
    jvmToolchain(17)
}

sourceSets {
    main {
        kotlin.srcDir("src/main/kotlin")
    }
}
