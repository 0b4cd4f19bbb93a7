package io.fpbp

import java.io.File
import java.io.InputStream
import java.nio.ByteBuffer
import java.nio.channels.FileChannel
import java.nio.file.StandardOpenOption

/**
 * A site bundle (`fpbp bundle SITE.json --radio-map RM.json --out X.fpbp`,
 * docs/formats.md "Site bundle"): site.json with its beacons and access
 * points, the plan images and the radio map in one file, held in a direct
 * [ByteBuffer] that the native library reads in place (no String of the
 * radio map crosses JNI). Start an engine with [FpbpEngine.startBundle] or
 * hand it to [io.fpbp.android.FpbpPositioning.Site.fromBundle].
 *
 * The buffer is only read; keep the file it maps unchanged while the
 * bundle is in use.
 */
class SiteBundle private constructor(
    /** The bundle's bytes (direct; position 0, limit = size). */
    val buffer: ByteBuffer,
) {
    /** Size of the bundle, bytes. */
    val sizeBytes: Int get() = buffer.capacity()

    /**
     * The text of the bundle's site.json (for BLE scan filters and
     * [io.fpbp.android.FpbpPositioning.beaconIds]). The first call checks the
     * whole bundle natively (manifest, sizes, SHA-256 of every entry) and
     * throws [IllegalArgumentException] naming the field or entry at fault.
     */
    val siteJson: String by lazy { NativeBridge.bundleSiteJson(buffer) }

    companion object {
        /** Largest bundle [fromStream] reads, bytes (the native limit, `bundle::MAX_BUNDLE_BYTES`). */
        const val MAX_BYTES: Long = 1L shl 30

        /**
         * Maps [file] read-only (no copy on the Java heap; the pages load as
         * the native parser reads them).
         */
        @JvmStatic
        fun fromFile(file: File): SiteBundle =
            FileChannel.open(file.toPath(), StandardOpenOption.READ).use { ch ->
                val size = ch.size()
                require(size <= MAX_BYTES) { "$file: $size bytes, over the bundle limit of $MAX_BYTES" }
                SiteBundle(ch.map(FileChannel.MapMode.READ_ONLY, 0, size))
            }

        /**
         * Reads [input] (e.g. `assets.open("site.fpbp")`) into a direct buffer
         * and closes it. [sizeHint] (e.g. `AssetFileDescriptor.length`) avoids
         * regrowing the buffer; -1 when unknown. For an asset stored
         * uncompressed, mapping its file descriptor ([fromBuffer] of
         * `FileInputStream(afd.fileDescriptor).channel.map(READ_ONLY,
         * afd.startOffset, afd.length)`) avoids the copy.
         */
        @JvmStatic
        @JvmOverloads
        fun fromStream(input: InputStream, sizeHint: Long = -1): SiteBundle = input.use { s ->
            var buf = ByteBuffer.allocateDirect(sizeHint.coerceIn(64L * 1024, MAX_BYTES).toInt())
            val chunk = ByteArray(64 * 1024)
            while (true) {
                val n = s.read(chunk)
                if (n < 0) break
                if (buf.remaining() < n) {
                    val want = maxOf(buf.capacity().toLong() * 2, buf.position().toLong() + n)
                    require(buf.position().toLong() + n <= MAX_BYTES) { "bundle stream over the limit of $MAX_BYTES bytes" }
                    val grown = ByteBuffer.allocateDirect(want.coerceAtMost(MAX_BYTES).toInt())
                    buf.flip()
                    grown.put(buf)
                    buf = grown
                }
                buf.put(chunk, 0, n)
            }
            buf.flip()
            SiteBundle(buf.slice())
        }

        /**
         * The bundle in [buffer] from its position to its limit (a direct
         * buffer is used in place, a heap buffer is copied once into a direct
         * one). [buffer]'s own position is not changed.
         */
        @JvmStatic
        fun fromBuffer(buffer: ByteBuffer): SiteBundle {
            val view = buffer.slice()
            if (view.isDirect) return SiteBundle(view)
            val copy = ByteBuffer.allocateDirect(view.remaining())
            copy.put(view)
            copy.flip()
            return SiteBundle(copy)
        }

        /** The bundle in [bytes] (copied once into a direct buffer). */
        @JvmStatic
        fun fromBytes(bytes: ByteArray): SiteBundle = fromBuffer(ByteBuffer.wrap(bytes))
    }
}
