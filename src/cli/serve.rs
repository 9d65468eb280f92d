//! `wellmesh serve`: the HTTP API with (by default) embedded workers on SQLite.
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::sync::{Notify, watch};
use wellmesh::api::{self, ApiConfig, AppState};
use wellmesh::jobs::{self, JobMetrics, WorkerConfig, WorkerPool};
use wellmesh::process::ContourPipeline;

use super::worker::{WorkerArgs, init_tracing, shutdown_signal};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Address to listen on (port 0 picks a free port, printed at start).
    #[arg(long, default_value = "127.0.0.1:8080", env = "WELLMESH_BIND")]
    pub bind: SocketAddr,
    /// Directory of the embedded SQLite database (used without --database-url).
    #[arg(long, default_value = "wellmesh-data", env = "WELLMESH_DATA_DIR")]
    pub data_dir: PathBuf,
    /// `postgres://...` to share jobs with other nodes, or `sqlite://PATH`.
    #[arg(long, env = "WELLMESH_DATABASE_URL")]
    pub database_url: Option<String>,
    /// Jobs run at once by this process; 0 serves the API only.
    #[arg(long, default_value_t = 1, env = "WELLMESH_WORKERS")]
    pub workers: usize,
    /// Directory of the browser viewer.
    #[arg(long, default_value = "viewer", env = "WELLMESH_VIEWER_DIR")]
    pub viewer_dir: PathBuf,
    /// Largest request body, in MiB (413 beyond).
    #[arg(long, default_value_t = 64, env = "WELLMESH_MAX_BODY_MB")]
    pub max_body_mb: usize,
    /// Most samples per request (422 beyond).
    #[arg(long, default_value_t = 2_000_000, env = "WELLMESH_MAX_POINTS")]
    pub max_points: usize,
    /// Requests with at most this many samples run synchronously unless they send
    /// `Prefer: respond-async`.
    #[arg(long, default_value_t = 20_000, env = "WELLMESH_SYNC_MAX_POINTS")]
    pub sync_max_points: usize,
    /// Seconds a synchronous request waits before answering 201 (job continues).
    #[arg(long, default_value_t = 60, env = "WELLMESH_SYNC_WAIT_SECS")]
    pub sync_wait_secs: u64,
    /// Most jobs waiting in the queue (429 beyond); 0: no limit.
    #[arg(long, default_value_t = 100, env = "WELLMESH_MAX_QUEUED")]
    pub max_queued: i64,
    /// Bearer API key required on /jobs and executions (repeatable; comma-separated
    /// in the environment). None: no authentication.
    #[arg(long = "api-key", env = "WELLMESH_API_KEYS", value_delimiter = ',')]
    pub api_keys: Vec<String>,
    #[command(flatten)]
    pub worker: WorkerArgs,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    init_tracing(&args.worker.log_format);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(serve(args))?;
    Ok(ExitCode::SUCCESS)
}

async fn serve(args: Args) -> anyhow::Result<()> {
    let url = match &args.database_url {
        Some(url) => url.clone(),
        None => {
            std::fs::create_dir_all(&args.data_dir).with_context(|| {
                format!("creating the data directory {}", args.data_dir.display())
            })?;
            format!("sqlite://{}", args.data_dir.join("wellmesh.db").display())
        }
    };
    let store = jobs::open_store(&url)
        .await
        .with_context(|| format!("opening the job store {}", redact(&url)))?;
    let wake = Arc::new(Notify::new());
    let metrics = Arc::new(JobMetrics::default());
    let config = ApiConfig {
        max_body_bytes: args.max_body_mb.saturating_mul(1024 * 1024),
        max_points: args.max_points,
        sync_max_points: args.sync_max_points,
        sync_wait: Duration::from_secs(args.sync_wait_secs),
        max_queued: (args.max_queued > 0).then_some(args.max_queued),
        max_attempts: args.worker.max_attempts,
        api_keys: args
            .api_keys
            .into_iter()
            .filter(|k| !k.is_empty())
            .collect(),
        viewer_dir: args.viewer_dir,
    };
    let app = api::router(AppState {
        store: store.clone(),
        config: Arc::new(config),
        wake: wake.clone(),
        metrics: metrics.clone(),
    });
    let listener = tokio::net::TcpListener::bind(args.bind)
        .await
        .with_context(|| format!("binding {}", args.bind))?;
    let address = listener.local_addr()?;
    let pool = (args.workers > 0).then(|| {
        let config = WorkerConfig {
            concurrency: args.workers,
            ..args.worker.config()
        };
        WorkerPool::start(store, Arc::new(ContourPipeline), config, wake, metrics)
    });
    tracing::info!(%address, workers = args.workers, store = %redact(&url), "wellmesh serving");
    println!("wellmesh listening on http://{address}");
    let (stop, stopped) = watch::channel(false);
    tokio::spawn(async move {
        shutdown_signal().await;
        tracing::info!("shutting down: finishing or re-queueing running jobs");
        let _ = stop.send(true);
    });
    let mut server_stopped = stopped.clone();
    let server = axum::serve(listener, app).with_graceful_shutdown(async move {
        let _ = server_stopped.wait_for(|s| *s).await;
    });
    let mut workers_stopped = stopped;
    let workers = async move {
        let _ = workers_stopped.wait_for(|s| *s).await;
        if let Some(pool) = pool {
            pool.shutdown().await;
        }
    };
    let (served, ()) = tokio::join!(server, workers);
    served.context("serving HTTP")?;
    tracing::info!("stopped");
    Ok(())
}

/// The URL without its password, for logs and errors.
pub fn redact(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let credentials = &url[scheme + 3..at];
            match credentials.find(':') {
                Some(colon) => format!(
                    "{}{}:***{}",
                    &url[..scheme + 3],
                    &credentials[..colon],
                    &url[at..]
                ),
                None => url.to_string(),
            }
        }
        _ => url.to_string(),
    }
}
