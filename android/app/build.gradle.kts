// Sample app: plain Android framework APIs (no AndroidX). libfpbp.so comes
// with the :fpbp library (its cargoNdk task builds it for each ABI).
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

/** Copies maps/demo into the generated assets as demo/. */
val copySiteAssets by tasks.registering(Copy::class) {
    from(repoRoot.resolve("maps/demo"))
    into(layout.buildDirectory.dir("generated/siteAssets/demo"))
}

tasks.matching { it.name.startsWith("merge") && it.name.endsWith("Assets") }.configureEach {
    dependsOn(copySiteAssets)
}
