// The fpbp Android library (AAR): the JNI bridge and plain-JVM parts
// (io.fpbp: NativeBridge, FpbpEngine, tasks, pose delivery, status, policies;
// no android.* imports, also compiled and tested on a desktop JVM by
// host-tests/jvm) and the Android layer (io.fpbp.android: FpbpPositioning,
// BLE / sensor / WiFi sources, the foreground service), with libfpbp.so for
// arm64-v8a, armeabi-v7a and x86_64 built by cargo-ndk (one cargoNdk<Variant>
// task per variant, into build/, registered through the androidComponents API).
//
// Needs the NDK (the SDK's, or ANDROID_NDK_HOME), `cargo install cargo-ndk`
// and `rustup target add aarch64-linux-android armv7-linux-androideabi x86_64-linux-android`.
// `./gradlew :fpbp:publishToMavenLocal` gives io.fpbp:fpbp-android:0.2.0.
// Not built on the machine that wrote it (no SDK, NDK, Gradle or Google Maven
// there); see ../README.md for what was verified.
import org.gradle.process.ExecOperations
import org.jetbrains.kotlin.gradle.dsl.JvmTarget
import javax.inject.Inject

plugins {
    id("com.android.library")
    id("org.jetbrains.kotlin.android")
    `maven-publish`
}

/** ABIs of libfpbp.so in the AAR (cargo-ndk -t names). */
val fpbpAbis = listOf("arm64-v8a", "armeabi-v7a", "x86_64")

/** minSdk of the library, also the API level libfpbp.so links against. */
val fpbpMinSdk = 26

android {
    namespace = "io.fpbp"
    compileSdk = 35

    defaultConfig {
        minSdk = fpbpMinSdk
        consumerProguardFiles("consumer-rules.pro")
        ndk {
            abiFilters += fpbpAbis
        }
    }

    sourceSets {
        getByName("main") {
            java.srcDir("src/main/kotlin")
        }
    }

    // Bytecode for Java 17, compiled by whatever JDK 17+ runs Gradle (Android
    // Studio's bundled JDK 21 included): no toolchain is pinned, so nothing
    // has to find or download a JDK 17.
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
    compilerOptions {
        jvmTarget.set(JvmTarget.JVM_17)
    }
}

dependencies {
    // Flow<Pose> / Flow<Status> (Maven Central).
    api("org.jetbrains.kotlinx:kotlinx-coroutines-core:1.11.0")
}

/**
 * Builds libfpbp.so (crate fpbp-jni, rust/jni) with cargo-ndk into
 * `outputDir/<abi>/libfpbp.so`. AGP chooses `outputDir` (under build/) and
 * runs the task before anything that reads the variant's jniLibs.
 * The `self-test` cargo feature (test hooks) is never enabled here.
 */
abstract class CargoNdkTask : DefaultTask() {
    /** cargo executable (`fpbp.cargo`; default ~/.cargo/bin/cargo when present, else `cargo` on PATH). */
    @get:Input
    abstract val cargo: Property<String>

    /** cargo-ndk `-t` names. */
    @get:Input
    abstract val abis: ListProperty<String>

    /** Android API level the .so links against (`--platform`), the library's minSdk. */
    @get:Input
    abstract val platform: Property<Int>

    /** Cargo profile (`android-release`: stripped, LTO; see the workspace Cargo.toml). */
    @get:Input
    abstract val profile: Property<String>

    /** NDK root handed to cargo-ndk as ANDROID_NDK_HOME (absent: cargo-ndk looks for one itself). */
    @get:Input
    @get:Optional
    abstract val ndkDir: Property<String>

    /** The Cargo workspace root (cargo runs there). */
    @get:Internal
    abstract val workspaceDir: DirectoryProperty

    /** Cargo manifests, lock file, .cargo/config.toml and the Rust sources (cargo itself decides what to rebuild). */
    @get:InputFiles
    @get:PathSensitive(PathSensitivity.RELATIVE)
    abstract val rustSources: ConfigurableFileCollection

    @get:OutputDirectory
    abstract val outputDir: DirectoryProperty

    @get:Inject
    abstract val execOps: ExecOperations

    @get:Inject
    abstract val fs: FileSystemOperations

    @TaskAction
    fun buildLibraries() {
        val out = outputDir.get().asFile
        fs.delete { delete(out) } // no stale ABI or library left from an earlier run
        out.mkdirs()
        val command = mutableListOf(cargo.get(), "ndk")
        abis.get().forEach { command += listOf("-t", it) }
        command += listOf(
            "--platform", platform.get().toString(),
            "-o", out.absolutePath,
            "build", "--profile", profile.get(), "-p", "fpbp-jni", "--lib",
        )
        execOps.exec {
            workingDir = workspaceDir.get().asFile
            commandLine(command)
            ndkDir.orNull?.let { environment("ANDROID_NDK_HOME", it) }
        }
    }
}

/** Repository root (the Cargo workspace). */
val repoRoot: File = rootDir.parentFile

/** `fpbp.cargo`, else rustup's cargo in CARGO_HOME or ~/.cargo (an IDE's PATH often lacks it), else `cargo`. */
val cargoExecutable: Provider<String> = providers.gradleProperty("fpbp.cargo").orElse(
    providers.environmentVariable("CARGO_HOME")
        .orElse(providers.systemProperty("user.home").map { "$it/.cargo" })
        .map { home ->
            val windows = System.getProperty("os.name").startsWith("Windows")
            val exe = File(home, if (windows) "bin/cargo.exe" else "bin/cargo")
            if (exe.isFile) exe.absolutePath else "cargo"
        },
)

/** `fpbp.cargoProfile` overrides the profile of every variant. */
val cargoProfileOverride: Provider<String> = providers.gradleProperty("fpbp.cargoProfile")

androidComponents {
    onVariants { variant ->
        val taskName = "cargoNdk" + variant.name.replaceFirstChar { it.uppercase() }
        val cargoNdk = tasks.register<CargoNdkTask>(taskName) {
            group = "build"
            description = "Builds libfpbp.so (rust/jni) with cargo-ndk for ${fpbpAbis.joinToString()} (${variant.name})"
            cargo.set(cargoExecutable)
            abis.set(fpbpAbis)
            platform.set(fpbpMinSdk)
            // Release: the stripped LTO profile. Other build types: `release`
            // (same optimisation, line tables kept for native backtraces;
            // AGP still strips what it packages).
            profile.set(cargoProfileOverride.orElse(if (variant.buildType == "release") "android-release" else "release"))
            ndkDir.set(
                providers.environmentVariable("ANDROID_NDK_HOME")
                    .orElse(androidComponents.sdkComponents.ndkDirectory.map { it.asFile.absolutePath }),
            )
            workspaceDir.set(repoRoot)
            rustSources.from(
                fileTree(repoRoot) {
                    include("Cargo.toml", "Cargo.lock", ".cargo/config.toml", "rust/**")
                    exclude("**/target/**")
                },
            )
        }
        variant.sources.jniLibs?.addGeneratedSourceDirectory(cargoNdk, CargoNdkTask::outputDir)
    }
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
