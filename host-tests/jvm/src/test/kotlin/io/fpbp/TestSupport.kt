package io.fpbp

import java.io.File

/** Paths and sites shared by the host tests (run.sh passes the system properties). */
object TestSupport {
    /** Repository root. */
    val repo: File = File(System.getProperty("fpbp.repo") ?: "../..").canonicalFile

    /** Engines the native library offers. */
    val engines: List<String> by lazy { FpbpEngine.engineNames() }

    /**
     * The engine the tests run: `fpbp` (the main algorithm) when registered,
     * else the first registered one, with a printed note.
     */
    val engine: String by lazy {
        val want = System.getProperty("fpbp.engine")?.takeIf { it.isNotEmpty() } ?: "fpbp"
        when {
            want in engines -> want
            engines.isNotEmpty() -> engines.first().also {
                println("NOTE: engine `$want` is not registered (have: $engines); host tests use `$it`")
            }
            else -> error("no engine is registered in fpbp_core::engines::ENGINE_NAMES")
        }
    }

    /** The demo site (maps/demo/site.json) shipped by the project. */
    val demoSite: File get() = File(repo, "maps/demo/site.json")

    /** A one-floor open site (no plan file) with four beacons at the corners. */
    val openSiteJson: String = """
        {
          "format": "fpbp-site", "version": 1, "name": "host-test open floor",
          "floors": [ { "id": 0, "name": "ground", "open_area_m": [20.0, 12.0], "pixels_per_meter": 10.0 } ],
          "beacons": [
            { "id": "mac:00:00:00:00:00:01", "floor": 0, "x_m": 1.0,  "y_m": 1.0,  "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0 },
            { "id": "mac:00:00:00:00:00:02", "floor": 0, "x_m": 19.0, "y_m": 1.0,  "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0 },
            { "id": "mac:00:00:00:00:00:03", "floor": 0, "x_m": 19.0, "y_m": 11.0, "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0 },
            { "id": "mac:00:00:00:00:00:04", "floor": 0, "x_m": 1.0,  "y_m": 11.0, "rssi_1m_dbm": -59.0, "path_loss_exponent": 2.0 }
          ]
        }
    """.trimIndent()

    /** Beacon ids of [openSiteJson]. */
    val openSiteBeacons = (1..4).map { "mac:00:00:00:00:00:0$it" }

    /** Starts [engine] on the open site, with a start position (some engines need one). */
    fun startOpen(name: String = engine): FpbpEngine =
        FpbpEngine.start(openSiteJson, repo.path, name, "", InitialPosition(10.0, 6.0, 0, 0.0))
}
