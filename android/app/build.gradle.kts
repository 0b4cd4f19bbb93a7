// Sample app: plain Android framework APIs (no AndroidX). libfpbp.so for each
// ABI is built from the Rust workspace by cargo-ndk before the JNI libs are
// merged (needs the NDK: ANDROID_NDK_HOME, and `cargo install cargo-ndk`,
// `rustup target add aarch64-linux-android armv7-linux-androideabi x86_64-linux-android`).
plugins {
    id("com.android.application")
    id("org.jetbrains.kotlin.android")
}

android {
    namespace = "io.fpbp.sample"
    compileSdk = 35

    defaultConfig {
        applicationId = "io.fpbp.sample"
        minSdk = 26
        targetSdk = 35
        versionCode = 1
        versionName = "0.1.0"
        ndk {
            abiFilters += listOf("arm64-v8a", "armeabi-v7a", "x86_64")
        }
    }

    sourceSets {
        getByName("main") {
            java.srcDir("src/main/kotlin")
            jniLibs.srcDir("src/main/jniLibs")
            // The demo site (site.json + plan) ships as assets under demo/.
            assets.srcDir(layout.buildDirectory.dir("generated/siteAssets"))
        }
    }

    compileOptions {
        sourceCompatibility = JavaVersion.VERSION_17
        targetCompatibility = JavaVersion.VERSION_17
    }
}

kotlin {
    jvmToolchain(17)
}

dependencies {
    implementation(project(":fpbp"))
}

/** Repository root (the Cargo workspace). */
val repoRoot: File = rootDir.parentFile

/** Builds libfpbp.so for the three ABIs into src/main/jniLibs/<abi>/. */
val cargoNdk by tasks.registering(Exec::class) {
    description = "Builds libfpbp.so (rust/jni) with cargo-ndk for arm64-v8a, armeabi-v7a, x86_64"
    workingDir = repoRoot
    commandLine(
        "cargo", "ndk",
        "-t", "arm64-v8a", "-t", "armeabi-v7a", "-t", "x86_64",
        "-o", file("src/main/jniLibs").absolutePath,
        "build", "--release", "-p", "fpbp-jni",
    )
    inputs.dir(repoRoot.resolve("rust"))
    inputs.file(repoRoot.resolve("Cargo.toml"))
    outputs.dir(file("src/main/jniLibs"))
}

/** Copies maps/demo into the generated assets as demo/. */
val copySiteAssets by tasks.registering(Copy::class) {
    from(repoRoot.resolve("maps/demo"))
    into(layout.buildDirectory.dir("generated/siteAssets/demo"))
}

tasks.matching { it.name.startsWith("merge") && it.name.endsWith("JniLibFolders") }.configureEach {
    dependsOn(cargoNdk)
}
tasks.matching { it.name.startsWith("merge") && it.name.endsWith("Assets") }.configureEach {
    dependsOn(copySiteAssets)
}
