// The fpbp Android library (AAR): the JNI bridge and plain-JVM parts
// (io.fpbp: NativeBridge, FpbpEngine, tasks, pose delivery, status, policies;
// no android.* imports, also compiled and tested on a desktop JVM by
// host-tests/jvm) and the Android layer (io.fpbp.android: FpbpPositioning,
// BLE / sensor / WiFi sources, the foreground service), with libfpbp.so for
// arm64-v8a, armeabi-v7a and x86_64 built by cargo-ndk into src/main/jniLibs.
//
// Needs the NDK (ANDROID_NDK_HOME or the SDK's ndk/), `cargo install cargo-ndk`
// and `rustup target add aarch64-linux-android armv7-linux-androideabi x86_64-linux-android`.
// `./gradlew :fpbp:publishToMavenLocal` gives io.fpbp:fpbp-android:0.2.0.
// Not built on the machine that wrote it (no SDK, NDK, Gradle or Google Maven
// there); see ../README.md for what was verified.
plugins {
    id("com.android.library")
    id("org.jetbrains.kotlin.android")
    `maven-publish`
}

android {
    namespace = "io.fpbp"
    compileSdk = 35

    defaultConfig {
        minSdk = 26
        consumerProguardFiles("consumer-rules.pro")
        ndk {
            abiFilters += listOf("arm64-v8a", "armeabi-v7a", "x86_64")
        }
    }

    sourceSets {
        getByName("main") {
            java.srcDir("src/main/kotlin")
            jniLibs.srcDir("src/main/jniLibs")
        }
    }

    compileOptions {
        sourceCompatibility = JavaVersion.VERSION_17
        targetCompatibility = JavaVersion.VERSION_17
    }

    publishing {
        singleVariant("release") {
            withSourcesJar()
        }
    }
}

kotlin {
    jvmToolchain(17)
}

dependencies {
    // Flow<Pose> / Flow<Status> (Maven Central).
    api("org.jetbrains.kotlinx:kotlinx-coroutines-core:1.11.0")
}

/** Repository root (the Cargo workspace). */
val repoRoot: File = rootDir.parentFile

/** Builds libfpbp.so (rust/jni) for the three ABIs into src/main/jniLibs/<abi>/. */
val cargoNdk by tasks.registering(Exec::class) {
    description = "Builds libfpbp.so (rust/jni) with cargo-ndk for arm64-v8a, armeabi-v7a, x86_64"
    workingDir = repoRoot
    commandLine(
        "cargo", "ndk",
        "-t", "arm64-v8a", "-t", "armeabi-v7a", "-t", "x86_64",
        "--platform", "26",
        "-o", file("src/main/jniLibs").absolutePath,
        "build", "--release", "-p", "fpbp-jni",
    )
    inputs.dir(repoRoot.resolve("rust"))
    inputs.file(repoRoot.resolve("Cargo.toml"))
    inputs.file(repoRoot.resolve("Cargo.lock"))
    outputs.dir(file("src/main/jniLibs"))
}

tasks.matching { it.name.startsWith("merge") && it.name.endsWith("JniLibFolders") }.configureEach {
    dependsOn(cargoNdk)
}

publishing {
    publications {
        register<MavenPublication>("release") {
            groupId = "io.fpbp"
            artifactId = "fpbp-android"
            version = "0.2.0"
            afterEvaluate {
                from(components["release"])
            }
            pom {
                name.set("fpbp for Android")
                description.set("Indoor positioning: BLE + PDR + floor plan (FP-BP) with a Rust core")
            }
        }
    }
}
