//! Service startup: the two processes the binary runs, built from [`Settings`] —
//! [`Application`] (the HTTP API with embedded workers) and [`WorkerNode`] (workers
//! only, sharing a job database) — and the telemetry they log through.
//!
//! Invariant: `build` opens the store and binds the listener before anything runs, so a
//! bind error or a database that cannot be migrated fails the start, and port 0 works
//! (the bound address is known before the first request). Stopping stops accepting
//! work first, then lets running jobs finish within the grace period or re-queues them.

mod edge;
mod settings;
mod telemetry;

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::net::TcpListener;
use tokio::sync::{Notify, watch};

use crate::api::{self, AppState};
use crate::jobs::{self, JobMetrics, JobStore, Pipeline, WorkerConfig, WorkerPool};
use crate::process::ContourPipeline;

pub use settings::{EdgeLimits, LogFormat, Settings, redact_url};
pub use telemetry::init_telemetry;

/// The HTTP API over the job store, with `settings.worker.concurrency` embedded workers.
pub struct Application {
    listener: TcpListener,
    address: SocketAddr,
    state: AppState,
    pipeline: Arc<dyn Pipeline>,
    worker: WorkerConfig,
    store_url: String,
    edge: EdgeLimits,
    retention: Option<Duration>,
}

impl Application {
    /// Opens (and migrates) the store and binds the listener; runs the contour pipeline.
    pub async fn build(settings: Settings) -> anyhow::Result<Application> {
        Self::build_with_pipeline(settings, Arc::new(ContourPipeline)).await
    }

    /// As [`Application::build`], with the pipeline the workers run (tests use this to
    /// control a job's outcome and duration).
    pub async fn build_with_pipeline(
        settings: Settings,
        pipeline: Arc<dyn Pipeline>,
    ) -> anyhow::Result<Application> {
        let store_url = settings.store_url()?;
        let store = open_store(&store_url).await?;
        let listener = TcpListener::bind(settings.bind)
            .await
            .with_context(|| format!("binding {}", settings.bind))?;
        let address = listener.local_addr().context("reading the bound address")?;
        let state = AppState::new(store, settings.api);
        Ok(Application {
            listener,
            address,
            state,
            pipeline,
            worker: settings.worker,
            store_url: redact_url(&store_url),
            edge: settings.edge,
            retention: settings.retention,
        })
    }

    /// The address the API listens on (with the port picked when 0 was asked for).
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    pub fn port(&self) -> u16 {
        self.address.port()
    }

    /// The job store this application serves.
    pub fn store(&self) -> Arc<dyn JobStore> {
        self.state.store.clone()
    }

    /// Serves until ctrl-c or SIGTERM, then shuts down gracefully.
    pub async fn run_until_stopped(self) -> anyhow::Result<()> {
        self.run_until(shutdown_signal()).await
    }

    /// Serves until `stop` resolves, then stops accepting connections, lets requests in
    /// flight finish, and stops the workers (their running jobs finish within the grace
    /// period or go back to the queue). Connections still open after the shutdown
    /// deadline are dropped.
    pub async fn run_until(
        self,
        stop: impl Future<Output = ()> + Send + 'static,
    ) -> anyhow::Result<()> {
        let Application {
            listener,
            address,
            state,
            pipeline,
            worker,
            store_url,
            edge,
            retention,
        } = self;
        let workers = worker.concurrency;
        let pool = (workers > 0).then(|| {
            WorkerPool::start(
                state.store.clone(),
                pipeline,
                worker,
                state.wake.clone(),
                state.metrics.clone(),
            )
        });
        let (stopping, stopped) = watch::channel(false);
        if let Some(retention) = retention {
            tokio::spawn(sweep_finished_jobs(
                state.store.clone(),
                retention,
                stopped.clone(),
            ));
        }
        let app = api::router(state);
        tracing::info!(%address, workers, store = %store_url, "wellmesh serving");
        tokio::spawn(async move {
            stop.await;
            tracing::info!("shutting down: finishing or re-queueing running jobs");
            let _ = stopping.send(true);
        });
        let server = edge::serve(listener, app, edge, stopped.clone());
        let mut workers_stopped = stopped;
        let workers = async move {
            let _ = workers_stopped.wait_for(|s| *s).await;
            if let Some(pool) = pool {
                pool.shutdown().await;
            }
        };
        tokio::join!(server, workers);
        tracing::info!("stopped");
        Ok(())
    }
}

/// Deletes finished jobs older than `retention`, at start and then every
/// [`sweep_period`] of it, until `stopped`.
async fn sweep_finished_jobs(
    store: Arc<dyn JobStore>,
    retention: Duration,
    mut stopped: watch::Receiver<bool>,
) {
    let period = sweep_period(retention);
    loop {
        let cutoff = jobs::now_ms() - retention.as_millis() as i64;
        match store.delete_finished_before(cutoff).await {
            Ok(0) => {}
            Ok(deleted) => tracing::info!(deleted, "retention sweep deleted finished jobs"),
            Err(e) => tracing::warn!(error = %e, "retention sweep failed; will retry"),
        }
        tokio::select! {
            _ = tokio::time::sleep(period) => {}
            _ = until_stopped(&mut stopped) => return,
        }
    }
}

/// Resolves once `stopped` turns true (or its sender is gone).
async fn until_stopped(stopped: &mut watch::Receiver<bool>) {
    let _ = stopped.wait_for(|s| *s).await;
}

/// A tenth of the retention period, between 1 s and 10 minutes.
fn sweep_period(retention: Duration) -> Duration {
    (retention / 10).clamp(Duration::from_secs(1), Duration::from_secs(600))
}

/// Workers only: claims jobs from a shared store until stopped.
pub struct WorkerNode {
    store: Arc<dyn JobStore>,
    pipeline: Arc<dyn Pipeline>,
    worker: WorkerConfig,
}

impl WorkerNode {
    /// Opens (and migrates) the store; runs the contour pipeline with at least one worker.
    pub async fn build(settings: Settings) -> anyhow::Result<WorkerNode> {
        Self::build_with_pipeline(settings, Arc::new(ContourPipeline)).await
    }

    /// As [`WorkerNode::build`], with the pipeline the workers run.
    pub async fn build_with_pipeline(
        settings: Settings,
        pipeline: Arc<dyn Pipeline>,
    ) -> anyhow::Result<WorkerNode> {
        let store = open_store(&settings.store_url()?).await?;
        let worker = WorkerConfig {
            concurrency: settings.worker.concurrency.max(1),
            ..settings.worker
        };
        Ok(WorkerNode {
            store,
            pipeline,
            worker,
        })
    }

    /// Works until ctrl-c or SIGTERM, then shuts down gracefully.
    pub async fn run_until_stopped(self) -> anyhow::Result<()> {
        self.run_until(shutdown_signal()).await
    }

    /// Works until `stop` resolves; running jobs then finish within the grace period or
    /// go back to the queue.
    pub async fn run_until(self, stop: impl Future<Output = ()>) -> anyhow::Result<()> {
        tracing::info!(
            name = %self.worker.name,
            workers = self.worker.concurrency,
            "wellmesh worker started"
        );
        let pool = WorkerPool::start(
            self.store,
            self.pipeline,
            self.worker,
            Arc::new(Notify::new()),
            Arc::new(JobMetrics::default()),
        );
        stop.await;
        tracing::info!("shutting down: finishing or re-queueing running jobs");
        pool.shutdown().await;
        Ok(())
    }
}

async fn open_store(url: &str) -> anyhow::Result<Arc<dyn JobStore>> {
    jobs::open_store(url)
        .await
        .with_context(|| format!("opening the job store {}", redact_url(url)))
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
