// fpbp Android project: the Android library (:fpbp, an AAR with libfpbp.so;
// its io.fpbp package has no android.* imports) and the sample app (:app).
// Open this folder (android/) in Android Studio with the NDK and cargo-ndk
// installed, or run ./gradlew; see README.md. No JDK toolchain is pinned (the
// modules set Java/Kotlin target 17), so no toolchain resolver is needed.
pluginManagement {
    repositories {
        google()
        mavenCentral()
        gradlePluginPortal()
    }
}

dependencyResolutionManagement {
    repositoriesMode.set(RepositoriesMode.FAIL_ON_PROJECT_REPOS)
    repositories {
        google()
        mavenCentral()
    }
}

rootProject.name = "fpbp-android"
include(":fpbp", ":app")
