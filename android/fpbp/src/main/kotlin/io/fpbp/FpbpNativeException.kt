package io.fpbp

/** An internal error of the native library (a bug or a caught panic), thrown by libfpbp. */
class FpbpNativeException(message: String) : RuntimeException(message)
