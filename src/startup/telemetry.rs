//! Telemetry: log lines on stderr, filtered by `RUST_LOG` (default `info`).
//!
//! Invariant: installing the subscriber twice is harmless (the second call is ignored),
//! so tests may start several applications in one process.

use tracing_subscriber::EnvFilter;

use super::LogFormat;

/// Installs the process's log subscriber: text or JSON lines on stderr.
pub fn init_telemetry(format: LogFormat) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Json => builder.json().try_init(),
        LogFormat::Text => builder.try_init(),
    };
}
