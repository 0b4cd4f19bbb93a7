//! JNI surface of fpbp (being implemented).
