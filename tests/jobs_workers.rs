//! Workers against a real store (SQLite, and PostgreSQL when configured): outcomes,
//! time limit, panics, graceful shutdown and exactly-once execution across pools.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::Notify;
use wellmesh::jobs::{
    FailureKind, JobFailure, JobMetrics, JobState, JobStore, Pipeline, PostgresStore, SqliteStore,
    StoredOutput, WorkerConfig, WorkerPool, now_ms,
};
use wellmesh::process::{ProcessInputs, Thresholds};
use wellmesh::progress::{Progress, Stage};

async fn sqlite_store() -> Arc<dyn JobStore> {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("workers-{}", uuid::Uuid::new_v4().simple()));
    std::fs::create_dir_all(&dir).unwrap();
    let url = format!("sqlite://{}", dir.join("jobs.db").display());
    Arc::new(SqliteStore::connect(&url).await.unwrap())
}

async fn postgres_store() -> Option<Arc<dyn JobStore>> {
    let Ok(url) =
        std::env::var("WELLMESH_TEST_DATABASE_URL").or_else(|_| std::env::var("DATABASE_URL"))
    else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must set WELLMESH_TEST_DATABASE_URL to run the PostgreSQL suite"
        );
        return None;
    };
    let schema = format!("test_{}", uuid::Uuid::new_v4().simple());
    Some(Arc::new(
        PostgresStore::connect_in_schema(&url, &schema)
            .await
            .unwrap(),
    ))
}

macro_rules! worker_suite {
    ($($name:ident),* $(,)?) => {
        mod sqlite {
            $(
                #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
                async fn $name() {
                    super::$name(super::sqlite_store().await).await;
                }
            )*
        }
        mod postgres {
            $(
                #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
                async fn $name() {
                    if let Some(store) = super::postgres_store().await {
                        super::$name(store).await;
                    }
                }
            )*
        }
    };
}

worker_suite!(
    a_worker_runs_a_job_and_stores_its_outputs,
    a_job_past_its_time_limit_fails_as_a_timeout,
    a_panicking_pipeline_fails_its_job_and_the_worker_goes_on,
    shutdown_requeues_a_job_still_running_after_the_grace_period,
    shutdown_lets_a_job_finish_within_the_grace_period,
    two_pools_on_one_store_run_each_job_exactly_once,
);

/// Behaviour chosen per job by its `variable` input: `sleep:MS`, `forever`, `panic`.
#[derive(Default)]
struct ScriptedPipeline {
    runs: Mutex<HashMap<String, usize>>,
    running: AtomicUsize,
    most_at_once: AtomicUsize,
    saw_cancel: AtomicBool,
}

impl Pipeline for ScriptedPipeline {
    fn run(&self, inputs: &[u8], progress: &dyn Progress) -> Result<Vec<StoredOutput>, JobFailure> {
        let inputs: ProcessInputs = serde_json::from_slice(inputs).expect("stored inputs");
        let script = inputs.variable.clone().unwrap_or_default();
        let tag = inputs.crs.clone().unwrap_or_default();
        *self.runs.lock().unwrap().entry(tag.clone()).or_default() += 1;
        let now = self.running.fetch_add(1, Ordering::SeqCst) + 1;
        self.most_at_once.fetch_max(now, Ordering::SeqCst);
        let outcome = (|| {
            progress.report(Stage::Tetrahedralize, 0.1);
            let millis = match script.as_str() {
                "panic" => panic!("scripted panic"),
                "forever" => u64::MAX,
                other => other
                    .strip_prefix("sleep:")
                    .and_then(|ms| ms.parse().ok())
                    .unwrap_or(0),
            };
            let start = std::time::Instant::now();
            while start.elapsed() < Duration::from_millis(millis) {
                if progress.is_cancelled() {
                    self.saw_cancel.store(true, Ordering::SeqCst);
                    return Err(JobFailure::Cancelled);
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Ok(vec![StoredOutput {
                id: "summary".into(),
                file_name: "summary.json".into(),
                media_type: "application/json".into(),
                bytes: format!("{{\"tag\": \"{tag}\"}}").into_bytes(),
            }])
        })();
        self.running.fetch_sub(1, Ordering::SeqCst);
        outcome
    }
}

fn job_inputs(script: &str, tag: &str) -> Vec<u8> {
    serde_json::to_vec(&ProcessInputs {
        samples_csv: Some("well,x,y,z,value\n".into()),
        thresholds: Thresholds::One(0.5),
        variable: Some(script.into()),
        crs: Some(tag.into()),
        ..ProcessInputs::default()
    })
    .unwrap()
}

fn config(concurrency: usize) -> WorkerConfig {
    WorkerConfig {
        concurrency,
        lease: Duration::from_secs(5),
        heartbeat: Duration::from_millis(40),
        poll: Duration::from_millis(30),
        time_limit: Duration::from_secs(60),
        shutdown_grace: Duration::from_secs(10),
        name: "test".into(),
    }
}

fn start(
    store: &Arc<dyn JobStore>,
    pipeline: &Arc<ScriptedPipeline>,
    config: WorkerConfig,
) -> WorkerPool {
    WorkerPool::start(
        store.clone(),
        pipeline.clone(),
        config,
        Arc::new(Notify::new()),
        Arc::new(JobMetrics::default()),
    )
}

async fn wait_for(store: &Arc<dyn JobStore>, id: uuid::Uuid, wanted: JobState) {
    for _ in 0..600 {
        if store.get(id).await.unwrap().unwrap().state == wanted {
            return;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    let job = store.get(id).await.unwrap().unwrap();
    panic!(
        "job stayed {:?} ({}), never {wanted:?}",
        job.state, job.message
    );
}

async fn a_worker_runs_a_job_and_stores_its_outputs(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let pool = start(&store, &pipeline, config(1));
    let job = store
        .submit(&job_inputs("sleep:100", "a"), 3, None, now_ms())
        .await
        .unwrap();

    wait_for(&store, job.id, JobState::Successful).await;
    pool.shutdown().await;

    let summary = store.output(job.id, "summary").await.unwrap().unwrap();
    assert_eq!(summary.bytes, b"{\"tag\": \"a\"}");
    assert_eq!(store.get(job.id).await.unwrap().unwrap().attempt, 1);
}

async fn a_job_past_its_time_limit_fails_as_a_timeout(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let pool = start(
        &store,
        &pipeline,
        WorkerConfig {
            time_limit: Duration::from_millis(300),
            ..config(1)
        },
    );
    let job = store
        .submit(&job_inputs("forever", "t"), 3, None, now_ms())
        .await
        .unwrap();

    wait_for(&store, job.id, JobState::Failed).await;
    pool.shutdown().await;

    let failed = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(failed.failure, Some(FailureKind::Timeout));
    assert!(failed.message.contains("time limit"), "{}", failed.message);
    for _ in 0..100 {
        if pipeline.saw_cancel.load(Ordering::SeqCst) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(pipeline.saw_cancel.load(Ordering::SeqCst));
}

async fn a_panicking_pipeline_fails_its_job_and_the_worker_goes_on(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let pool = start(&store, &pipeline, config(1));
    let bad = store
        .submit(&job_inputs("panic", "p"), 3, None, now_ms())
        .await
        .unwrap();
    let good = store
        .submit(&job_inputs("sleep:0", "g"), 3, None, now_ms() + 1)
        .await
        .unwrap();

    wait_for(&store, good.id, JobState::Successful).await;
    pool.shutdown().await;

    let failed = store.get(bad.id).await.unwrap().unwrap();
    assert_eq!(failed.state, JobState::Failed);
    assert_eq!(failed.failure, Some(FailureKind::Internal));
    assert!(
        !failed.message.contains("scripted"),
        "internals leaked: {}",
        failed.message
    );
}

async fn shutdown_requeues_a_job_still_running_after_the_grace_period(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let pool = start(
        &store,
        &pipeline,
        WorkerConfig {
            shutdown_grace: Duration::from_millis(100),
            ..config(1)
        },
    );
    let job = store
        .submit(&job_inputs("forever", "s"), 1, None, now_ms())
        .await
        .unwrap();
    wait_for(&store, job.id, JobState::Running).await;

    pool.shutdown().await;

    let requeued = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(requeued.state, JobState::Accepted);
    assert!(
        requeued.message.contains("shut down"),
        "{}",
        requeued.message
    );
    // Released, not lost: the attempt limit of 1 still lets the next worker run it.
    let claimed = store.claim_next_job("next", now_ms(), 1_000).await.unwrap();
    assert_eq!(claimed.unwrap().lease.job_id, job.id);
}

async fn shutdown_lets_a_job_finish_within_the_grace_period(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let pool = start(&store, &pipeline, config(1));
    let job = store
        .submit(&job_inputs("sleep:300", "f"), 3, None, now_ms())
        .await
        .unwrap();
    wait_for(&store, job.id, JobState::Running).await;

    pool.shutdown().await;

    assert_eq!(
        store.get(job.id).await.unwrap().unwrap().state,
        JobState::Successful
    );
}

async fn two_pools_on_one_store_run_each_job_exactly_once(store: Arc<dyn JobStore>) {
    let pipeline = Arc::new(ScriptedPipeline::default());
    let first = start(&store, &pipeline, config(2));
    let second = start(&store, &pipeline, config(2));
    let mut ids = Vec::new();
    for i in 0..16 {
        let job = store
            .submit(
                &job_inputs("sleep:20", &format!("job{i}")),
                3,
                None,
                now_ms() + i,
            )
            .await
            .unwrap();
        ids.push(job.id);
    }

    for id in &ids {
        wait_for(&store, *id, JobState::Successful).await;
    }
    first.shutdown().await;
    second.shutdown().await;

    let runs = pipeline.runs.lock().unwrap().clone();
    assert_eq!(runs.len(), 16);
    assert!(runs.values().all(|&n| n == 1), "{runs:?}");
    assert!(pipeline.most_at_once.load(Ordering::SeqCst) <= 4);
}
