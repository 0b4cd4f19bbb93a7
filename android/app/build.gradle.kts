// Sample app: plain Android framework APIs (no AndroidX). libfpbp.so comes
// with the :fpbp library (its cargoNdk<Variant> tasks build it for each ABI).
import org.jetbrains.kotlin.gradle.dsl.JvmTarget
import javax.inject.Inject

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
    }

    sourceSets {
        getByName("main") {
            java.srcDir("src/main/kotlin")
        }
    }

    // Bytecode for Java 17 from any JDK 17+ running Gradle (no pinned toolchain).
    compileOptions {
        sourceCompatibility = JavaVersion.VERSION_17
        targetCompatibility = JavaVersion.VERSION_17
    }

    packaging {
        jniLibs {
            // libfpbp.so stored uncompressed and page-aligned in the APK and
            // loaded from there (no extraction at install). Its LOAD segments
            // are 16 KB aligned (../../.cargo/config.toml), as Google Play
            // requires for apps targeting Android 15+.
            useLegacyPackaging = false
        }
    }
}

kotlin {
    compilerOptions {
        jvmTarget.set(JvmTarget.JVM_17)
    }
}

dependencies {
    implementation(project(":fpbp"))
}

/** Copies a site folder into `outputDir/demo/` (AGP chooses outputDir). */
abstract class CopySiteAssets : DefaultTask() {
    @get:InputDirectory
    @get:PathSensitive(PathSensitivity.RELATIVE)
    abstract val siteDir: DirectoryProperty

    @get:OutputDirectory
    abstract val outputDir: DirectoryProperty

    @get:Inject
    abstract val fs: FileSystemOperations

    @TaskAction
    fun copy() {
        fs.sync {
            from(siteDir) { into("demo") }
            into(outputDir.get().asFile)
        }
    }
}

/** Repository root (the Cargo workspace). */
val repoRoot: File = rootDir.parentFile

// The demo site (maps/demo: site.json + plan) ships as assets under demo/.
// Registered as a generated assets folder of each variant, so every task that
// reads the variant's assets (merge, lint, lintVital, packaging) depends on it.
androidComponents {
    onVariants { variant ->
        val copySiteAssets = tasks.register<CopySiteAssets>(
            "copy" + variant.name.replaceFirstChar { it.uppercase() } + "SiteAssets",
        ) {
            siteDir.set(repoRoot.resolve("maps/demo"))
        }
        variant.sources.assets?.addGeneratedSourceDirectory(copySiteAssets, CopySiteAssets::outputDir)
    }
}
