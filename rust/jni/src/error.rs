//! Errors of the bridge and the one policy that turns them (and panics) into
//! Java exceptions.
//!
//! | Rust                          | Java                                   |
//! |-------------------------------|----------------------------------------|
//! | bad input, config, site, name | `java.lang.IllegalArgumentException`   |
//! | stale or stopped handle       | `java.lang.IllegalStateException`      |
//! | engine refuses the operation  | `java.lang.UnsupportedOperationException` |
//! | panic, poisoned lock, JNI bug | `io.fpbp.FpbpNativeException` (a `RuntimeException`) |

use jni::Env;
use jni::errors::ErrorPolicy;
use jni::strings::JNIString;

/// Java class thrown for internal errors (defined in the Kotlin library).
pub const INTERNAL_EXCEPTION_CLASS: &str = "io/fpbp/FpbpNativeException";

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

impl From<fpbp_core::Error> for BridgeError {
    fn from(e: fpbp_core::Error) -> Self {
        BridgeError::IllegalArgument(e.to_string())
    }
}

impl BridgeError {
    /// The Java class this error is thrown as (JNI binary name).
    pub fn java_class(&self) -> &'static str {
        match self {
            BridgeError::IllegalArgument(_) => "java/lang/IllegalArgumentException",
            BridgeError::IllegalState(_) => "java/lang/IllegalStateException",
            BridgeError::Unsupported(_) => "java/lang/UnsupportedOperationException",
            BridgeError::Internal(_) | BridgeError::Jni(_) => INTERNAL_EXCEPTION_CLASS,
        }
    }
}

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

/// Throws `class` with `msg`; falls back to `java.lang.RuntimeException` when
/// the class cannot be found (e.g. the Kotlin library is not on the class path).
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
            match env.throw_new(JNIString::from("java/lang/RuntimeException"), &jmsg) {
                Ok(()) | Err(JavaException) => Ok(()),
                Err(e) => Err(e),
            }
        }
    }
}

/// The error policy of every entry point: errors become the exception of
/// [`BridgeError::java_class`], panics become `FpbpNativeException`, and the
/// native method returns its type's default (0, null).
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
        let msg = clip_echoes(&format!("fpbp {method}: {err}"));
        log::debug!("{msg}");
        throw(env, err.java_class(), &msg)?;
        Ok(T::default())
    }

    fn on_panic<'unowned_env_local: 'native_method, 'native_method>(
        env: &mut Env<'unowned_env_local>,
        method: &mut &'static str,
        payload: Box<dyn std::any::Any + Send + 'static>,
    ) -> jni::errors::Result<T> {
        let msg = clip_echoes(&format!(
            "fpbp {method}: internal panic: {}",
            panic_message(payload.as_ref())
        ));
        log::error!("{msg}");
        throw(env, INTERNAL_EXCEPTION_CLASS, &msg)?;
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
}
