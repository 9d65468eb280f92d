//! The scale-out [`JobStore`]: PostgreSQL shared by any number of API and worker nodes.
//!
//! Invariant: a job is claimed by exactly one worker: the claim locks the oldest queued
//! row with `FOR UPDATE SKIP LOCKED` and moves it to `running` in the same statement.

use std::str::FromStr;
use std::time::Duration;

use async_trait::async_trait;
use sqlx::migrate::Migrator;
use sqlx::postgres::{PgConnectOptions, PgConnection, PgPool, PgPoolOptions, PgRow};
use sqlx::{Connection, Row};
use uuid::Uuid;

use super::{
    ClaimedJob, Dismissal, FailureKind, INPUTS_ENCODING, JobQuery, JobRecord, JobState, JobStore,
    JobStoreError, Lease, OutputInfo, StateCounts, StorageUse, StoredOutput, decode_inputs,
    output_parts, part_from, state_list, whole_output,
};

/// The schema's versioned migrations (`migrations/postgres/`), embedded in the binary.
static MIGRATOR: Migrator = sqlx::migrate!("migrations/postgres");

/// Longest wait for a pooled connection (or a new one) before a request fails with 503.
const ACQUIRE_TIMEOUT: Duration = Duration::from_secs(2);
/// Longest any one statement may run on the server.
const STATEMENT_TIMEOUT: Duration = Duration::from_secs(30);

/// The advisory lock submits with a queue limit take in turn.
const QUEUE_LIMIT_LOCK: i64 = 7_236_002;

const JOB_COLUMNS: &str = "id, state, message, progress, attempt, max_attempts, failure, \
     failure_field, owner, created_ms, started_ms, finished_ms, updated_ms";

/// PostgreSQL-backed [`JobStore`].
#[derive(Debug, Clone)]
pub struct PostgresStore {
    pool: PgPool,
}

impl PostgresStore {
    /// Connects to the database a `postgres://` URL names and brings its schema to the
    /// newest migration.
    pub async fn connect(url: &str) -> Result<Self, JobStoreError> {
        Self::connect_with(PgConnectOptions::from_str(url)?).await
    }

    /// Connects with the tables in `schema` (created if missing): one database can hold
    /// independent queues, which is how the test suite isolates its tests.
    pub async fn connect_in_schema(url: &str, schema: &str) -> Result<Self, JobStoreError> {
        let admin = PgPoolOptions::new()
            .max_connections(1)
            .connect_with(PgConnectOptions::from_str(url)?)
            .await?;
        let quoted = format!("\"{}\"", schema.replace('"', "\"\""));
        sqlx::query(&format!("CREATE SCHEMA IF NOT EXISTS {quoted}"))
            .execute(&admin)
            .await?;
        admin.close().await;
        let options = PgConnectOptions::from_str(url)?.options([("search_path", schema)]);
        Self::connect_with(options).await
    }

    async fn connect_with(options: PgConnectOptions) -> Result<Self, JobStoreError> {
        // Several nodes may start at once: the migrator holds a session advisory lock
        // while it runs. It runs on a connection of its own, closed afterwards, so a
        // failed migration cannot leave that lock held by a pooled connection.
        let mut migrating = PgConnection::connect_with(&options).await?;
        MIGRATOR.run_direct(&mut migrating).await?;
        migrating.close().await?;
        // A dead database shows within ACQUIRE_TIMEOUT (a new connection is refused, or
        // none frees up), and a hung statement ends after STATEMENT_TIMEOUT.
        let options = options.options([(
            "statement_timeout",
            STATEMENT_TIMEOUT.as_millis().to_string(),
        )]);
        let pool = PgPoolOptions::new()
            .max_connections(8)
            .acquire_timeout(ACQUIRE_TIMEOUT)
            .connect_with(options)
            .await?;
        Ok(PostgresStore { pool })
    }
}

fn record(row: &PgRow) -> Result<JobRecord, JobStoreError> {
    let id: String = row.try_get("id")?;
    Ok(JobRecord {
        id: Uuid::parse_str(&id)
            .map_err(|e| JobStoreError::Corrupt(format!("job id {id:?}: {e}")))?,
        state: JobState::parse(&row.try_get::<String, _>("state")?)?,
        message: row.try_get("message")?,
        progress: row.try_get::<i64, _>("progress")?.clamp(0, 100) as u8,
        attempt: row.try_get("attempt")?,
        max_attempts: row.try_get("max_attempts")?,
        failure: row
            .try_get::<Option<String>, _>("failure")?
            .map(|f| FailureKind::parse(&f)),
        failure_field: row.try_get("failure_field")?,
        owner: row.try_get("owner")?,
        created_ms: row.try_get("created_ms")?,
        started_ms: row.try_get("started_ms")?,
        finished_ms: row.try_get("finished_ms")?,
        updated_ms: row.try_get("updated_ms")?,
    })
}

fn output_info(row: &PgRow) -> Result<OutputInfo, JobStoreError> {
    Ok(OutputInfo {
        id: row.try_get("output_id")?,
        file_name: row.try_get("file_name")?,
        media_type: row.try_get("media_type")?,
        size_bytes: row.try_get("size_bytes")?,
    })
}

#[async_trait]
impl JobStore for PostgresStore {
    async fn submit_compressed(
        &self,
        compressed_inputs: &[u8],
        owner: Option<&str>,
        max_attempts: i64,
        max_queued: Option<i64>,
        now_ms: i64,
    ) -> Result<JobRecord, JobStoreError> {
        let id = Uuid::new_v4();
        let mut tx = self.pool.begin().await?;
        if max_queued.is_some() {
            // Under READ COMMITTED two submits could both count 99 and both insert:
            // submits with a limit take turns (the lock ends with the transaction).
            sqlx::query("SELECT pg_advisory_xact_lock($1)")
                .bind(QUEUE_LIMIT_LOCK)
                .execute(&mut *tx)
                .await?;
        }
        let inserted = sqlx::query(
            "INSERT INTO jobs (id, state, message, inputs, inputs_encoding, owner, max_attempts,
                created_ms, updated_ms)
             SELECT $1, 'accepted', 'queued', $2, $6, $7, $3, $4, $4
             WHERE $5::BIGINT IS NULL
                OR (SELECT count(*) FROM jobs WHERE state = 'accepted') < $5",
        )
        .bind(id.to_string())
        .bind(compressed_inputs)
        .bind(max_attempts)
        .bind(now_ms)
        .bind(max_queued)
        .bind(INPUTS_ENCODING)
        .bind(owner)
        .execute(&mut *tx)
        .await?;
        if inserted.rows_affected() == 0 {
            let queued: i64 =
                sqlx::query_scalar("SELECT count(*) FROM jobs WHERE state = 'accepted'")
                    .fetch_one(&mut *tx)
                    .await?;
            tx.rollback().await?;
            return Err(JobStoreError::QueueFull { queued });
        }
        tx.commit().await?;
        self.get(id)
            .await?
            .ok_or_else(|| JobStoreError::Corrupt(format!("job {id} vanished after insert")))
    }

    async fn get(&self, id: Uuid) -> Result<Option<JobRecord>, JobStoreError> {
        let row = sqlx::query(&format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1"))
            .bind(id.to_string())
            .fetch_optional(&self.pool)
            .await?;
        row.as_ref().map(record).transpose()
    }

    async fn list(&self, limit: i64) -> Result<Vec<JobRecord>, JobStoreError> {
        let rows = sqlx::query(&format!(
            "SELECT {JOB_COLUMNS} FROM jobs ORDER BY created_ms DESC, id LIMIT $1"
        ))
        .bind(limit)
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(record).collect()
    }

    async fn list_jobs(&self, query: &JobQuery) -> Result<Vec<JobRecord>, JobStoreError> {
        let rows = sqlx::query(&format!(
            "SELECT {JOB_COLUMNS} FROM jobs
             WHERE state != 'dismissed'
               AND ($2 = '' OR state = ANY(string_to_array($2, ',')))
               AND ($3::TEXT IS NULL OR owner = $3)
               AND ($4::BIGINT IS NULL OR created_ms < $4 OR (created_ms = $4 AND id > $5))
             ORDER BY created_ms DESC, id LIMIT $1"
        ))
        .bind(query.limit)
        .bind(state_list(&query.states))
        .bind(query.owner.as_deref())
        .bind(query.after.map(|p| p.created_ms))
        .bind(query.after.map(|p| p.id.to_string()))
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(record).collect()
    }

    async fn delete_finished_before(&self, finished_before_ms: i64) -> Result<u64, JobStoreError> {
        // Rows are deleted; autovacuum makes their space reusable.
        let deleted = sqlx::query(
            "DELETE FROM jobs WHERE state IN ('successful', 'failed', 'dismissed')
                AND finished_ms < $1",
        )
        .bind(finished_before_ms)
        .execute(&self.pool)
        .await?
        .rows_affected();
        Ok(deleted)
    }

    async fn storage(&self) -> Result<StorageUse, JobStoreError> {
        let (jobs, input_bytes): (i64, i64) = sqlx::query_as(
            "SELECT count(*), coalesce(sum(octet_length(inputs)), 0)::BIGINT FROM jobs",
        )
        .fetch_one(&self.pool)
        .await?;
        let output_bytes: i64 =
            sqlx::query_scalar("SELECT coalesce(sum(size_bytes), 0)::BIGINT FROM job_outputs")
                .fetch_one(&self.pool)
                .await?;
        let largest_job_bytes: i64 = sqlx::query_scalar(
            "SELECT coalesce(max(octet_length(j.inputs) + coalesce(
                (SELECT sum(o.size_bytes) FROM job_outputs o WHERE o.job_id = j.id), 0)), 0)::BIGINT
             FROM jobs j",
        )
        .fetch_one(&self.pool)
        .await?;
        Ok(StorageUse {
            jobs,
            input_bytes,
            output_bytes,
            largest_job_bytes,
            file_bytes: None,
        })
    }

    async fn claim_next_job(
        &self,
        worker: &str,
        now_ms: i64,
        lease_ms: i64,
    ) -> Result<Option<ClaimedJob>, JobStoreError> {
        sqlx::query(
            "UPDATE jobs SET
                state = CASE WHEN attempt - released >= max_attempts THEN 'failed' ELSE 'accepted' END,
                failure = CASE WHEN attempt - released >= max_attempts THEN 'lease_expired' ELSE failure END,
                message = CASE WHEN attempt - released >= max_attempts
                    THEN 'the workers running this job stopped answering ' || (attempt - released)::TEXT || ' times'
                    ELSE 're-queued: the worker running it stopped answering' END,
                finished_ms = CASE WHEN attempt - released >= max_attempts THEN $1 ELSE NULL END,
                lease_owner = NULL, lease_expires_ms = NULL, updated_ms = $1
             WHERE state = 'running' AND lease_expires_ms < $1",
        )
        .bind(now_ms)
        .execute(&self.pool)
        .await?;
        let row = sqlx::query(
            "UPDATE jobs SET state = 'running', attempt = attempt + 1, lease_owner = $1,
                lease_expires_ms = $2, started_ms = coalesce(started_ms, $3), updated_ms = $3,
                progress = 0, message = 'started'
             WHERE id = (SELECT id FROM jobs WHERE state = 'accepted'
                         ORDER BY created_ms, id LIMIT 1 FOR UPDATE SKIP LOCKED)
             RETURNING id, attempt, inputs, inputs_encoding",
        )
        .bind(worker)
        .bind(now_ms + lease_ms)
        .bind(now_ms)
        .fetch_optional(&self.pool)
        .await?;
        let Some(row) = row else { return Ok(None) };
        let id: String = row.try_get("id")?;
        Ok(Some(ClaimedJob {
            lease: Lease {
                job_id: Uuid::parse_str(&id)
                    .map_err(|e| JobStoreError::Corrupt(format!("job id {id:?}: {e}")))?,
                attempt: row.try_get("attempt")?,
            },
            inputs: decode_inputs(
                row.try_get("inputs")?,
                &row.try_get::<String, _>("inputs_encoding")?,
            )
            .await?,
        }))
    }

    async fn record_heartbeat(
        &self,
        lease: Lease,
        progress: u8,
        message: &str,
        now_ms: i64,
        lease_ms: i64,
    ) -> Result<bool, JobStoreError> {
        let done = sqlx::query(
            "UPDATE jobs SET lease_expires_ms = $1, progress = $2, message = $3, updated_ms = $4
             WHERE id = $5 AND attempt = $6 AND state = 'running'",
        )
        .bind(now_ms + lease_ms)
        .bind(i64::from(progress.min(100)))
        .bind(message)
        .bind(now_ms)
        .bind(lease.job_id.to_string())
        .bind(lease.attempt)
        .execute(&self.pool)
        .await?;
        Ok(done.rows_affected() == 1)
    }

    async fn mark_succeeded(
        &self,
        lease: Lease,
        outputs: &[StoredOutput],
        now_ms: i64,
    ) -> Result<bool, JobStoreError> {
        let mut tx = self.pool.begin().await?;
        let done = sqlx::query(
            "UPDATE jobs SET state = 'successful', progress = 100, message = 'done',
                finished_ms = $1, updated_ms = $1, lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = $2 AND attempt = $3 AND state = 'running'",
        )
        .bind(now_ms)
        .bind(lease.job_id.to_string())
        .bind(lease.attempt)
        .execute(&mut *tx)
        .await?;
        if done.rows_affected() != 1 {
            tx.rollback().await?;
            return Ok(false);
        }
        sqlx::query("DELETE FROM job_outputs WHERE job_id = $1")
            .bind(lease.job_id.to_string())
            .execute(&mut *tx)
            .await?;
        for output in outputs {
            sqlx::query(
                "INSERT INTO job_outputs (job_id, output_id, file_name, media_type, size_bytes)
                 VALUES ($1, $2, $3, $4, $5)",
            )
            .bind(lease.job_id.to_string())
            .bind(&output.id)
            .bind(&output.file_name)
            .bind(&output.media_type)
            .bind(output.bytes.len() as i64)
            .execute(&mut *tx)
            .await?;
            for (start, part) in output_parts(&output.bytes) {
                sqlx::query(
                    "INSERT INTO job_output_parts (job_id, output_id, start_byte, bytes)
                     VALUES ($1, $2, $3, $4)",
                )
                .bind(lease.job_id.to_string())
                .bind(&output.id)
                .bind(start)
                .bind(part)
                .execute(&mut *tx)
                .await?;
            }
        }
        tx.commit().await?;
        Ok(true)
    }

    async fn mark_failed(
        &self,
        lease: Lease,
        kind: FailureKind,
        field: Option<&str>,
        message: &str,
        now_ms: i64,
    ) -> Result<bool, JobStoreError> {
        let done = sqlx::query(
            "UPDATE jobs SET state = 'failed', failure = $1, failure_field = $6, message = $2,
                finished_ms = $3, updated_ms = $3, lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = $4 AND attempt = $5 AND state = 'running'",
        )
        .bind(kind.as_str())
        .bind(message)
        .bind(now_ms)
        .bind(lease.job_id.to_string())
        .bind(lease.attempt)
        .bind(field)
        .execute(&self.pool)
        .await?;
        Ok(done.rows_affected() == 1)
    }

    async fn release(&self, lease: Lease, now_ms: i64) -> Result<bool, JobStoreError> {
        let done = sqlx::query(
            "UPDATE jobs SET state = 'accepted', released = released + 1, progress = 0,
                message = 're-queued: the worker running it shut down', updated_ms = $1,
                lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = $2 AND attempt = $3 AND state = 'running'",
        )
        .bind(now_ms)
        .bind(lease.job_id.to_string())
        .bind(lease.attempt)
        .execute(&self.pool)
        .await?;
        Ok(done.rows_affected() == 1)
    }

    async fn request_dismissal(&self, id: Uuid, now_ms: i64) -> Result<Dismissal, JobStoreError> {
        let mut tx = self.pool.begin().await?;
        let done = sqlx::query(
            "UPDATE jobs SET state = 'dismissed', message = 'dismissed', inputs = ''::BYTEA,
                inputs_encoding = 'identity',
                finished_ms = coalesce(finished_ms, $1), updated_ms = $1,
                lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = $2",
        )
        .bind(now_ms)
        .bind(id.to_string())
        .execute(&mut *tx)
        .await?;
        if done.rows_affected() == 0 {
            tx.rollback().await?;
            return Ok(Dismissal::NotFound);
        }
        sqlx::query("DELETE FROM job_outputs WHERE job_id = $1")
            .bind(id.to_string())
            .execute(&mut *tx)
            .await?;
        let row = sqlx::query(&format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1"))
            .bind(id.to_string())
            .fetch_one(&mut *tx)
            .await?;
        let job = record(&row)?;
        tx.commit().await?;
        Ok(Dismissal::Dismissed(job))
    }

    async fn inputs(&self, id: Uuid) -> Result<Option<Vec<u8>>, JobStoreError> {
        let row: Option<(Vec<u8>, String)> =
            sqlx::query_as("SELECT inputs, inputs_encoding FROM jobs WHERE id = $1")
                .bind(id.to_string())
                .fetch_optional(&self.pool)
                .await?;
        match row {
            Some((stored, encoding)) => Ok(Some(decode_inputs(stored, &encoding).await?)),
            None => Ok(None),
        }
    }

    async fn outputs(&self, id: Uuid) -> Result<Vec<OutputInfo>, JobStoreError> {
        let rows = sqlx::query(
            "SELECT output_id, file_name, media_type, size_bytes
             FROM job_outputs WHERE job_id = $1 ORDER BY output_id",
        )
        .bind(id.to_string())
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(output_info).collect()
    }

    async fn output_info(
        &self,
        id: Uuid,
        output_id: &str,
    ) -> Result<Option<OutputInfo>, JobStoreError> {
        let row = sqlx::query(
            "SELECT output_id, file_name, media_type, size_bytes
             FROM job_outputs WHERE job_id = $1 AND output_id = $2",
        )
        .bind(id.to_string())
        .bind(output_id)
        .fetch_optional(&self.pool)
        .await?;
        row.as_ref().map(output_info).transpose()
    }

    async fn output_part(
        &self,
        id: Uuid,
        output_id: &str,
        offset: u64,
    ) -> Result<Option<Vec<u8>>, JobStoreError> {
        let offset_i64 = i64::try_from(offset).unwrap_or(i64::MAX);
        let part: Option<(i64, Vec<u8>)> = sqlx::query_as(
            "SELECT start_byte, bytes FROM job_output_parts
             WHERE job_id = $1 AND output_id = $2 AND start_byte <= $3
             ORDER BY start_byte DESC LIMIT 1",
        )
        .bind(id.to_string())
        .bind(output_id)
        .bind(offset_i64)
        .fetch_optional(&self.pool)
        .await?;
        if let Some((start, bytes)) = part {
            return Ok(Some(part_from(start, bytes, offset)));
        }
        // No part: an output of no bytes, or none at all.
        Ok(self.output_info(id, output_id).await?.map(|_| Vec::new()))
    }

    async fn output(
        &self,
        id: Uuid,
        output_id: &str,
    ) -> Result<Option<StoredOutput>, JobStoreError> {
        let Some(info) = self.output_info(id, output_id).await? else {
            return Ok(None);
        };
        let parts: Vec<(Vec<u8>,)> = sqlx::query_as(
            "SELECT bytes FROM job_output_parts WHERE job_id = $1 AND output_id = $2
             ORDER BY start_byte",
        )
        .bind(id.to_string())
        .bind(output_id)
        .fetch_all(&self.pool)
        .await?;
        Ok(whole_output(info, parts.into_iter().map(|(part,)| part)))
    }

    async fn count_by_state(&self) -> Result<StateCounts, JobStoreError> {
        let rows = sqlx::query("SELECT state, count(*) AS n FROM jobs GROUP BY state")
            .fetch_all(&self.pool)
            .await?;
        rows.iter()
            .map(|row| {
                Ok((
                    JobState::parse(&row.try_get::<String, _>("state")?)?,
                    row.try_get("n")?,
                ))
            })
            .collect()
    }

    async fn ping(&self) -> Result<(), JobStoreError> {
        sqlx::query("SELECT 1").execute(&self.pool).await?;
        Ok(())
    }
}
