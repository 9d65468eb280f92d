//! The durable job queue: a [`JobStore`] trait with SQLite and PostgreSQL backends, and the
//! workers that run jobs through a [`Pipeline`]. The queue knows nothing of what a job's
//! inputs mean: it stores bytes and hands them to the pipeline (`process` knows the rest).
//!
//! Invariant: a job's state only moves `accepted -> running -> successful | failed |
//! dismissed` (or back to `accepted` when a lease expires or a worker shuts down), and
//! every write a worker makes is fenced by the job's `attempt`: a write that matches no
//! row means the lease was lost, and the worker stops computing. Outputs are written in
//! the same transaction that marks the job successful, so a job completes exactly once.

mod postgres;
mod sqlite;
mod worker;

use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use async_trait::async_trait;

use crate::progress::Progress;
use serde::{Deserialize, Serialize};
use uuid::Uuid;

pub use postgres::PostgresStore;
pub use sqlite::SqliteStore;
pub use worker::{INTERNAL_FAILURE, JobMetrics, WorkerConfig, WorkerPool};

/// Why a job produced no outputs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JobFailure {
    /// The inputs could not be read or contoured; the message names the row, `field` the
    /// input at fault where it is known.
    #[error("{message}")]
    Input {
        field: Option<String>,
        message: String,
    },
    /// The job was dismissed, its lease was lost, or its time ran out.
    #[error("cancelled")]
    Cancelled,
    /// Something the user cannot fix.
    #[error("internal error: {0}")]
    Internal(String),
}

impl JobFailure {
    /// An input failure without a known field.
    pub fn input(message: impl Into<String>) -> Self {
        JobFailure::Input {
            field: None,
            message: message.into(),
        }
    }

    /// An input failure of the input named `field`.
    pub fn input_field(field: impl Into<String>, message: impl Into<String>) -> Self {
        JobFailure::Input {
            field: Some(field.into()),
            message: message.into(),
        }
    }
}

/// Longest message stored with a job or sent in an error, in bytes: an error that quotes
/// the input it refused is cut here, so a bad 50 MB field is never stored or echoed back.
pub const MAX_MESSAGE_BYTES: usize = 1024;

/// `text` cut to at most [`MAX_MESSAGE_BYTES`] (at a character boundary), saying how much
/// was cut.
pub fn cap_message(text: &str) -> String {
    if text.len() <= MAX_MESSAGE_BYTES {
        return text.to_string();
    }
    let keep = text.floor_char_boundary(MAX_MESSAGE_BYTES - 40);
    format!("{}... ({} more bytes)", &text[..keep], text.len() - keep)
}

/// Turns a job's stored inputs into its outputs. The service runs the `dmt-contour`
/// process ([`crate::process::ContourPipeline`]); tests of the queue plug in pipelines
/// whose duration and outcome they control.
///
/// Invariant: [`Pipeline::run`] is called on a CPU (rayon) thread, never on an async
/// runtime thread, and returns [`JobFailure::Cancelled`] soon after its `Progress` starts
/// answering `is_cancelled() == true`.
pub trait Pipeline: Send + Sync + 'static {
    /// `inputs` are the bytes the job was submitted with.
    fn run(&self, inputs: &[u8], progress: &dyn Progress) -> Result<Vec<StoredOutput>, JobFailure>;
}

/// Where a job is in its life (OGC API - Processes `statusCode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    Accepted,
    Running,
    Successful,
    Failed,
    Dismissed,
}

impl JobState {
    pub const ALL: [JobState; 5] = [
        JobState::Accepted,
        JobState::Running,
        JobState::Successful,
        JobState::Failed,
        JobState::Dismissed,
    ];

    /// The name stored in the database and written in statusInfo documents.
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Accepted => "accepted",
            JobState::Running => "running",
            JobState::Successful => "successful",
            JobState::Failed => "failed",
            JobState::Dismissed => "dismissed",
        }
    }

    pub fn parse(s: &str) -> Result<Self, JobStoreError> {
        JobState::ALL
            .into_iter()
            .find(|state| state.as_str() == s)
            .ok_or_else(|| JobStoreError::Corrupt(format!("unknown job state {s:?}")))
    }

    /// `true` for states a job never leaves on its own.
    pub fn is_finished(self) -> bool {
        matches!(
            self,
            JobState::Successful | JobState::Failed | JobState::Dismissed
        )
    }
}

/// Why a failed job failed, so the API can answer with the right status code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureKind {
    /// The inputs could not be read or contoured (the user can fix them).
    Input,
    /// The job ran past the per-job time limit.
    Timeout,
    /// Workers holding the job died more often than the attempt limit allows.
    LeaseExpired,
    /// A bug: a panic or an error the user cannot fix.
    Internal,
}

impl FailureKind {
    pub fn as_str(self) -> &'static str {
        match self {
            FailureKind::Input => "input",
            FailureKind::Timeout => "timeout",
            FailureKind::LeaseExpired => "lease_expired",
            FailureKind::Internal => "internal",
        }
    }

    pub fn parse(s: &str) -> Self {
        match s {
            "input" => FailureKind::Input,
            "timeout" => FailureKind::Timeout,
            "lease_expired" => FailureKind::LeaseExpired,
            _ => FailureKind::Internal,
        }
    }
}

/// A job as stored. Times are milliseconds since the Unix epoch.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRecord {
    pub id: Uuid,
    pub state: JobState,
    /// Human-readable stage ("tetrahedralize 40%") or the failure reason.
    pub message: String,
    /// 0..=100.
    pub progress: u8,
    /// Number of times a worker claimed the job; the fencing token of worker writes.
    pub attempt: i64,
    pub max_attempts: i64,
    pub failure: Option<FailureKind>,
    /// The input a failure of kind [`FailureKind::Input`] was about, where known.
    pub failure_field: Option<String>,
    /// The principal (API key) that submitted the job; `None` without keys.
    pub owner: Option<String>,
    pub created_ms: i64,
    pub started_ms: Option<i64>,
    pub finished_ms: Option<i64>,
    pub updated_ms: i64,
}

/// A job handed to a worker by [`JobStore::claim_next_job`].
#[derive(Debug, Clone, PartialEq)]
pub struct ClaimedJob {
    pub lease: Lease,
    /// The execute inputs as submitted (JSON).
    pub inputs: Vec<u8>,
}

/// Proof of holding a job: every worker write names it and matches only while the
/// job is still `running` with this `attempt`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lease {
    pub job_id: Uuid,
    pub attempt: i64,
}

/// Outputs are stored in parts of at most this many bytes (`job_output_parts`, keyed by
/// the offset of their first byte) and read back a part at a time, so serving an output
/// holds one part in memory per download, whatever the output's size.
pub const OUTPUT_PART_BYTES: usize = 256 * 1024;

/// One output of a finished job.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredOutput {
    /// `glb`, `summary`, `tileset`, `geojson`, `obj`, `vtu`.
    pub id: String,
    pub file_name: String,
    pub media_type: String,
    pub bytes: Vec<u8>,
}

/// An output without its bytes, for the results document.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputInfo {
    pub id: String,
    pub file_name: String,
    pub media_type: String,
    pub size_bytes: i64,
}

/// What [`JobStore::request_dismissal`] found.
#[derive(Debug, Clone, PartialEq)]
pub enum Dismissal {
    /// The job is now (or already was) dismissed; its outputs are deleted.
    Dismissed(JobRecord),
    NotFound,
}

/// Which jobs a listing asks for, newest first. Dismissed jobs are never listed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JobQuery {
    /// Most jobs answered.
    pub limit: i64,
    /// Only jobs after this one in the listing's order (the last job of the page before).
    pub after: Option<ListPosition>,
    /// Only jobs in these states; empty: every state but `dismissed`.
    pub states: Vec<JobState>,
    /// Only this principal's jobs; `None`: everyone's.
    pub owner: Option<String>,
}

/// A job's place in the listing order (`created_ms` descending, then `id` ascending).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListPosition {
    pub created_ms: i64,
    pub id: Uuid,
}

/// What the store holds, for `/metrics`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StorageUse {
    /// Jobs stored, in every state.
    pub jobs: i64,
    /// Bytes of stored inputs (compressed where they are).
    pub input_bytes: i64,
    /// Bytes of stored outputs.
    pub output_bytes: i64,
    /// Inputs plus outputs of the job holding the most.
    pub largest_job_bytes: i64,
    /// Size of the database file where the store can tell (SQLite), else `None`.
    pub file_bytes: Option<i64>,
}

/// A job's figure in the store, grouped by state.
pub type StateCounts = Vec<(JobState, i64)>;

/// Why the store could not answer.
#[derive(Debug, thiserror::Error)]
pub enum JobStoreError {
    #[error("the queue holds {queued} jobs, its limit")]
    QueueFull { queued: i64 },
    #[error("database error: {0}")]
    Database(#[from] sqlx::Error),
    #[error("migrating the job database: {0}")]
    Migration(#[from] sqlx::migrate::MigrateError),
    #[error("stored job is corrupt: {0}")]
    Corrupt(String),
    #[error("unsupported database URL {0:?}: expected sqlite:// or postgres://")]
    UnsupportedUrl(String),
}

/// The durable queue and result store shared by API nodes and workers.
///
/// Every method is one short transaction. `now_ms` is passed in (rather than read from
/// the clock) so tests can move time; production callers pass [`now_ms`].
#[async_trait]
pub trait JobStore: Send + Sync + 'static {
    /// Queues a job without an owner unless `max_queued` jobs are already waiting.
    async fn submit(
        &self,
        inputs: &[u8],
        max_attempts: i64,
        max_queued: Option<i64>,
        now_ms: i64,
    ) -> Result<JobRecord, JobStoreError> {
        self.submit_owned(inputs, None, max_attempts, max_queued, now_ms)
            .await
    }

    /// Queues a job owned by `owner` unless `max_queued` jobs are already waiting; the
    /// count and the insert are one atomic step, so concurrent submits never pass the
    /// limit. The inputs are stored compressed.
    async fn submit_owned(
        &self,
        inputs: &[u8],
        owner: Option<&str>,
        max_attempts: i64,
        max_queued: Option<i64>,
        now_ms: i64,
    ) -> Result<JobRecord, JobStoreError> {
        let compressed = encode_inputs(inputs).await?;
        self.submit_compressed(&compressed, owner, max_attempts, max_queued, now_ms)
            .await
    }

    /// [`JobStore::submit_owned`] for inputs already compressed by
    /// [`compress_json_inputs`]: the service never holds a large job's inputs
    /// uncompressed beside its parsed request.
    async fn submit_compressed(
        &self,
        compressed_inputs: &[u8],
        owner: Option<&str>,
        max_attempts: i64,
        max_queued: Option<i64>,
        now_ms: i64,
    ) -> Result<JobRecord, JobStoreError>;

    async fn get(&self, id: Uuid) -> Result<Option<JobRecord>, JobStoreError>;

    /// The newest `limit` jobs, newest first, in every state.
    async fn list(&self, limit: i64) -> Result<Vec<JobRecord>, JobStoreError>;

    /// The jobs `query` asks for, newest first; never dismissed ones.
    async fn list_jobs(&self, query: &JobQuery) -> Result<Vec<JobRecord>, JobStoreError>;

    /// Deletes finished jobs (successful, failed, dismissed) that finished before
    /// `finished_before_ms`, with their inputs and outputs, and gives the space back
    /// (SQLite: an incremental vacuum). Returns the number of jobs deleted.
    async fn delete_finished_before(&self, finished_before_ms: i64) -> Result<u64, JobStoreError>;

    /// What the store holds.
    async fn storage(&self) -> Result<StorageUse, JobStoreError>;

    /// Re-queues jobs whose lease expired (or fails them once they reach the attempt
    /// limit), then claims the oldest accepted job for `worker`, holding it until
    /// `now_ms + lease_ms`.
    async fn claim_next_job(
        &self,
        worker: &str,
        now_ms: i64,
        lease_ms: i64,
    ) -> Result<Option<ClaimedJob>, JobStoreError>;

    /// Extends the lease and records progress. `Ok(false)`: the lease is lost (the job
    /// was dismissed, or re-queued and claimed by someone else); stop computing.
    async fn record_heartbeat(
        &self,
        lease: Lease,
        progress: u8,
        message: &str,
        now_ms: i64,
        lease_ms: i64,
    ) -> Result<bool, JobStoreError>;

    /// Stores the outputs and marks the job successful, atomically. `Ok(false)`: the
    /// lease was lost and nothing was written.
    async fn mark_succeeded(
        &self,
        lease: Lease,
        outputs: &[StoredOutput],
        now_ms: i64,
    ) -> Result<bool, JobStoreError>;

    /// Marks the job failed with a message (and the input at fault, where known).
    /// `Ok(false)`: the lease was lost.
    async fn mark_failed(
        &self,
        lease: Lease,
        kind: FailureKind,
        field: Option<&str>,
        message: &str,
        now_ms: i64,
    ) -> Result<bool, JobStoreError>;

    /// Puts a running job back in the queue without counting an attempt against it
    /// (graceful shutdown). `Ok(false)`: the lease was lost.
    async fn release(&self, lease: Lease, now_ms: i64) -> Result<bool, JobStoreError>;

    /// Dismisses a job in any state: queued jobs never run, running jobs lose their
    /// lease (their worker stops at its next heartbeat); its inputs and outputs are
    /// deleted at once (the row stays, so a late worker write is fenced out).
    async fn request_dismissal(&self, id: Uuid, now_ms: i64) -> Result<Dismissal, JobStoreError>;

    async fn inputs(&self, id: Uuid) -> Result<Option<Vec<u8>>, JobStoreError>;

    async fn outputs(&self, id: Uuid) -> Result<Vec<OutputInfo>, JobStoreError>;

    /// One output's name, media type and size, without its bytes.
    async fn output_info(
        &self,
        id: Uuid,
        output_id: &str,
    ) -> Result<Option<OutputInfo>, JobStoreError>;

    /// The bytes of an output from `offset` to the end of the stored part holding it: at
    /// most [`OUTPUT_PART_BYTES`], read without loading the rest of the output. Empty at
    /// or past the output's end; `None` when the output does not exist (or no longer
    /// does: a download racing a dismissal ends there).
    async fn output_part(
        &self,
        id: Uuid,
        output_id: &str,
        offset: u64,
    ) -> Result<Option<Vec<u8>>, JobStoreError>;

    /// A whole output in memory: for small ones (the summary); downloads read
    /// [`JobStore::output_part`] instead.
    async fn output(
        &self,
        id: Uuid,
        output_id: &str,
    ) -> Result<Option<StoredOutput>, JobStoreError>;

    /// Number of jobs in each state (states without jobs are left out).
    async fn count_by_state(&self) -> Result<StateCounts, JobStoreError>;

    /// Answers when the database does.
    async fn ping(&self) -> Result<(), JobStoreError>;
}

/// Inputs as stored: gzip, the encoding named in the `inputs_encoding` column.
pub(crate) const INPUTS_ENCODING: &str = "gzip";

/// Compresses submitted inputs for storage (off the async threads: inputs may be tens of
/// megabytes).
pub(crate) async fn encode_inputs(inputs: &[u8]) -> Result<Vec<u8>, JobStoreError> {
    use std::io::Write as _;
    let inputs = inputs.to_vec();
    tokio::task::spawn_blocking(move || {
        let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        encoder.write_all(&inputs)?;
        encoder.finish()
    })
    .await
    .map_err(|e| JobStoreError::Corrupt(format!("compressing inputs: {e}")))?
    .map_err(|e| JobStoreError::Corrupt(format!("compressing inputs: {e}")))
}

/// `inputs` as JSON, compressed as stored (gzip), written straight into the compressor so
/// the uncompressed JSON is never held whole. CPU work for a blocking thread.
pub fn compress_json_inputs(inputs: &impl Serialize) -> std::io::Result<Vec<u8>> {
    let encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    let mut writer = std::io::BufWriter::with_capacity(64 * 1024, encoder);
    serde_json::to_writer(&mut writer, inputs)?;
    writer.into_inner().map_err(|e| e.into_error())?.finish()
}

/// The submitted bytes of inputs stored with `encoding`.
pub(crate) async fn decode_inputs(
    stored: Vec<u8>,
    encoding: &str,
) -> Result<Vec<u8>, JobStoreError> {
    use std::io::Read as _;
    match encoding {
        "identity" => Ok(stored),
        INPUTS_ENCODING => tokio::task::spawn_blocking(move || {
            let mut inputs = Vec::new();
            flate2::read::GzDecoder::new(stored.as_slice()).read_to_end(&mut inputs)?;
            Ok::<_, std::io::Error>(inputs)
        })
        .await
        .map_err(|e| JobStoreError::Corrupt(format!("decompressing inputs: {e}")))?
        .map_err(|e| JobStoreError::Corrupt(format!("decompressing inputs: {e}"))),
        other => Err(JobStoreError::Corrupt(format!(
            "unknown inputs encoding {other:?}"
        ))),
    }
}

/// An output's bytes cut into the parts it is stored as: `(offset of the first byte,
/// bytes)`, every part [`OUTPUT_PART_BYTES`] long but the last; none for no bytes.
pub(crate) fn output_parts(bytes: &[u8]) -> impl Iterator<Item = (i64, &[u8])> {
    bytes
        .chunks(OUTPUT_PART_BYTES)
        .enumerate()
        .map(|(i, part)| ((i * OUTPUT_PART_BYTES) as i64, part))
}

/// The bytes from `offset` of the stored part that starts at `start` (the last part
/// starting at or before `offset`): empty when `offset` lies past its end, which is past
/// the output's end.
pub(crate) fn part_from(start: i64, mut part: Vec<u8>, offset: u64) -> Vec<u8> {
    let skip = usize::try_from(offset.saturating_sub(start.max(0) as u64)).unwrap_or(usize::MAX);
    if skip >= part.len() {
        return Vec::new();
    }
    part.drain(..skip);
    part
}

/// An output put back together from its parts in order; `None` when they do not add up
/// to its size (a dismissal or the retention sweep deleted them meanwhile).
pub(crate) fn whole_output(
    info: OutputInfo,
    parts: impl Iterator<Item = Vec<u8>>,
) -> Option<StoredOutput> {
    let mut bytes = Vec::with_capacity(usize::try_from(info.size_bytes).unwrap_or(0));
    for part in parts {
        bytes.extend_from_slice(&part);
    }
    (bytes.len() as i64 == info.size_bytes).then_some(StoredOutput {
        id: info.id,
        file_name: info.file_name,
        media_type: info.media_type,
        bytes,
    })
}

/// `states` as the comma-separated list the stores' listing queries take.
pub(crate) fn state_list(states: &[JobState]) -> String {
    states
        .iter()
        .map(|s| s.as_str())
        .collect::<Vec<_>>()
        .join(",")
}

/// Milliseconds since the Unix epoch, the clock every store write uses.
pub fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}

/// Opens the store a URL names: `sqlite://PATH` (created if missing) or
/// `postgres://...`. The schema is migrated to the newest version (`migrations/`).
pub async fn open_store(url: &str) -> Result<Arc<dyn JobStore>, JobStoreError> {
    if url.starts_with("sqlite:") {
        Ok(Arc::new(SqliteStore::connect(url).await?))
    } else if url.starts_with("postgres://") || url.starts_with("postgresql://") {
        Ok(Arc::new(PostgresStore::connect(url).await?))
    } else {
        Err(JobStoreError::UnsupportedUrl(url.to_string()))
    }
}
