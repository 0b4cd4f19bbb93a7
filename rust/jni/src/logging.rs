//! Logger set-up, once per process: logcat (tag `fpbp`) on Android,
//! env_logger (`RUST_LOG`, default `warn`) on a desktop JVM.

use std::sync::Once;

static INIT: Once = Once::new();

/// Installs the platform logger on first call; later calls do nothing.
pub fn init() {
    INIT.call_once(|| {
        #[cfg(target_os = "android")]
        android_logger::init_once(
            android_logger::Config::default()
                .with_max_level(log::LevelFilter::Info)
                .with_tag("fpbp"),
        );
        #[cfg(not(target_os = "android"))]
        {
            // Another logger may already be installed by the host: keep it.
            let _ =
                env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
                    .try_init();
        }
    });
}
