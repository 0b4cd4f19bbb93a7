package io.fpbp

import org.junit.jupiter.api.Assumptions.assumeTrue
import org.junit.jupiter.api.Tag
import org.junit.jupiter.api.Test
import java.io.File
import java.lang.management.ManagementFactory
import java.lang.management.MemoryType

/**
 * Load time and peak memory of a site with its radio map on the JVM: from
 * a bundle (`SiteBundle.fromFile` + `FpbpEngine.startBundle`: the file is
 * mapped, the map is decoded natively as a stream) against the JSON form
 * (the map read into a String and passed to `FpbpEngine.start`). Run by
 * hand: `FPBP_BENCH_BUNDLE=X.fpbp FPBP_BENCH_SITE=S.json
 * FPBP_BENCH_RADIO_MAP=RM.json host-tests/jvm/run.sh --bench`. Prints
 * figures; asserts nothing about time.
 */
@Tag("bench")
class BundleLoadBench {
    private fun resetPeaks() {
        System.gc()
        ManagementFactory.getMemoryPoolMXBeans().forEach { it.resetPeakUsage() }
        // Linux: resets VmHWM (peak RSS) of this process
        runCatching { File("/proc/self/clear_refs").writeText("5") }
    }

    private fun peakHeapMb(): Double =
        ManagementFactory.getMemoryPoolMXBeans().filter { it.type == MemoryType.HEAP }.sumOf { it.peakUsage.used } / 1e6

    private fun peakRssMb(): String =
        runCatching {
            File("/proc/self/status").readLines().first { it.startsWith("VmHWM:") }
                .split(Regex("\\s+"))[1].toLong() / 1e3
        }.map { "%.1f MB".format(it) }.getOrDefault("n/a")

    private fun measure(label: String, start: () -> FpbpEngine) {
        repeat(2) { start().close() } // warm-up
        val times = (1..5).map {
            resetPeaks()
            val t0 = System.nanoTime()
            val e = start()
            val ms = (System.nanoTime() - t0) / 1e6
            val heap = peakHeapMb()
            val rss = peakRssMb()
            e.close()
            Triple(ms, heap, rss)
        }
        val sorted = times.sortedBy { it.first }
        val med = sorted[2]
        println(
            "bench %-40s median %7.1f ms (min %.1f, max %.1f); peak Java heap %.1f MB, peak RSS %s (of the median run)".format(
                label, med.first, sorted[0].first, sorted[4].first, med.second, med.third,
            ),
        )
    }

    @Test
    fun bundleAgainstJson() {
        val bundle = System.getProperty("fpbp.bench.bundle")?.takeIf { it.isNotEmpty() }
        val site = System.getProperty("fpbp.bench.site")?.takeIf { it.isNotEmpty() }
        val map = System.getProperty("fpbp.bench.radiomap")?.takeIf { it.isNotEmpty() }
        assumeTrue(bundle != null && site != null && map != null) {
            "set FPBP_BENCH_BUNDLE, FPBP_BENCH_SITE and FPBP_BENCH_RADIO_MAP (see the class comment)"
        }
        val f = File(bundle!!)
        val s = File(site!!)
        val m = File(map!!)
        println("bench bundle ${f.length()} bytes; site ${s.length()} + radio map JSON ${m.length()} bytes")
        measure("startBundle (mapped file)") { FpbpEngine.startBundle(SiteBundle.fromFile(f)) }
        measure("start (site + radio map JSON String)") {
            FpbpEngine.start(s.readText(), s.parentFile.path, FpbpDefaults.ENGINE, "", null, m.readText())
        }
    }
}
