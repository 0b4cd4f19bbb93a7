//! Errors of the bridge and the one table that turns them (and panics) into
//! Java exceptions.
//!
//! | Rust                          | Java                                   |
//! |-------------------------------|----------------------------------------|
//! | bad input, config, site, name | `java.lang.IllegalArgumentException`   |
//! | stale or stopped handle       | `java.lang.IllegalStateException`      |
//! | engine refuses the operation  | `java.lang.UnsupportedOperationException` |
//! | panic, poisoned lock, JNI bug | `io.fpbp.FpbpNativeException` (a `RuntimeException`) |
//!
//! In code that table is the section "The exception table" below: which
//! [`BridgeError`] each `fpbp_core::Error` variant becomes, and the Java
//! class of each `BridgeError` (the only place a class name is spelled; a
//! test checks it).

use jni::Env;
use jni::errors::ErrorPolicy;
use jni::strings::JNIString;

/// What went wrong in a native call, by the Java exception it becomes.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The caller passed something unusable (bad JSON, unknown engine, missing plan).
    #[error("{0}")]
    IllegalArgument(String),
    /// The handle is unknown: never started, already stopped, or forged.
    #[error("{0}")]
    IllegalState(String),
    /// The engine does not offer the operation (e.g. `setPosition`).
    #[error("{0}")]
    Unsupported(String),
    /// A bug or an earlier panic inside the native library.
    #[error("{0}")]
    Internal(String),
    /// A JNI call failed (usually a Java exception is already pending).
    #[error("JNI: {0}")]
    Jni(#[from] jni::errors::Error),
}

// ---- The exception table ----

impl From<fpbp_core::Error> for BridgeError {
    /// One row per core error variant, no `_` arm: a new variant does not
    /// compile until it is given its exception here. The message is the
    /// core error's text.
    fn from(e: fpbp_core::Error) -> Self {
        use fpbp_core::Error as E;
        let kind: fn(String) -> BridgeError = match &e {
            E::Site { .. } => BridgeError::IllegalArgument,
            E::Plan { .. } => BridgeError::IllegalArgument,
            E::Config { .. } => BridgeError::IllegalArgument,
            E::UnknownEngine(..) => BridgeError::IllegalArgument,
            E::Input(_) => BridgeError::IllegalArgument,
            E::Unsupported(_) => BridgeError::Unsupported,
            E::Bundle { .. } => BridgeError::IllegalArgument,
            E::Calibration(_) => BridgeError::IllegalArgument,
            E::Io { .. } => BridgeError::IllegalArgument,
        };
        kind(e.to_string())
    }
}

impl BridgeError {
    /// The Java class this error is thrown as (JNI binary name).
    pub fn java_class(&self) -> &'static str {
        match self {
            BridgeError::IllegalArgument(_) => "java/lang/IllegalArgumentException",
            BridgeError::IllegalState(_) => "java/lang/IllegalStateException",
            BridgeError::Unsupported(_) => "java/lang/UnsupportedOperationException",
            BridgeError::Internal(_) | BridgeError::Jni(_) => "io/fpbp/FpbpNativeException",
        }
    }
}

/// Thrown instead when the class of [`BridgeError::java_class`] cannot be
/// found (e.g. the Kotlin library is not on the class path).
pub const FALLBACK_CLASS: &str = "java/lang/RuntimeException";

// ---- end of the exception table ----

/// Longest run of caller input an exception message repeats, chars.
pub const MAX_ECHO_CHARS: usize = 200;

/// Longest exception message, chars (after [`clip_echoes`]).
pub const MAX_MESSAGE_CHARS: usize = 2000;

/// `s` itself when it has at most [`MAX_ECHO_CHARS`] chars, else its first
/// ones and how long it was: for messages that repeat caller input.
pub fn clip(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_ECHO_CHARS {
        return s.to_string();
    }
    let head: String = s.chars().take(MAX_ECHO_CHARS).collect();
    format!("{head}... ({n} chars)")
}

/// Clips every quoted run (between a pair of `` ` `` or `"`) longer than
/// [`MAX_ECHO_CHARS`]: core and serde errors quote the input they repeat
/// (unknown field names, string values). Then caps the whole message at
/// [`MAX_MESSAGE_CHARS`], saying how long it was.
pub fn clip_echoes(msg: &str) -> String {
    let chars: Vec<char> = msg.chars().collect();
    let mut out = String::with_capacity(msg.len().min(MAX_MESSAGE_CHARS + 64));
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        out.push(c);
        i += 1;
        if c != '`' && c != '"' {
            continue;
        }
        let end = chars[i..]
            .iter()
            .position(|&d| d == c)
            .map_or(chars.len(), |k| i + k);
        let run: String = chars[i..end].iter().collect();
        out.push_str(&clip(&run));
        if end < chars.len() {
            out.push(c);
        }
        i = end + 1;
    }
    let n = out.chars().count();
    if n <= MAX_MESSAGE_CHARS {
        return out;
    }
    let head: String = out.chars().take(MAX_MESSAGE_CHARS).collect();
    format!("{head}... (message cut, {n} chars)")
}

/// Text of a panic payload.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_string()
    }
}

/// Throws `class` with `msg`; falls back to [`FALLBACK_CLASS`] when the class
/// cannot be found.
/// jni 0.22's `throw_new` reports success as `Err(JavaException)` (the new
/// exception is pending), so that error is not a failure here.
fn throw(env: &mut Env<'_>, class: &str, msg: &str) -> jni::errors::Result<()> {
    use jni::errors::Error::JavaException;
    if env.exception_check() {
        return Ok(()); // an exception is already pending: it wins
    }
    let jmsg = JNIString::from(msg);
    match env.throw_new(JNIString::from(class), &jmsg) {
        Ok(()) | Err(JavaException) if env.exception_check() => Ok(()),
        _ => {
            env.exception_clear();
            match env.throw_new(JNIString::from(FALLBACK_CLASS), &jmsg) {
                Ok(()) | Err(JavaException) => Ok(()),
                Err(e) => Err(e),
            }
        }
    }
}

/// Logs (at `level`) and throws `err` as the exception of
/// [`BridgeError::java_class`], its message `fpbp <method>: <err>` with
/// echoes clipped ([`clip_echoes`]).
fn throw_error(
    env: &mut Env<'_>,
    method: &str,
    err: &BridgeError,
    level: log::Level,
) -> jni::errors::Result<()> {
    let msg = clip_echoes(&format!("fpbp {method}: {err}"));
    log::log!(level, "{msg}");
    throw(env, err.java_class(), &msg)
}

/// The error policy of every entry point: errors become the exception of
/// [`BridgeError::java_class`], panics an [`BridgeError::Internal`] one
/// (`FpbpNativeException`), and the native method returns its type's
/// default (0, false, null).
#[derive(Debug, Default)]
pub struct ThrowJava;

impl<T: Default> ErrorPolicy<T, BridgeError> for ThrowJava {
    type Captures<'unowned_env_local: 'native_method, 'native_method> = &'static str;

    fn on_error<'unowned_env_local: 'native_method, 'native_method>(
        env: &mut Env<'unowned_env_local>,
        method: &mut &'static str,
        err: BridgeError,
    ) -> jni::errors::Result<T> {
        if let BridgeError::Jni(jni::errors::Error::JavaException) = err {
            return Ok(T::default()); // pending Java exception propagates as is
        }
        throw_error(env, method, &err, log::Level::Debug)?;
        Ok(T::default())
    }

    fn on_panic<'unowned_env_local: 'native_method, 'native_method>(
        env: &mut Env<'unowned_env_local>,
        method: &mut &'static str,
        payload: Box<dyn std::any::Any + Send + 'static>,
    ) -> jni::errors::Result<T> {
        let err = BridgeError::Internal(format!(
            "internal panic: {}",
            panic_message(payload.as_ref())
        ));
        throw_error(env, method, &err, log::Level::Error)?;
        Ok(T::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_echoes_are_clipped_and_say_how_long_they_were() {
        assert_eq!(clip("short"), "short");
        let long = "x".repeat(10_000);
        let c = clip(&long);
        assert!(c.len() < 300 && c.ends_with("(10000 chars)"), "{c}");
        let msg = format!("unknown engine `{long}` (known: fpbp, bp); value \"{long}\" too");
        let m = clip_echoes(&msg);
        assert!(m.len() < 700, "{}", m.len());
        assert!(m.contains("(10000 chars)` (known: fpbp, bp)"), "{m}");
        assert!(m.ends_with("(10000 chars)\" too"), "{m}");
        // an unterminated quote is clipped too
        let m = clip_echoes(&format!("bad `{long}"));
        assert!(m.len() < 300 && m.ends_with("(10000 chars)"), "{m}");
        // short messages pass unchanged; a long unquoted one is capped
        assert_eq!(
            clip_echoes("fpbp start: `a` and \"b\""),
            "fpbp start: `a` and \"b\""
        );
        let m = clip_echoes(&"y ".repeat(5_000));
        assert!(
            m.chars().count() < MAX_MESSAGE_CHARS + 40 && m.ends_with("(message cut, 10000 chars)"),
            "{m}"
        );
    }

    /// Index of `e`'s variant in `fpbp_core::Error`. No `_` arm: a new
    /// variant does not compile until it is counted here (and then
    /// [`CORE_VARIANTS`] and the samples below must grow with it).
    fn core_variant(e: &fpbp_core::Error) -> usize {
        use fpbp_core::Error as E;
        match e {
            E::Site { .. } => 0,
            E::Plan { .. } => 1,
            E::Config { .. } => 2,
            E::UnknownEngine(..) => 3,
            E::Input(_) => 4,
            E::Unsupported(_) => 5,
            E::Bundle { .. } => 6,
            E::Calibration(_) => 7,
            E::Io { .. } => 8,
        }
    }

    const CORE_VARIANTS: usize = 9;

    #[test]
    fn every_core_error_variant_maps_to_its_java_class() {
        use fpbp_core::Error as E;
        let s = |x: &str| x.to_string();
        let illegal_argument = "java/lang/IllegalArgumentException";
        let samples = [
            (
                E::Site {
                    file: s("site.json"),
                    field: s("floors"),
                    msg: s("empty"),
                },
                illegal_argument,
            ),
            (
                E::Plan {
                    file: s("plan.png"),
                    msg: s("not a PNG"),
                },
                illegal_argument,
            ),
            (
                E::Config {
                    field: s("tasks.radio_period_ms"),
                    msg: s("0"),
                },
                illegal_argument,
            ),
            (E::UnknownEngine(s("x"), s("fpbp, tcpf")), illegal_argument),
            (E::Input(s("arity")), illegal_argument),
            (
                E::Unsupported(s("no reset")),
                "java/lang/UnsupportedOperationException",
            ),
            (
                E::Bundle {
                    at: s("header"),
                    msg: s("magic"),
                },
                illegal_argument,
            ),
            (E::Calibration(s("too few")), illegal_argument),
            (
                E::Io {
                    file: s("site.json"),
                    source: std::io::Error::other("gone"),
                },
                illegal_argument,
            ),
        ];
        let mut seen = [false; CORE_VARIANTS];
        for (e, class) in samples {
            seen[core_variant(&e)] = true;
            let text = e.to_string();
            let b = BridgeError::from(e);
            assert_eq!(b.java_class(), class, "{text}");
            assert_eq!(b.to_string(), text, "the message is the core error's text");
        }
        assert!(
            seen.iter().all(|&s| s),
            "a core variant without a sample: {seen:?}"
        );
    }

    #[test]
    fn bridge_errors_map_to_their_java_class() {
        let m = || "m".to_string();
        for (e, class) in [
            (
                BridgeError::IllegalArgument(m()),
                "java/lang/IllegalArgumentException",
            ),
            (
                BridgeError::IllegalState(m()),
                "java/lang/IllegalStateException",
            ),
            (
                BridgeError::Unsupported(m()),
                "java/lang/UnsupportedOperationException",
            ),
            (BridgeError::Internal(m()), "io/fpbp/FpbpNativeException"),
            (
                BridgeError::Jni(jni::errors::Error::NullPtr("x")),
                "io/fpbp/FpbpNativeException",
            ),
        ] {
            assert_eq!(e.java_class(), class);
        }
        assert_eq!(FALLBACK_CLASS, "java/lang/RuntimeException");
    }

    /// The exception table is the only place a Java class name is spelled:
    /// no other source file of the bridge names one, and error.rs (its code,
    /// not these tests) names each of the five once.
    #[test]
    fn class_names_appear_only_in_the_exception_table() {
        let class_literal =
            |src: &str| src.matches("\"java/").count() + src.matches("\"io/fpbp/").count();
        let others = [
            ("lib.rs", include_str!("lib.rs")),
            ("live.rs", include_str!("live.rs")),
            ("logging.rs", include_str!("logging.rs")),
            ("registry.rs", include_str!("registry.rs")),
            ("selftest.rs", include_str!("selftest.rs")),
            ("session.rs", include_str!("session.rs")),
            ("site_loader.rs", include_str!("site_loader.rs")),
        ];
        for (name, src) in others {
            assert_eq!(class_literal(src), 0, "{name} spells a Java class name");
        }
        let this = include_str!("error.rs");
        let code = &this[..this.find("#[cfg(test)]").expect("test module")];
        let table_start = code
            .find("// ---- The exception table ----")
            .expect("table start");
        let table_end = code
            .find("// ---- end of the exception table ----")
            .expect("table end");
        assert_eq!(class_literal(&code[..table_start]), 0);
        assert_eq!(class_literal(&code[table_start..table_end]), 5);
        assert_eq!(class_literal(&code[table_end..]), 0);
    }
}
