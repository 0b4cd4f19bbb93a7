//! Errors of the bridge and the one policy that turns them (and panics) into
//! Java exceptions.
//!
//! | Rust                          | Java                                   |
//! |-------------------------------|----------------------------------------|
//! | bad input, config, site, name | `java.lang.IllegalArgumentException`   |
//! | stale or stopped handle       | `java.lang.IllegalStateException`      |
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
            BridgeError::Internal(_) | BridgeError::Jni(_) => INTERNAL_EXCEPTION_CLASS,
        }
    }
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
        let msg = format!("fpbp {method}: {err}");
        log::debug!("{msg}");
        throw(env, err.java_class(), &msg)?;
        Ok(T::default())
    }

    fn on_panic<'unowned_env_local: 'native_method, 'native_method>(
        env: &mut Env<'unowned_env_local>,
        method: &mut &'static str,
        payload: Box<dyn std::any::Any + Send + 'static>,
    ) -> jni::errors::Result<T> {
        let msg = format!(
            "fpbp {method}: internal panic: {}",
            panic_message(payload.as_ref())
        );
        log::error!("{msg}");
        throw(env, INTERNAL_EXCEPTION_CLASS, &msg)?;
        Ok(T::default())
    }
}
