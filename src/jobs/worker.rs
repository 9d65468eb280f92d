//! Workers: claim jobs, run the pipeline on rayon, heartbeat the lease, store results.
//!
//! Invariant: at most `concurrency` jobs of one pool are held at once; a job's
//! computation is cancelled as soon as its lease is lost, it is dismissed, or it runs
//! past the time limit; on shutdown a job still running after the grace period is put
//! back in the queue (not failed), so another worker finishes it.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::{Notify, oneshot, watch};
use tokio::task::JoinHandle;
use tracing::{Instrument, error, info, info_span, warn};

use super::{FailureKind, JobFailure, JobStore, Lease, Pipeline, cap_message, now_ms};
use crate::progress::{Progress, Stage};

/// The message a job keeps when it failed for an internal reason; the cause itself is
/// only logged, with the job id.
pub const INTERNAL_FAILURE: &str =
    "internal error while computing this job; the cause is logged with its job id";

/// How a pool of workers behaves.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    /// Jobs this pool runs at once.
    pub concurrency: usize,
    /// How long a claim holds a job without a heartbeat.
    pub lease: Duration,
    /// How often a running job renews its lease and records its progress.
    pub heartbeat: Duration,
    /// How often an idle worker looks for work (it is also woken on local submits).
    pub poll: Duration,
    /// Per-job run time limit.
    pub time_limit: Duration,
    /// On shutdown, how long running jobs may take to finish before being re-queued.
    pub shutdown_grace: Duration,
    /// Name recorded as the lease owner.
    pub name: String,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            concurrency: 1,
            lease: Duration::from_secs(15),
            heartbeat: Duration::from_secs(1),
            poll: Duration::from_millis(500),
            time_limit: Duration::from_secs(30 * 60),
            shutdown_grace: Duration::from_secs(20),
            name: default_worker_name(),
        }
    }
}

/// `HOST-PID-XXXX`: unique per process, readable in logs.
pub fn default_worker_name() -> String {
    let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "worker".to_string());
    let suffix = uuid::Uuid::new_v4().simple().to_string();
    format!("{host}-{}-{}", std::process::id(), &suffix[..6])
}

/// Job outcomes and run times seen by the workers of this process (Prometheus).
#[derive(Debug, Default)]
pub struct JobMetrics {
    inner: Mutex<MetricsInner>,
}

#[derive(Debug, Default)]
struct MetricsInner {
    outcomes: BTreeMap<&'static str, u64>,
    bucket_counts: [u64; DURATION_BUCKETS_S.len()],
    count: u64,
    sum_s: f64,
}

const DURATION_BUCKETS_S: [f64; 12] = [
    0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0,
];

impl JobMetrics {
    fn record(&self, outcome: &'static str, seconds: f64) {
        let mut inner = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        *inner.outcomes.entry(outcome).or_default() += 1;
        for (bound, count) in DURATION_BUCKETS_S
            .iter()
            .zip(inner.bucket_counts.iter_mut())
        {
            if seconds <= *bound {
                *count += 1;
            }
        }
        inner.count += 1;
        inner.sum_s += seconds;
    }

    /// Appends the Prometheus text exposition of these metrics.
    pub fn render(&self, out: &mut String) {
        let inner = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let _ = writeln!(
            out,
            "# HELP wellmesh_jobs_finished_total Jobs finished by this process's workers, by outcome."
        );
        let _ = writeln!(out, "# TYPE wellmesh_jobs_finished_total counter");
        for outcome in [
            "successful",
            "failed",
            "dismissed",
            "lease_lost",
            "requeued",
        ] {
            let n = inner.outcomes.get(outcome).copied().unwrap_or(0);
            let _ = writeln!(
                out,
                "wellmesh_jobs_finished_total{{outcome=\"{outcome}\"}} {n}"
            );
        }
        let _ = writeln!(
            out,
            "# HELP wellmesh_job_duration_seconds Run time of jobs run by this process's workers."
        );
        let _ = writeln!(out, "# TYPE wellmesh_job_duration_seconds histogram");
        for (bound, count) in DURATION_BUCKETS_S.iter().zip(inner.bucket_counts.iter()) {
            let _ = writeln!(
                out,
                "wellmesh_job_duration_seconds_bucket{{le=\"{bound}\"}} {count}"
            );
        }
        let _ = writeln!(
            out,
            "wellmesh_job_duration_seconds_bucket{{le=\"+Inf\"}} {}",
            inner.count
        );
        let _ = writeln!(out, "wellmesh_job_duration_seconds_sum {}", inner.sum_s);
        let _ = writeln!(out, "wellmesh_job_duration_seconds_count {}", inner.count);
    }
}

/// A running pool of workers; drop it only after [`WorkerPool::shutdown`].
#[derive(Debug)]
pub struct WorkerPool {
    handles: Vec<JoinHandle<()>>,
    stop: watch::Sender<bool>,
}

impl WorkerPool {
    /// Starts `config.concurrency` workers on the current tokio runtime. `wake` is
    /// notified by local submitters so an idle worker starts at once.
    pub fn start(
        store: Arc<dyn JobStore>,
        pipeline: Arc<dyn Pipeline>,
        config: WorkerConfig,
        wake: Arc<Notify>,
        metrics: Arc<JobMetrics>,
    ) -> WorkerPool {
        let (stop, stopped) = watch::channel(false);
        let config = Arc::new(config);
        let handles = (0..config.concurrency.max(1))
            .map(|slot| {
                let worker = Worker {
                    store: store.clone(),
                    pipeline: pipeline.clone(),
                    config: config.clone(),
                    wake: wake.clone(),
                    metrics: metrics.clone(),
                    stopped: stopped.clone(),
                    name: format!("{}/{slot}", config.name),
                };
                tokio::spawn(worker.run())
            })
            .collect();
        WorkerPool { handles, stop }
    }

    /// Stops claiming, lets running jobs finish within the grace period (re-queueing
    /// the others), and waits for every worker to end.
    pub async fn shutdown(self) {
        let _ = self.stop.send(true);
        for handle in self.handles {
            if let Err(e) = handle.await {
                error!(error = %e, "worker task ended abnormally");
            }
        }
    }
}

struct Worker {
    store: Arc<dyn JobStore>,
    pipeline: Arc<dyn Pipeline>,
    config: Arc<WorkerConfig>,
    wake: Arc<Notify>,
    metrics: Arc<JobMetrics>,
    stopped: watch::Receiver<bool>,
    name: String,
}

impl Worker {
    async fn run(mut self) {
        let lease_ms = self.config.lease.as_millis() as i64;
        loop {
            if *self.stopped.borrow() {
                return;
            }
            match self
                .store
                .claim_next_job(&self.name, now_ms(), lease_ms)
                .await
            {
                Ok(Some(job)) => {
                    let span =
                        info_span!("job", job_id = %job.lease.job_id, attempt = job.lease.attempt);
                    self.run_job(job.lease, &job.inputs).instrument(span).await;
                }
                Ok(None) => {
                    tokio::select! {
                        _ = self.wake.notified() => {}
                        _ = tokio::time::sleep(self.config.poll) => {}
                        _ = self.stopped.changed() => {}
                    }
                }
                Err(e) => {
                    warn!(error = %e, "could not claim a job");
                    tokio::select! {
                        _ = tokio::time::sleep(self.config.poll * 4) => {}
                        _ = self.stopped.changed() => {}
                    }
                }
            }
        }
    }

    async fn run_job(&mut self, lease: Lease, inputs: &[u8]) {
        let lease_ms = self.config.lease.as_millis() as i64;
        let started = Instant::now();
        let inputs = inputs.to_vec();
        info!("job started");
        let tracker = Arc::new(JobProgress::new(started + self.config.time_limit));
        let (sender, mut receiver) = oneshot::channel();
        {
            let pipeline = self.pipeline.clone();
            let tracker = tracker.clone();
            let span = tracing::Span::current();
            rayon::spawn(move || {
                let _entered = span.enter();
                let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| {
                    pipeline.run(&inputs, tracker.as_ref())
                }));
                let _ = sender.send(outcome);
            });
        }
        let mut beat = tokio::time::interval(self.config.heartbeat);
        beat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut stopped = self.stopped.clone();
        let grace = self.config.shutdown_grace;
        let shutdown_deadline = async move {
            while !*stopped.borrow() {
                if stopped.changed().await.is_err() {
                    std::future::pending::<()>().await;
                }
            }
            tokio::time::sleep(grace).await;
        };
        tokio::pin!(shutdown_deadline);
        let outcome = loop {
            tokio::select! {
                outcome = &mut receiver => break outcome,
                _ = beat.tick() => {
                    if tracker.timed_out() {
                        // The pipeline was told to stop; do not wait for it to notice.
                        tracker.cancel();
                        let message = format!(
                            "ran past the time limit of {} s",
                            self.config.time_limit.as_secs()
                        );
                        self.finish_failed(lease, FailureKind::Timeout, None, &message, started).await;
                        return;
                    }
                    let (percent, message) = tracker.snapshot();
                    match self.store.record_heartbeat(lease, percent, &message, now_ms(), lease_ms).await {
                        Ok(true) => {}
                        Ok(false) => {
                            tracker.cancel();
                            info!("lease lost (job dismissed or re-queued); computation cancelled");
                            self.metrics.record("lease_lost", started.elapsed().as_secs_f64());
                            return;
                        }
                        Err(e) => warn!(error = %e, "heartbeat failed; will retry"),
                    }
                }
                _ = &mut shutdown_deadline => {
                    tracker.cancel();
                    match self.store.release(lease, now_ms()).await {
                        Ok(true) => info!("shutting down: job re-queued"),
                        Ok(false) => info!("shutting down: lease already lost"),
                        Err(e) => warn!(error = %e, "shutting down: could not re-queue; its lease will expire"),
                    }
                    self.metrics.record("requeued", started.elapsed().as_secs_f64());
                    return;
                }
            }
        };
        match outcome {
            Ok(Ok(Ok(outputs))) => {
                match self.store.mark_succeeded(lease, &outputs, now_ms()).await {
                    Ok(true) => {
                        info!(seconds = started.elapsed().as_secs_f64(), "job successful");
                        self.metrics
                            .record("successful", started.elapsed().as_secs_f64());
                    }
                    Ok(false) => {
                        info!("job finished after its lease was lost; result dropped");
                        self.metrics
                            .record("lease_lost", started.elapsed().as_secs_f64());
                    }
                    Err(e) => {
                        error!(error = %e, "could not store the results; the lease will expire and the job run again");
                    }
                }
            }
            Ok(Ok(Err(JobFailure::Cancelled))) if tracker.timed_out() => {
                let message = format!(
                    "ran past the time limit of {} s",
                    self.config.time_limit.as_secs()
                );
                self.finish_failed(lease, FailureKind::Timeout, None, &message, started)
                    .await;
            }
            Ok(Ok(Err(JobFailure::Cancelled))) => {
                self.finish_internal(
                    lease,
                    "the pipeline stopped without being asked to",
                    started,
                )
                .await;
            }
            Ok(Ok(Err(JobFailure::Input { field, message }))) => {
                self.finish_failed(
                    lease,
                    FailureKind::Input,
                    field.as_deref(),
                    &message,
                    started,
                )
                .await;
            }
            Ok(Ok(Err(JobFailure::Internal(cause)))) => {
                self.finish_internal(lease, &cause, started).await;
            }
            Ok(Err(panic)) => {
                let detail = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                self.finish_internal(lease, &format!("the pipeline panicked: {detail}"), started)
                    .await;
            }
            Err(_) => {
                self.finish_internal(lease, "the computation ended without an answer", started)
                    .await;
            }
        }
    }

    /// Records a failure the user cannot fix: the cause is logged (with the job id, from
    /// the span), the job keeps only [`INTERNAL_FAILURE`].
    async fn finish_internal(&self, lease: Lease, cause: &str, started: Instant) {
        error!(%cause, "job failed: internal error");
        self.finish_failed(
            lease,
            FailureKind::Internal,
            None,
            INTERNAL_FAILURE,
            started,
        )
        .await;
    }

    /// Records a failure; the message is capped at [`super::MAX_MESSAGE_BYTES`].
    async fn finish_failed(
        &self,
        lease: Lease,
        kind: FailureKind,
        field: Option<&str>,
        message: &str,
        started: Instant,
    ) {
        let message = cap_message(message);
        match self
            .store
            .mark_failed(lease, kind, field, &message, now_ms())
            .await
        {
            Ok(true) => {
                info!(failure = kind.as_str(), field, %message, "job failed");
                self.metrics
                    .record("failed", started.elapsed().as_secs_f64());
            }
            Ok(false) => {
                info!("job failed after its lease was lost; nothing recorded");
                self.metrics
                    .record("lease_lost", started.elapsed().as_secs_f64());
            }
            Err(e) => error!(error = %e, "could not record the failure"),
        }
    }
}

/// The [`Progress`] handed to the pipeline: records stage and percent for the next
/// heartbeat, and answers `is_cancelled` for dismissal, lost lease and time limit.
#[derive(Debug)]
struct JobProgress {
    cancelled: AtomicBool,
    deadline: Instant,
    state: Mutex<(u8, String)>,
}

impl JobProgress {
    fn new(deadline: Instant) -> Self {
        JobProgress {
            cancelled: AtomicBool::new(false),
            deadline,
            state: Mutex::new((0, "started".to_string())),
        }
    }

    fn cancel(&self) {
        self.cancelled.store(true, Ordering::Relaxed);
    }

    fn timed_out(&self) -> bool {
        Instant::now() >= self.deadline
    }

    fn snapshot(&self) -> (u8, String) {
        self.state.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

/// Where each stage sits in the job's 0..100 progress: (start, span). Every stage has a
/// place; the curvature search shares the contour stage's scale (`progress::Stage`).
fn stage_span(stage: Stage) -> (f64, f64) {
    match stage {
        Stage::Read => (0.0, 5.0),
        Stage::Fit => (5.0, 10.0),
        Stage::Refine => (15.0, 15.0),
        Stage::Tetrahedralize => (30.0, 25.0),
        Stage::Contour | Stage::Curvature => (55.0, 30.0),
        Stage::Bounds => (85.0, 5.0),
        Stage::CrossValidate => (90.0, 5.0),
        Stage::Export => (95.0, 4.0),
    }
}

impl Progress for JobProgress {
    fn report(&self, stage: Stage, fraction: f64) {
        let fraction = if fraction.is_finite() {
            fraction.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        let (start, span) = stage_span(stage);
        let percent = (start + span * fraction).floor().clamp(0.0, 99.0) as u8;
        state.0 = state.0.max(percent);
        state.1 = format!("{stage} {:.0}%", fraction * 100.0);
    }

    fn is_cancelled(&self) -> bool {
        self.cancelled.load(Ordering::Relaxed) || self.timed_out()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_only_moves_forward_and_names_the_stage() {
        let progress = JobProgress::new(Instant::now() + Duration::from_secs(60));
        progress.report(Stage::Tetrahedralize, 0.5);
        assert_eq!(progress.snapshot(), (42, "tetrahedralize 50%".to_string()));
        progress.report(Stage::Read, 1.0);
        assert_eq!(progress.snapshot().0, 42);
        progress.report(Stage::Export, 1.0);
        assert_eq!(progress.snapshot().0, 99);
    }

    #[test]
    fn every_stage_moves_the_percent_and_stages_follow_the_pipeline_order() {
        let mut last_start = 0.0;
        for stage in Stage::ALL {
            let progress = JobProgress::new(Instant::now() + Duration::from_secs(60));
            progress.report(stage, 0.0);
            let start = progress.snapshot().0;
            progress.report(stage, 1.0);
            let end = progress.snapshot().0;
            assert!(
                end > start,
                "{stage} does not move the percent ({start} -> {end})"
            );
            let (span_start, _) = stage_span(stage);
            assert!(
                span_start >= last_start,
                "{stage} starts before the stage before it"
            );
            last_start = span_start;
        }
        // A 0/1 shell's curvature search moves the percent between the extraction's steps.
        let progress = JobProgress::new(Instant::now() + Duration::from_secs(60));
        let (lo, hi) = crate::progress::CURVATURE_SHARE;
        progress.report(Stage::Contour, lo);
        let before = progress.snapshot().0;
        progress.report(Stage::Curvature, hi);
        assert!(progress.snapshot().0 > before);
    }

    #[test]
    fn a_passed_deadline_cancels() {
        let progress = JobProgress::new(Instant::now());
        assert!(progress.is_cancelled());
        let progress = JobProgress::new(Instant::now() + Duration::from_secs(60));
        assert!(!progress.is_cancelled());
        progress.cancel();
        assert!(progress.is_cancelled());
    }

    #[test]
    fn metrics_render_a_histogram() {
        let metrics = JobMetrics::default();
        metrics.record("successful", 0.7);
        let mut text = String::new();
        metrics.render(&mut text);
        assert!(text.contains("wellmesh_jobs_finished_total{outcome=\"successful\"} 1"));
        assert!(text.contains("wellmesh_job_duration_seconds_bucket{le=\"0.5\"} 0"));
        assert!(text.contains("wellmesh_job_duration_seconds_bucket{le=\"1\"} 1"));
        assert!(text.contains("wellmesh_job_duration_seconds_count 1"));
    }
}
