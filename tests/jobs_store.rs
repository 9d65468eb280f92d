//! One test suite for the `JobStore` contract, run against SQLite and PostgreSQL.
//!
//! PostgreSQL runs when `WELLMESH_TEST_DATABASE_URL` (or `DATABASE_URL`) is set; each
//! test gets a fresh schema. Under `CI` a missing URL is a failure, not a skip.

use std::collections::HashSet;
use std::sync::Arc;

use wellmesh::jobs::{
    Dismissal, FailureKind, JobQuery, JobState, JobStore, JobStoreError, ListPosition,
    OUTPUT_PART_BYTES, PostgresStore, SqliteStore, StoredOutput, compress_json_inputs,
};

const LEASE_MS: i64 = 1_000;

async fn sqlite_store() -> Arc<dyn JobStore> {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("jobs-{}", uuid::Uuid::new_v4().simple()));
    std::fs::create_dir_all(&dir).unwrap();
    let url = format!("sqlite://{}", dir.join("jobs.db").display());
    Arc::new(SqliteStore::connect(&url).await.unwrap())
}

async fn postgres_store() -> Option<Arc<dyn JobStore>> {
    let url = std::env::var("WELLMESH_TEST_DATABASE_URL")
        .or_else(|_| std::env::var("DATABASE_URL"))
        .ok();
    let Some(url) = url else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must set WELLMESH_TEST_DATABASE_URL to run the PostgreSQL suite"
        );
        eprintln!("PostgreSQL suite skipped: set WELLMESH_TEST_DATABASE_URL");
        return None;
    };
    let schema = format!("test_{}", uuid::Uuid::new_v4().simple());
    Some(Arc::new(
        PostgresStore::connect_in_schema(&url, &schema)
            .await
            .unwrap(),
    ))
}

macro_rules! store_suite {
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

store_suite!(
    a_submitted_job_is_accepted_and_listed,
    claims_take_the_oldest_job_and_never_the_same_twice,
    a_heartbeat_extends_the_lease_and_records_progress,
    an_expired_lease_is_requeued_and_the_old_worker_is_fenced_out,
    a_job_whose_workers_keep_dying_fails_at_the_attempt_limit,
    success_stores_every_output_with_the_state_change,
    a_dismissed_queued_job_never_runs,
    dismissing_a_running_job_takes_its_lease_away,
    dismissing_a_finished_job_deletes_its_outputs,
    the_queue_limit_refuses_submits_beyond_it,
    a_released_job_is_requeued_without_using_an_attempt,
    concurrent_claims_never_share_a_job,
    failures_keep_their_kind_field_and_message,
    a_listing_honours_its_limit_without_dismissed_jobs_and_pages_on,
    a_listing_filters_by_state_and_owner,
    inputs_are_stored_compressed_and_read_back_as_submitted,
    dismissal_deletes_inputs_and_outputs_at_once,
    the_retention_sweep_deletes_only_old_finished_jobs,
    storage_counts_inputs_and_outputs_per_job,
    concurrent_submits_never_pass_the_queue_limit,
    a_large_output_is_read_back_a_part_at_a_time,
    inputs_compressed_by_the_service_are_read_back_as_their_json,
);

fn output(id: &str, bytes: &[u8]) -> StoredOutput {
    StoredOutput {
        id: id.to_string(),
        file_name: format!("out.{id}"),
        media_type: "application/octet-stream".to_string(),
        bytes: bytes.to_vec(),
    }
}

async fn a_submitted_job_is_accepted_and_listed(store: Arc<dyn JobStore>) {
    let job = store.submit(b"{\"a\":1}", 3, None, 1_000).await.unwrap();

    let listed = store.list(10).await.unwrap();
    let fetched = store.get(job.id).await.unwrap().unwrap();

    assert_eq!(job.state, JobState::Accepted);
    assert_eq!(job.created_ms, 1_000);
    assert_eq!(job.attempt, 0);
    assert_eq!(fetched, job);
    assert_eq!(listed, vec![job.clone()]);
    assert_eq!(store.inputs(job.id).await.unwrap().unwrap(), b"{\"a\":1}");
    assert!(store.get(uuid::Uuid::new_v4()).await.unwrap().is_none());
}

async fn claims_take_the_oldest_job_and_never_the_same_twice(store: Arc<dyn JobStore>) {
    let older = store.submit(b"1", 3, None, 1_000).await.unwrap();
    let newer = store.submit(b"2", 3, None, 2_000).await.unwrap();

    let first = store
        .claim_next_job("w1", 3_000, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    let second = store
        .claim_next_job("w2", 3_000, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    let third = store.claim_next_job("w3", 3_000, LEASE_MS).await.unwrap();

    assert_eq!(first.lease.job_id, older.id);
    assert_eq!(first.lease.attempt, 1);
    assert_eq!(first.inputs, b"1");
    assert_eq!(second.lease.job_id, newer.id);
    assert!(third.is_none());
    let running = store.get(older.id).await.unwrap().unwrap();
    assert_eq!(running.state, JobState::Running);
    assert_eq!(running.started_ms, Some(3_000));
}

async fn a_heartbeat_extends_the_lease_and_records_progress(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    // Renewed at 900 ms, the lease runs to 1900 ms: a claim at 1500 ms finds nothing.
    let held = store
        .record_heartbeat(claimed.lease, 42, "tetrahedralize 80%", 900, LEASE_MS)
        .await
        .unwrap();
    let stolen = store.claim_next_job("w2", 1_500, LEASE_MS).await.unwrap();

    assert!(held);
    assert!(stolen.is_none());
    let running = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(running.progress, 42);
    assert_eq!(running.message, "tetrahedralize 80%");
    assert_eq!(running.updated_ms, 900);
}

async fn an_expired_lease_is_requeued_and_the_old_worker_is_fenced_out(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let dead = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    let taken_over = store
        .claim_next_job("w2", 5_000, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    let late_heartbeat = store
        .record_heartbeat(dead.lease, 50, "x", 5_100, LEASE_MS)
        .await
        .unwrap();
    let late_success = store
        .mark_succeeded(dead.lease, &[output("glb", b"stale")], 5_200)
        .await
        .unwrap();
    let late_failure = store
        .mark_failed(dead.lease, FailureKind::Input, None, "stale", 5_200)
        .await
        .unwrap();

    assert_eq!(taken_over.lease.job_id, job.id);
    assert_eq!(taken_over.lease.attempt, 2);
    assert!(!late_heartbeat);
    assert!(!late_success);
    assert!(!late_failure);
    assert!(store.outputs(job.id).await.unwrap().is_empty());
    assert!(
        store
            .mark_succeeded(taken_over.lease, &[output("glb", b"fresh")], 5_300)
            .await
            .unwrap()
    );
    let done = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(done.state, JobState::Successful);
    assert_eq!(
        store.output(job.id, "glb").await.unwrap().unwrap().bytes,
        b"fresh"
    );
}

async fn a_job_whose_workers_keep_dying_fails_at_the_attempt_limit(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 2, None, 0).await.unwrap();
    store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .claim_next_job("w2", 2_000, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    let third = store.claim_next_job("w3", 4_000, LEASE_MS).await.unwrap();

    assert!(third.is_none());
    let failed = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(failed.state, JobState::Failed);
    assert_eq!(failed.failure, Some(FailureKind::LeaseExpired));
    assert_eq!(failed.finished_ms, Some(4_000));
    assert!(failed.message.contains("2 times"), "{}", failed.message);
}

async fn success_stores_every_output_with_the_state_change(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    let outputs = vec![output("summary", b"{}"), output("glb", &[0, 1, 2, 255])];

    let stored = store
        .mark_succeeded(claimed.lease, &outputs, 700)
        .await
        .unwrap();

    assert!(stored);
    let done = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(done.state, JobState::Successful);
    assert_eq!(done.progress, 100);
    assert_eq!(done.finished_ms, Some(700));
    let listed = store.outputs(job.id).await.unwrap();
    let ids: Vec<_> = listed
        .iter()
        .map(|o| (o.id.as_str(), o.size_bytes))
        .collect();
    assert_eq!(ids, vec![("glb", 4), ("summary", 2)]);
    assert_eq!(
        store.output(job.id, "glb").await.unwrap().unwrap(),
        outputs[1]
    );
    assert!(store.output(job.id, "obj").await.unwrap().is_none());
    // Done is done: the same lease cannot complete it again.
    assert!(
        !store
            .mark_succeeded(claimed.lease, &outputs, 800)
            .await
            .unwrap()
    );
}

async fn a_dismissed_queued_job_never_runs(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();

    let dismissal = store.request_dismissal(job.id, 10).await.unwrap();
    let claimed = store.claim_next_job("w1", 20, LEASE_MS).await.unwrap();

    let Dismissal::Dismissed(record) = dismissal else {
        panic!("expected a dismissal")
    };
    assert_eq!(record.state, JobState::Dismissed);
    assert_eq!(record.finished_ms, Some(10));
    assert!(claimed.is_none());
    assert_eq!(
        store
            .request_dismissal(uuid::Uuid::new_v4(), 10)
            .await
            .unwrap(),
        Dismissal::NotFound
    );
}

async fn dismissing_a_running_job_takes_its_lease_away(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    store.request_dismissal(job.id, 100).await.unwrap();
    let heartbeat = store
        .record_heartbeat(claimed.lease, 10, "x", 200, LEASE_MS)
        .await
        .unwrap();
    let success = store
        .mark_succeeded(claimed.lease, &[output("glb", b"x")], 300)
        .await
        .unwrap();

    assert!(!heartbeat);
    assert!(!success);
    assert_eq!(
        store.get(job.id).await.unwrap().unwrap().state,
        JobState::Dismissed
    );
    // A dismissed job is not re-queued when its old lease expires.
    assert!(
        store
            .claim_next_job("w2", 10_000, LEASE_MS)
            .await
            .unwrap()
            .is_none()
    );
}

async fn dismissing_a_finished_job_deletes_its_outputs(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .mark_succeeded(claimed.lease, &[output("glb", b"x")], 50)
        .await
        .unwrap();

    store.request_dismissal(job.id, 100).await.unwrap();

    let record = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(record.state, JobState::Dismissed);
    assert_eq!(record.finished_ms, Some(50));
    assert!(store.outputs(job.id).await.unwrap().is_empty());
}

async fn the_queue_limit_refuses_submits_beyond_it(store: Arc<dyn JobStore>) {
    store.submit(b"1", 3, Some(2), 0).await.unwrap();
    store.submit(b"2", 3, Some(2), 0).await.unwrap();

    let refused = store.submit(b"3", 3, Some(2), 0).await;
    store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    let accepted_again = store.submit(b"4", 3, Some(2), 0).await;

    assert!(
        matches!(refused, Err(JobStoreError::QueueFull { queued: 2 })),
        "{refused:?}"
    );
    assert!(accepted_again.is_ok());
    assert_eq!(store.list(10).await.unwrap().len(), 3);
}

async fn a_released_job_is_requeued_without_using_an_attempt(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 1, None, 0).await.unwrap();
    let first = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    let released = store.release(first.lease, 10).await.unwrap();
    let second = store
        .claim_next_job("w2", 20, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    assert!(released);
    assert_eq!(second.lease.job_id, job.id);
    assert_eq!(second.lease.attempt, 2);
    assert!(!store.release(first.lease, 30).await.unwrap());
    assert!(store.mark_succeeded(second.lease, &[], 40).await.unwrap());
}

async fn concurrent_claims_never_share_a_job(store: Arc<dyn JobStore>) {
    let mut submitted = HashSet::new();
    for i in 0..24 {
        submitted.insert(store.submit(b"x", 3, None, i).await.unwrap().id);
    }

    let claimers: Vec<_> = (0..6)
        .map(|w| {
            let store = store.clone();
            tokio::spawn(async move {
                let mut mine = Vec::new();
                while let Some(job) = store
                    .claim_next_job(&format!("w{w}"), 100, 60_000)
                    .await
                    .unwrap()
                {
                    mine.push(job.lease.job_id);
                }
                mine
            })
        })
        .collect();
    let mut claimed = Vec::new();
    for claimer in claimers {
        claimed.extend(claimer.await.unwrap());
    }

    let unique: HashSet<_> = claimed.iter().copied().collect();
    assert_eq!(claimed.len(), 24, "a job was claimed twice or lost");
    assert_eq!(unique, submitted);
}

async fn failures_keep_their_kind_field_and_message(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    let recorded = store
        .mark_failed(
            claimed.lease,
            FailureKind::Input,
            Some("samples_csv"),
            "samples_csv row 3: bad x",
            90,
        )
        .await
        .unwrap();

    assert!(recorded);
    let failed = store.get(job.id).await.unwrap().unwrap();
    assert_eq!(failed.state, JobState::Failed);
    assert_eq!(failed.failure, Some(FailureKind::Input));
    assert_eq!(failed.message, "samples_csv row 3: bad x");
    assert_eq!(failed.failure_field.as_deref(), Some("samples_csv"));
    let counts = store.count_by_state().await.unwrap();
    assert_eq!(counts, vec![(JobState::Failed, 1)]);
}

fn query(limit: i64) -> JobQuery {
    JobQuery {
        limit,
        ..JobQuery::default()
    }
}

async fn a_listing_honours_its_limit_without_dismissed_jobs_and_pages_on(store: Arc<dyn JobStore>) {
    let mut ids = Vec::new();
    for t in 0..5 {
        ids.push(store.submit(b"1", 3, None, 1_000 + t).await.unwrap().id);
    }
    // The newest job is dismissed: a limit of 2 still answers 2 jobs.
    store.request_dismissal(ids[4], 2_000).await.unwrap();

    let first = store.list_jobs(&query(2)).await.unwrap();
    let last = first.last().unwrap();
    let second = store
        .list_jobs(&JobQuery {
            after: Some(ListPosition {
                created_ms: last.created_ms,
                id: last.id,
            }),
            ..query(2)
        })
        .await
        .unwrap();

    let names = |jobs: &[wellmesh::jobs::JobRecord]| jobs.iter().map(|j| j.id).collect::<Vec<_>>();
    assert_eq!(names(&first), vec![ids[3], ids[2]]);
    assert_eq!(names(&second), vec![ids[1], ids[0]]);
}

async fn a_listing_filters_by_state_and_owner(store: Arc<dyn JobStore>) {
    let mine = store
        .submit_owned(b"1", Some("key-a"), 3, None, 1)
        .await
        .unwrap();
    let theirs = store
        .submit_owned(b"2", Some("key-b"), 3, None, 2)
        .await
        .unwrap();
    let claimed = store
        .claim_next_job("w", 3, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(claimed.lease.job_id, mine.id);

    let owned = store
        .list_jobs(&JobQuery {
            owner: Some("key-b".into()),
            ..query(10)
        })
        .await
        .unwrap();
    let running = store
        .list_jobs(&JobQuery {
            states: vec![JobState::Running],
            ..query(10)
        })
        .await
        .unwrap();

    assert_eq!(owned.len(), 1);
    assert_eq!(owned[0].id, theirs.id);
    assert_eq!(owned[0].owner.as_deref(), Some("key-b"));
    assert_eq!(running.len(), 1);
    assert_eq!(running[0].id, mine.id);
}

async fn inputs_are_stored_compressed_and_read_back_as_submitted(store: Arc<dyn JobStore>) {
    let inputs = "well,x,y,z,value\n".repeat(20_000).into_bytes();
    let job = store.submit(&inputs, 3, None, 1).await.unwrap();

    let stored = store.storage().await.unwrap();
    let claimed = store
        .claim_next_job("w", 2, LEASE_MS)
        .await
        .unwrap()
        .unwrap();

    assert!(
        stored.input_bytes * 20 < inputs.len() as i64,
        "{} bytes stored for {}",
        stored.input_bytes,
        inputs.len()
    );
    assert_eq!(claimed.inputs, inputs);
    assert_eq!(store.inputs(job.id).await.unwrap().unwrap(), inputs);
}

async fn dismissal_deletes_inputs_and_outputs_at_once(store: Arc<dyn JobStore>) {
    let job = store.submit(&[7u8; 10_000], 3, None, 1).await.unwrap();
    let claimed = store
        .claim_next_job("w", 2, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .mark_succeeded(claimed.lease, &[output("glb", &[1u8; 5_000])], 3)
        .await
        .unwrap();
    let before = store.storage().await.unwrap();

    store.request_dismissal(job.id, 4).await.unwrap();

    let after = store.storage().await.unwrap();
    assert!(before.input_bytes > 0 && before.output_bytes == 5_000);
    assert_eq!((after.input_bytes, after.output_bytes), (0, 0));
    assert_eq!(store.inputs(job.id).await.unwrap().unwrap(), b"");
}

async fn the_retention_sweep_deletes_only_old_finished_jobs(store: Arc<dyn JobStore>) {
    let old = store.submit(b"1", 3, None, 1).await.unwrap();
    let claimed = store
        .claim_next_job("w", 2, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .mark_succeeded(claimed.lease, &[output("glb", b"x")], 10)
        .await
        .unwrap();
    let dismissed = store.submit(b"2", 3, None, 3).await.unwrap();
    store.request_dismissal(dismissed.id, 20).await.unwrap();
    let recent = store.submit(b"3", 3, None, 4).await.unwrap();
    let claimed = store
        .claim_next_job("w", 5, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .mark_succeeded(claimed.lease, &[output("glb", b"y")], 500)
        .await
        .unwrap();
    let queued = store.submit(b"4", 3, None, 6).await.unwrap();

    let deleted = store.delete_finished_before(100).await.unwrap();

    assert_eq!(deleted, 2);
    assert!(store.get(old.id).await.unwrap().is_none());
    assert!(store.get(dismissed.id).await.unwrap().is_none());
    assert!(store.output(old.id, "glb").await.unwrap().is_none());
    assert!(store.get(recent.id).await.unwrap().is_some());
    assert!(store.get(queued.id).await.unwrap().is_some());
    assert_eq!(store.storage().await.unwrap().jobs, 2);
}

async fn storage_counts_inputs_and_outputs_per_job(store: Arc<dyn JobStore>) {
    let job = store.submit(b"{}", 3, None, 1).await.unwrap();
    let claimed = store
        .claim_next_job("w", 2, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    store
        .mark_succeeded(
            claimed.lease,
            &[
                output("glb", &[0u8; 3_000]),
                output("summary", &[0u8; 1_000]),
            ],
            3,
        )
        .await
        .unwrap();
    store.submit(b"{}", 3, None, 4).await.unwrap();

    let storage = store.storage().await.unwrap();

    assert_eq!(storage.jobs, 2);
    assert_eq!(storage.output_bytes, 4_000);
    let inputs = storage.input_bytes / 2;
    assert_eq!(storage.largest_job_bytes, 4_000 + inputs);
    assert!(store.get(job.id).await.unwrap().is_some());
}

async fn concurrent_submits_never_pass_the_queue_limit(store: Arc<dyn JobStore>) {
    let submits = (0..32).map(|i| {
        let store = store.clone();
        tokio::spawn(async move { store.submit(b"1", 3, Some(10), i).await })
    });
    let mut accepted = 0;
    let mut refused = 0;
    for submit in submits {
        match submit.await.unwrap() {
            Ok(_) => accepted += 1,
            Err(JobStoreError::QueueFull { .. }) => refused += 1,
            Err(e) => panic!("{e}"),
        }
    }
    assert_eq!((accepted, refused), (10, 22));
    let counts = store.count_by_state().await.unwrap();
    assert_eq!(counts, vec![(JobState::Accepted, 10)]);
}

async fn a_large_output_is_read_back_a_part_at_a_time(store: Arc<dyn JobStore>) {
    let job = store.submit(b"1", 3, None, 0).await.unwrap();
    let claimed = store
        .claim_next_job("w1", 0, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    // Two whole parts and a short third one; every byte differs from its neighbours.
    let size = 2 * OUTPUT_PART_BYTES + 1_000;
    let glb: Vec<u8> = (0..size).map(|i| (i * 7 % 251) as u8).collect();
    let outputs = vec![output("glb", &glb), output("empty", b"")];
    assert!(
        store
            .mark_succeeded(claimed.lease, &outputs, 10)
            .await
            .unwrap()
    );

    let info = store.output_info(job.id, "glb").await.unwrap().unwrap();
    assert_eq!(info.size_bytes, size as i64);
    assert_eq!(info.file_name, "out.glb");
    // A read answers from its offset to the end of the part holding it, never more.
    let part = OUTPUT_PART_BYTES as u64;
    for (offset, expected) in [
        (0, 0..OUTPUT_PART_BYTES),
        (5, 5..OUTPUT_PART_BYTES),
        (part - 1, OUTPUT_PART_BYTES - 1..OUTPUT_PART_BYTES),
        (part, OUTPUT_PART_BYTES..2 * OUTPUT_PART_BYTES),
        (2 * part + 999, size - 1..size),
    ] {
        let read = store
            .output_part(job.id, "glb", offset)
            .await
            .unwrap()
            .unwrap();
        assert_eq!(read, glb[expected.clone()], "offset {offset}");
    }
    // Read part after part, the output comes back whole.
    let mut streamed = Vec::new();
    while streamed.len() < size {
        let read = store
            .output_part(job.id, "glb", streamed.len() as u64)
            .await
            .unwrap()
            .unwrap();
        assert!(!read.is_empty() && read.len() <= OUTPUT_PART_BYTES);
        streamed.extend(read);
    }
    assert_eq!(streamed, glb);
    assert_eq!(
        store.output(job.id, "glb").await.unwrap().unwrap(),
        outputs[0]
    );
    // At the end: empty; an empty output has no parts but exists; a missing one is None.
    let end = store.output_part(job.id, "glb", size as u64).await.unwrap();
    assert_eq!(end, Some(Vec::new()));
    let empty = store.output_part(job.id, "empty", 0).await.unwrap();
    assert_eq!(empty, Some(Vec::new()));
    assert_eq!(
        store.output(job.id, "empty").await.unwrap().unwrap(),
        outputs[1]
    );
    assert!(store.output_part(job.id, "obj", 0).await.unwrap().is_none());
    assert!(store.output_info(job.id, "obj").await.unwrap().is_none());
    let usage = store.storage().await.unwrap();
    assert_eq!(usage.output_bytes, size as i64);
    // Dismissal deletes the parts with the output.
    store.request_dismissal(job.id, 20).await.unwrap();
    assert!(store.output_part(job.id, "glb", 0).await.unwrap().is_none());
}

async fn inputs_compressed_by_the_service_are_read_back_as_their_json(store: Arc<dyn JobStore>) {
    // What the API submits: the parsed request serialized straight into the compressor.
    let csv: String = (0..20_000)
        .map(|i| format!("w{},{i}.5,{}.25,{}.75,{}\n", i % 7, i / 3, i % 11, i % 2))
        .collect();
    let inputs = serde_json::json!({"samples_csv": csv, "thresholds": [0.5, 1.0]});
    let compressed = compress_json_inputs(&inputs).unwrap();
    let json = serde_json::to_vec(&inputs).unwrap();
    assert!(
        compressed.len() * 3 < json.len(),
        "{} of {}",
        compressed.len(),
        json.len()
    );

    let job = store
        .submit_compressed(&compressed, Some("key-a"), 3, Some(10), 5)
        .await
        .unwrap();

    assert_eq!(job.owner.as_deref(), Some("key-a"));
    assert_eq!(store.inputs(job.id).await.unwrap().unwrap(), json);
    let claimed = store
        .claim_next_job("w1", 6, LEASE_MS)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(claimed.inputs, json);
    assert_eq!(
        store.storage().await.unwrap().input_bytes,
        compressed.len() as i64
    );
}
