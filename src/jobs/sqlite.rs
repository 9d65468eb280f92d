//! The embedded [`JobStore`]: one SQLite file in the data directory (WAL journal).
//!
//! Invariant: every transaction starts with a write, so SQLite takes its write lock
//! first and `busy_timeout` (not a deadlock) resolves contention between connections.

use std::str::FromStr;
use std::time::Duration;

use async_trait::async_trait;
use sqlx::migrate::Migrator;
use sqlx::sqlite::{
    SqliteAutoVacuum, SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions,
};
use sqlx::{Row, sqlite::SqliteRow};
use uuid::Uuid;

use super::{
    ClaimedJob, Dismissal, FailureKind, INPUTS_ENCODING, JobQuery, JobRecord, JobState, JobStore,
    JobStoreError, Lease, OutputInfo, StateCounts, StorageUse, StoredOutput, decode_inputs,
    output_parts, part_from, state_list, whole_output,
};

/// The schema's versioned migrations (`migrations/sqlite/`), embedded in the binary.
static MIGRATOR: Migrator = sqlx::migrate!("migrations/sqlite");

/// `PRAGMA auto_vacuum`'s answer for incremental auto-vacuum.
const INCREMENTAL_VACUUM: i64 = 2;

const JOB_COLUMNS: &str = "id, state, message, progress, attempt, max_attempts, failure, \
     failure_field, owner, created_ms, started_ms, finished_ms, updated_ms";

/// SQLite-backed [`JobStore`].
#[derive(Debug, Clone)]
pub struct SqliteStore {
    pool: SqlitePool,
}

impl SqliteStore {
    /// Opens (creating if needed) the database a `sqlite://PATH` URL names and brings its
    /// schema to the newest migration.
    pub async fn connect(url: &str) -> Result<Self, JobStoreError> {
        let options = SqliteConnectOptions::from_str(url)?
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .busy_timeout(Duration::from_secs(10))
            .foreign_keys(true)
            .auto_vacuum(SqliteAutoVacuum::Incremental);
        let pool = SqlitePoolOptions::new()
            .max_connections(4)
            .connect_with(options)
            .await?;
        MIGRATOR.run(&pool).await?;
        // The retention sweep gives freed pages back with `PRAGMA incremental_vacuum`,
        // which needs incremental auto-vacuum. A new file gets it from the connect option
        // before its first table; a file made before is converted once here (a VACUUM,
        // which cannot run inside a migration's transaction).
        let mode: i64 = sqlx::query_scalar("PRAGMA auto_vacuum")
            .fetch_one(&pool)
            .await?;
        if mode != INCREMENTAL_VACUUM {
            let mut connection = pool.acquire().await?;
            sqlx::query("PRAGMA auto_vacuum = INCREMENTAL")
                .execute(&mut *connection)
                .await?;
            sqlx::query("VACUUM").execute(&mut *connection).await?;
        }
        Ok(SqliteStore { pool })
    }
}

fn record(row: &SqliteRow) -> Result<JobRecord, JobStoreError> {
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

fn output_info(row: &SqliteRow) -> Result<OutputInfo, JobStoreError> {
    Ok(OutputInfo {
        id: row.try_get("output_id")?,
        file_name: row.try_get("file_name")?,
        media_type: row.try_get("media_type")?,
        size_bytes: row.try_get("size_bytes")?,
    })
}

#[async_trait]
impl JobStore for SqliteStore {
    async fn submit_compressed(
        &self,
        compressed_inputs: &[u8],
        owner: Option<&str>,
        max_attempts: i64,
        max_queued: Option<i64>,
        now_ms: i64,
    ) -> Result<JobRecord, JobStoreError> {
        let id = Uuid::new_v4();
        // One statement counts and inserts: SQLite runs it under its write lock.
        let inserted = sqlx::query(
            "INSERT INTO jobs (id, state, message, inputs, inputs_encoding, owner, max_attempts,
                created_ms, updated_ms)
             SELECT ?1, 'accepted', 'queued', ?2, ?6, ?7, ?3, ?4, ?4
             WHERE ?5 IS NULL OR (SELECT count(*) FROM jobs WHERE state = 'accepted') < ?5",
        )
        .bind(id.to_string())
        .bind(compressed_inputs)
        .bind(max_attempts)
        .bind(now_ms)
        .bind(max_queued)
        .bind(INPUTS_ENCODING)
        .bind(owner)
        .execute(&self.pool)
        .await?;
        if inserted.rows_affected() == 0 {
            let queued: i64 =
                sqlx::query_scalar("SELECT count(*) FROM jobs WHERE state = 'accepted'")
                    .fetch_one(&self.pool)
                    .await?;
            return Err(JobStoreError::QueueFull { queued });
        }
        self.get(id)
            .await?
            .ok_or_else(|| JobStoreError::Corrupt(format!("job {id} vanished after insert")))
    }

    async fn get(&self, id: Uuid) -> Result<Option<JobRecord>, JobStoreError> {
        let row = sqlx::query(&format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1"))
            .bind(id.to_string())
            .fetch_optional(&self.pool)
            .await?;
        row.as_ref().map(record).transpose()
    }

    async fn list(&self, limit: i64) -> Result<Vec<JobRecord>, JobStoreError> {
        let rows = sqlx::query(&format!(
            "SELECT {JOB_COLUMNS} FROM jobs ORDER BY created_ms DESC, id LIMIT ?1"
        ))
        .bind(limit)
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(record).collect()
    }

    async fn list_jobs(&self, query: &JobQuery) -> Result<Vec<JobRecord>, JobStoreError> {
        let rows = sqlx::query(&format!(
            "SELECT {JOB_COLUMNS} FROM jobs
             WHERE ((?2 = '' AND state != 'dismissed') OR (state != 'dismissed' AND instr(',' || ?2 || ',', ',' || state || ',') > 0))
               AND (?3 IS NULL OR owner = ?3)
               AND (?4 IS NULL OR created_ms < ?4 OR (created_ms = ?4 AND id > ?5))
             ORDER BY created_ms DESC, id LIMIT ?1"
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
        let deleted = sqlx::query(
            "DELETE FROM jobs WHERE state IN ('successful', 'failed', 'dismissed')
                AND finished_ms < ?1",
        )
        .bind(finished_before_ms)
        .execute(&self.pool)
        .await?
        .rows_affected();
        if deleted > 0 {
            // Free pages go back to the file system, and the WAL file is emptied.
            sqlx::query("PRAGMA incremental_vacuum")
                .execute(&self.pool)
                .await?;
            sqlx::query("PRAGMA wal_checkpoint(TRUNCATE)")
                .execute(&self.pool)
                .await?;
        }
        Ok(deleted)
    }

    async fn storage(&self) -> Result<StorageUse, JobStoreError> {
        let (jobs, input_bytes): (i64, i64) =
            sqlx::query_as("SELECT count(*), coalesce(sum(length(inputs)), 0) FROM jobs")
                .fetch_one(&self.pool)
                .await?;
        let output_bytes: i64 =
            sqlx::query_scalar("SELECT coalesce(sum(size_bytes), 0) FROM job_outputs")
                .fetch_one(&self.pool)
                .await?;
        let largest_job_bytes: i64 = sqlx::query_scalar(
            "SELECT coalesce(max(length(j.inputs) + coalesce(
                (SELECT sum(o.size_bytes) FROM job_outputs o WHERE o.job_id = j.id), 0)), 0)
             FROM jobs j",
        )
        .fetch_one(&self.pool)
        .await?;
        let pages: i64 = sqlx::query_scalar("PRAGMA page_count")
            .fetch_one(&self.pool)
            .await?;
        let page_size: i64 = sqlx::query_scalar("PRAGMA page_size")
            .fetch_one(&self.pool)
            .await?;
        Ok(StorageUse {
            jobs,
            input_bytes,
            output_bytes,
            largest_job_bytes,
            file_bytes: Some(pages * page_size),
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
                    THEN 'the workers running this job stopped answering ' || (attempt - released) || ' times'
                    ELSE 're-queued: the worker running it stopped answering' END,
                finished_ms = CASE WHEN attempt - released >= max_attempts THEN ?1 ELSE NULL END,
                lease_owner = NULL, lease_expires_ms = NULL, updated_ms = ?1
             WHERE state = 'running' AND lease_expires_ms < ?1",
        )
        .bind(now_ms)
        .execute(&self.pool)
        .await?;
        let row = sqlx::query(
            "UPDATE jobs SET state = 'running', attempt = attempt + 1, lease_owner = ?1,
                lease_expires_ms = ?2, started_ms = coalesce(started_ms, ?3), updated_ms = ?3,
                progress = 0, message = 'started'
             WHERE id = (SELECT id FROM jobs WHERE state = 'accepted'
                         ORDER BY created_ms, id LIMIT 1)
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
            "UPDATE jobs SET lease_expires_ms = ?1, progress = ?2, message = ?3, updated_ms = ?4
             WHERE id = ?5 AND attempt = ?6 AND state = 'running'",
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
                finished_ms = ?1, updated_ms = ?1, lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = ?2 AND attempt = ?3 AND state = 'running'",
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
        sqlx::query("DELETE FROM job_outputs WHERE job_id = ?1")
            .bind(lease.job_id.to_string())
            .execute(&mut *tx)
            .await?;
        for output in outputs {
            sqlx::query(
                "INSERT INTO job_outputs (job_id, output_id, file_name, media_type, size_bytes)
                 VALUES (?1, ?2, ?3, ?4, ?5)",
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
                     VALUES (?1, ?2, ?3, ?4)",
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
            "UPDATE jobs SET state = 'failed', failure = ?1, failure_field = ?6, message = ?2,
                finished_ms = ?3, updated_ms = ?3, lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = ?4 AND attempt = ?5 AND state = 'running'",
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
                message = 're-queued: the worker running it shut down', updated_ms = ?1,
                lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = ?2 AND attempt = ?3 AND state = 'running'",
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
            "UPDATE jobs SET state = 'dismissed', message = 'dismissed', inputs = X'',
                inputs_encoding = 'identity',
                finished_ms = coalesce(finished_ms, ?1), updated_ms = ?1,
                lease_owner = NULL, lease_expires_ms = NULL
             WHERE id = ?2",
        )
        .bind(now_ms)
        .bind(id.to_string())
        .execute(&mut *tx)
        .await?;
        if done.rows_affected() == 0 {
            tx.rollback().await?;
            return Ok(Dismissal::NotFound);
        }
        sqlx::query("DELETE FROM job_outputs WHERE job_id = ?1")
            .bind(id.to_string())
            .execute(&mut *tx)
            .await?;
        let row = sqlx::query(&format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1"))
            .bind(id.to_string())
            .fetch_one(&mut *tx)
            .await?;
        let job = record(&row)?;
        tx.commit().await?;
        Ok(Dismissal::Dismissed(job))
    }

    async fn inputs(&self, id: Uuid) -> Result<Option<Vec<u8>>, JobStoreError> {
        let row: Option<(Vec<u8>, String)> =
            sqlx::query_as("SELECT inputs, inputs_encoding FROM jobs WHERE id = ?1")
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
             FROM job_outputs WHERE job_id = ?1 ORDER BY output_id",
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
             FROM job_outputs WHERE job_id = ?1 AND output_id = ?2",
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
             WHERE job_id = ?1 AND output_id = ?2 AND start_byte <= ?3
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
            "SELECT bytes FROM job_output_parts WHERE job_id = ?1 AND output_id = ?2
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
