//! Typed errors of the log readers. Every message names the file and, for
//! content errors, the 1-based line.

use thiserror::Error;

/// Errors of [`crate::open_log`] and [`crate::LogReader`].
#[derive(Debug, Error)]
pub enum LogError {
    /// The file could not be opened or read (including a corrupt gzip stream).
    #[error("{file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// The first lines match none of the known formats.
    #[error(
        "{file}: unknown log format (expected a native `#fpbp-log 1|2` header, an ILC trace or an IPIN GetSensorData logfile)"
    )]
    UnknownFormat { file: String },
    /// A native log declares a version this reader does not know.
    #[error(
        "{file}:{line}: native log version `{version}` is not supported (this reader knows 1 and 2)"
    )]
    UnsupportedVersion {
        file: String,
        line: u64,
        version: String,
    },
    /// A malformed line (strict mode only; the lenient mode skips and counts it).
    #[error("{file}:{line}: {msg}")]
    Malformed {
        file: String,
        line: u64,
        msg: String,
    },
}
