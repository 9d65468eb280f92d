//! Flags that `wellmesh serve` and `wellmesh worker` share (worker timings, logging),
//! their defaults read from the library's [`Settings::default`], and the runtime both
//! start on.
use std::sync::LazyLock;
use std::time::Duration;

use anyhow::Context;
use wellmesh::startup::{LogFormat, Settings};

/// The library's defaults, which every flag below and in `serve`/`worker` shows.
pub static DEFAULTS: LazyLock<Settings> = LazyLock::new(Settings::default);

/// Worker and logging settings shared by `serve` and `worker`.
#[derive(Debug, Clone, clap::Args)]
pub struct WorkerArgs {
    /// Per-job run time limit, in seconds.
    #[arg(long, default_value_t = DEFAULTS.worker.time_limit.as_secs(), env = "WELLMESH_JOB_TIMEOUT_SECS")]
    pub job_timeout_secs: u64,
    /// Seconds a claimed job is held without a heartbeat before another worker may
    /// take it over.
    #[arg(long, default_value_t = DEFAULTS.worker.lease.as_secs(), env = "WELLMESH_LEASE_SECS")]
    pub lease_secs: u64,
    /// Milliseconds between heartbeats (lease renewal and progress).
    #[arg(long, default_value_t = DEFAULTS.worker.heartbeat.as_millis() as u64, env = "WELLMESH_HEARTBEAT_MS")]
    pub heartbeat_ms: u64,
    /// Times a job may be started before lost leases fail it.
    #[arg(long, default_value_t = DEFAULTS.api.max_attempts, env = "WELLMESH_MAX_ATTEMPTS")]
    pub max_attempts: i64,
    /// On SIGTERM/ctrl-c, seconds running jobs may take to finish before they are
    /// put back in the queue.
    #[arg(long, default_value_t = DEFAULTS.worker.shutdown_grace.as_secs(), env = "WELLMESH_SHUTDOWN_GRACE_SECS")]
    pub shutdown_grace_secs: u64,
    /// Log format: text or json.
    #[arg(long, default_value = DEFAULTS.log_format.name(), env = "WELLMESH_LOG_FORMAT")]
    pub log_format: String,
}

impl WorkerArgs {
    /// Writes these flags into `settings` (a lease of at least 1 s, heartbeats at least
    /// 50 ms apart, a time limit of at least 1 s).
    pub fn apply(&self, settings: &mut Settings) {
        settings.worker.lease = Duration::from_secs(self.lease_secs.max(1));
        settings.worker.heartbeat = Duration::from_millis(self.heartbeat_ms.max(50));
        settings.worker.time_limit = Duration::from_secs(self.job_timeout_secs.max(1));
        settings.worker.shutdown_grace = Duration::from_secs(self.shutdown_grace_secs);
        settings.api.max_attempts = self.max_attempts;
        settings.log_format = LogFormat::from_name(&self.log_format);
    }
}

/// A multi-threaded tokio runtime for a service process.
pub fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}
