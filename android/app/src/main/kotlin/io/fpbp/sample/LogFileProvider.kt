package io.fpbp.sample

import android.content.ContentProvider
import android.content.ContentValues
import android.content.Context
import android.database.Cursor
import android.database.MatrixCursor
import android.net.Uri
import android.os.ParcelFileDescriptor
import android.provider.OpenableColumns
import java.io.File
import java.io.FileNotFoundException

/**
 * Shares recorded logs with other apps (mail, drive) by content URI, read
 * only, without AndroidX's FileProvider: `content://io.fpbp.sample.logs/NAME`
 * serves `logs/NAME` from the app's external files folder. Only plain file
 * names in that folder resolve (no paths).
 */
class LogFileProvider : ContentProvider() {
    companion object {
        const val AUTHORITY = "io.fpbp.sample.logs"

        /** Folder the recorder writes to and the provider serves. */
        @JvmStatic
        fun logDir(context: Context): File = File(context.getExternalFilesDir(null) ?: context.filesDir, "logs")

        /** The content URI of a log in [logDir]. */
        @JvmStatic
        fun uriFor(file: File): Uri = Uri.Builder().scheme("content").authority(AUTHORITY).appendPath(file.name).build()
    }

    private fun fileOf(uri: Uri): File {
        val ctx = context ?: throw FileNotFoundException("no context")
        val name = uri.lastPathSegment ?: throw FileNotFoundException("$uri")
        if (uri.pathSegments.size != 1 || name.contains('/') || name.startsWith(".")) throw FileNotFoundException("$uri")
        val f = File(logDir(ctx), name)
        if (!f.isFile) throw FileNotFoundException("$uri")
        return f
    }

    override fun onCreate(): Boolean = true

    override fun getType(uri: Uri): String = "text/plain"

    override fun openFile(uri: Uri, mode: String): ParcelFileDescriptor {
        if (mode != "r") throw SecurityException("logs are read only")
        return ParcelFileDescriptor.open(fileOf(uri), ParcelFileDescriptor.MODE_READ_ONLY)
    }

    override fun query(uri: Uri, projection: Array<out String>?, selection: String?, selectionArgs: Array<out String>?, sortOrder: String?): Cursor {
        val f = fileOf(uri)
        val cols = projection ?: arrayOf(OpenableColumns.DISPLAY_NAME, OpenableColumns.SIZE)
        val row = cols.map { if (it == OpenableColumns.SIZE) f.length() else f.name }.toTypedArray()
        return MatrixCursor(cols).apply { addRow(row) }
    }

    override fun insert(uri: Uri, values: ContentValues?): Uri? = throw UnsupportedOperationException("read only")
    override fun delete(uri: Uri, selection: String?, selectionArgs: Array<out String>?): Int = 0
    override fun update(uri: Uri, values: ContentValues?, selection: String?, selectionArgs: Array<out String>?): Int = 0
}
