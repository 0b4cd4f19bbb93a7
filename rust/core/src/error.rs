//! Typed errors of the core. Messages name the file, field or value at fault.

use thiserror::Error;

/// Every fallible operation of the core returns this error.
#[derive(Debug, Error)]
pub enum Error {
    /// A site file (site.json) is invalid: `file` names it, `field` the JSON path.
    #[error("{file}: field `{field}`: {msg}")]
    Site {
        file: String,
        field: String,
        msg: String,
    },
    /// A floor plan image could not be used.
    #[error("{file}: {msg}")]
    Plan { file: String, msg: String },
    /// A configuration value is out of range: `field` is its dotted path.
    #[error("config field `{field}`: {msg}")]
    Config { field: String, msg: String },
    /// An engine name that does not exist.
    #[error("unknown engine `{0}` (known: {1})")]
    UnknownEngine(String, String),
    /// Bad input handed to an engine (e.g. a sensor event with the wrong arity).
    #[error("invalid input: {0}")]
    Input(String),
    /// An operation the engine does not offer (e.g. `set_position` on an
    /// engine without a way to move its state to a given point).
    #[error("{0}")]
    Unsupported(String),
    /// A site bundle (`fpbp bundle`) is malformed: `at` names the header
    /// field, manifest field (`manifest.entries[2].size`) or entry
    /// (`entry radio-map.json.gz`) at fault.
    #[error("bundle: {at}: {msg}")]
    Bundle { at: String, msg: String },
    /// Calibration could not produce a result.
    #[error("calibration: {0}")]
    Calibration(String),
    /// A file could not be read (the `fs` feature's site loader): `file`
    /// names it.
    #[error("{file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
}

/// Result alias of the core.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A config error whose field path gains `prefix` (a section validated
    /// on its own names its fields from the section: `fingerprint.x` becomes
    /// `ekf.fingerprint.x`); other errors are unchanged.
    pub fn within(self, prefix: &str) -> Self {
        match self {
            Error::Config { field, msg } => Error::Config {
                field: format!("{prefix}{field}"),
                msg,
            },
            e => e,
        }
    }

    /// Shorthand for a configuration error.
    pub fn config(field: impl Into<String>, msg: impl Into<String>) -> Self {
        Error::Config {
            field: field.into(),
            msg: msg.into(),
        }
    }
}
