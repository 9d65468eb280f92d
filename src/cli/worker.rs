//! `wellmesh worker`: workers only, sharing a PostgreSQL (or SQLite) job store.
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::sync::Notify;
use wellmesh::jobs::{self, JobMetrics, WorkerConfig, WorkerPool};
use wellmesh::process::ContourPipeline;

use super::serve::redact;

/// Worker settings shared by `serve` and `worker`.
#[derive(Debug, Clone, clap::Args)]
pub struct WorkerArgs {
    /// Per-job run time limit, in seconds.
    #[arg(long, default_value_t = 1800, env = "WELLMESH_JOB_TIMEOUT_SECS")]
    pub job_timeout_secs: u64,
    /// Seconds a claimed job is held without a heartbeat before another worker may
    /// take it over.
    #[arg(long, default_value_t = 15, env = "WELLMESH_LEASE_SECS")]
    pub lease_secs: u64,
    /// Milliseconds between heartbeats (lease renewal and progress).
    #[arg(long, default_value_t = 1000, env = "WELLMESH_HEARTBEAT_MS")]
    pub heartbeat_ms: u64,
    /// Times a job may be started before lost leases fail it.
    #[arg(long, default_value_t = 3, env = "WELLMESH_MAX_ATTEMPTS")]
    pub max_attempts: i64,
    /// On SIGTERM/ctrl-c, seconds running jobs may take to finish before they are
    /// put back in the queue.
    #[arg(long, default_value_t = 20, env = "WELLMESH_SHUTDOWN_GRACE_SECS")]
    pub shutdown_grace_secs: u64,
    /// Log format: text or json.
    #[arg(long, default_value = "text", env = "WELLMESH_LOG_FORMAT")]
    pub log_format: String,
}

impl WorkerArgs {
    pub fn config(&self) -> WorkerConfig {
        WorkerConfig {
            lease: Duration::from_secs(self.lease_secs.max(1)),
            heartbeat: Duration::from_millis(self.heartbeat_ms.max(50)),
            time_limit: Duration::from_secs(self.job_timeout_secs.max(1)),
            shutdown_grace: Duration::from_secs(self.shutdown_grace_secs),
            ..WorkerConfig::default()
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The shared job store: `postgres://...` (or `sqlite://PATH` on one machine).
    #[arg(long, env = "WELLMESH_DATABASE_URL")]
    pub database_url: String,
    /// Jobs run at once by this process.
    #[arg(long, default_value_t = 1, env = "WELLMESH_WORKERS")]
    pub workers: usize,
    #[command(flatten)]
    pub worker: WorkerArgs,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    init_tracing(&args.worker.log_format);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(async move {
        let store = jobs::open_store(&args.database_url)
            .await
            .with_context(|| format!("opening the job store {}", redact(&args.database_url)))?;
        let config = WorkerConfig {
            concurrency: args.workers.max(1),
            ..args.worker.config()
        };
        tracing::info!(name = %config.name, workers = config.concurrency, "wellmesh worker started");
        let pool = WorkerPool::start(
            store,
            Arc::new(ContourPipeline),
            config,
            Arc::new(Notify::new()),
            Arc::new(JobMetrics::default()),
        );
        shutdown_signal().await;
        tracing::info!("shutting down: finishing or re-queueing running jobs");
        pool.shutdown().await;
        anyhow::Ok(())
    })?;
    Ok(ExitCode::SUCCESS)
}

/// Logs to stderr, `RUST_LOG` filtered (default `info`), as text or JSON lines.
pub fn init_tracing(format: &str) {
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    let _ = if format.eq_ignore_ascii_case("json") {
        builder.json().try_init()
    } else {
        builder.try_init()
    };
}

/// Resolves on ctrl-c or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = terminate => {}
    }
}
