// Plugin versions for the whole Android project (not built on the machine that
// wrote them: Google's Maven and the Gradle distribution were unreachable;
// see README.md for what was verified).
plugins {
    id("com.android.application") version "8.9.1" apply false
    id("com.android.library") version "8.9.1" apply false
    id("org.jetbrains.kotlin.android") version "2.3.20" apply false
}
