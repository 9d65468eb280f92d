//! The job database's versioned migrations (`migrations/sqlite`, `migrations/postgres`):
//! a fresh database migrates to the newest version, a database made by the release
//! before migrations were kept is adopted with its jobs, and a second start is a no-op.
//!
//! PostgreSQL runs when `WELLMESH_TEST_DATABASE_URL` (or `DATABASE_URL`) is set; each
//! test gets a fresh schema. Under `CI` a missing URL is a failure, not a skip.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use sqlx::postgres::{PgConnectOptions, PgPoolOptions};
use sqlx::sqlite::{SqliteConnectOptions, SqlitePoolOptions};
use uuid::Uuid;
use wellmesh::jobs::{JobState, JobStore, OUTPUT_PART_BYTES, PostgresStore, SqliteStore};

/// The schema as the service created it, with `CREATE TABLE IF NOT EXISTS` at every
/// start, before its changes were kept as migrations (SQLite spelling).
const UNVERSIONED_SQLITE: &[&str] = &[
    "CREATE TABLE IF NOT EXISTS jobs (
        id TEXT PRIMARY KEY, state TEXT NOT NULL, message TEXT NOT NULL DEFAULT '',
        progress INTEGER NOT NULL DEFAULT 0, inputs BLOB NOT NULL,
        attempt INTEGER NOT NULL DEFAULT 0, released INTEGER NOT NULL DEFAULT 0,
        max_attempts INTEGER NOT NULL, failure TEXT, lease_owner TEXT,
        lease_expires_ms INTEGER, created_ms INTEGER NOT NULL, started_ms INTEGER,
        finished_ms INTEGER, updated_ms INTEGER NOT NULL)",
    "CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state, created_ms)",
    "CREATE TABLE IF NOT EXISTS job_outputs (
        job_id TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
        output_id TEXT NOT NULL, file_name TEXT NOT NULL, media_type TEXT NOT NULL,
        bytes BLOB NOT NULL, PRIMARY KEY (job_id, output_id))",
];

/// The same unversioned schema in PostgreSQL's spelling.
const UNVERSIONED_POSTGRES: &[&str] = &[
    "CREATE TABLE IF NOT EXISTS jobs (
        id TEXT PRIMARY KEY, state TEXT NOT NULL, message TEXT NOT NULL DEFAULT '',
        progress BIGINT NOT NULL DEFAULT 0, inputs BYTEA NOT NULL,
        attempt BIGINT NOT NULL DEFAULT 0, released BIGINT NOT NULL DEFAULT 0,
        max_attempts BIGINT NOT NULL, failure TEXT, lease_owner TEXT,
        lease_expires_ms BIGINT, created_ms BIGINT NOT NULL, started_ms BIGINT,
        finished_ms BIGINT, updated_ms BIGINT NOT NULL)",
    "CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state, created_ms)",
    "CREATE TABLE IF NOT EXISTS job_outputs (
        job_id TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
        output_id TEXT NOT NULL, file_name TEXT NOT NULL, media_type TEXT NOT NULL,
        bytes BYTEA NOT NULL, PRIMARY KEY (job_id, output_id))",
];

/// A finished job with one output, as the unversioned release stored it: the job's
/// inputs and the output's bytes are bound as `$1` (SQLite reads `$1` as a parameter too).
const OLD_JOB: &str = "INSERT INTO jobs (id, state, message, progress, inputs, attempt,
        max_attempts, created_ms, started_ms, finished_ms, updated_ms)
     VALUES ('4a0f5e3c-1b2d-4e6f-8a9b-0c1d2e3f4a5b', 'successful', 'done', 100, $1, 1, 3,
        1000, 1100, 1200, 1200)";
const OLD_OUTPUT: &str = "INSERT INTO job_outputs (job_id, output_id, file_name, media_type, bytes)
     VALUES ('4a0f5e3c-1b2d-4e6f-8a9b-0c1d2e3f4a5b', 'summary', 'summary.json',
        'application/json', $1)";
const OLD_GLB: &str = "INSERT INTO job_outputs (job_id, output_id, file_name, media_type, bytes)
     VALUES ('4a0f5e3c-1b2d-4e6f-8a9b-0c1d2e3f4a5b', 'glb', 'bodies.glb',
        'model/gltf-binary', $1)";
const OLD_JOB_ID: &str = "4a0f5e3c-1b2d-4e6f-8a9b-0c1d2e3f4a5b";
const OLD_INPUTS: &[u8] = br#"{"thresholds":[0.5],"samples_csv":"well,x,y,z,value\n"}"#;
const OLD_SUMMARY: &[u8] = br#"{"shells":[]}"#;

/// An output the old release stored as one blob, longer than two of the parts outputs
/// are stored in since migration 0004.
fn old_glb() -> Vec<u8> {
    (0..2 * OUTPUT_PART_BYTES + 777)
        .map(|i| (i * 13 % 253) as u8)
        .collect()
}

/// The versions of the migrations shipped for a backend, from their file names.
fn shipped_versions(backend: &str) -> Vec<i64> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("migrations")
        .join(backend);
    let mut versions: Vec<i64> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".sql"))
        .map(|name| name.split('_').next().unwrap().parse().unwrap())
        .collect();
    versions.sort_unstable();
    assert!(!versions.is_empty(), "no migrations in {}", dir.display());
    versions
}

fn sqlite_url() -> String {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("migrations-{}", Uuid::new_v4().simple()));
    std::fs::create_dir_all(&dir).unwrap();
    format!("sqlite://{}", dir.join("jobs.db").display())
}

/// `(version, installed_on)` of every applied migration, by version.
async fn sqlite_applied(url: &str) -> Vec<(i64, String)> {
    let pool = SqlitePoolOptions::new()
        .connect_with(SqliteConnectOptions::from_str(url).unwrap())
        .await
        .unwrap();
    let rows = sqlx::query_as(
        "SELECT version, CAST(installed_on AS TEXT) FROM _sqlx_migrations
         WHERE success ORDER BY version",
    )
    .fetch_all(&pool)
    .await
    .unwrap();
    pool.close().await;
    rows
}

async fn assert_old_job_kept(store: &dyn JobStore) {
    let id = Uuid::parse_str(OLD_JOB_ID).unwrap();
    let job = store.get(id).await.unwrap().expect("the old job survives");
    assert_eq!(job.state, JobState::Successful);
    assert_eq!(job.message, "done");
    let inputs = store.inputs(id).await.unwrap().unwrap();
    assert_eq!(inputs, OLD_INPUTS);
    let summary = store.output(id, "summary").await.unwrap().unwrap();
    assert_eq!(summary.bytes, OLD_SUMMARY);
    // The old blob was cut into parts: whole, part by part, and its size kept.
    let glb = old_glb();
    assert_eq!(store.output(id, "glb").await.unwrap().unwrap().bytes, glb);
    let info = store.output_info(id, "glb").await.unwrap().unwrap();
    assert_eq!(info.size_bytes, glb.len() as i64);
    let offset = OUTPUT_PART_BYTES + 3;
    let part = store
        .output_part(id, "glb", offset as u64)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(part, glb[offset..2 * OUTPUT_PART_BYTES]);
}

#[tokio::test]
async fn a_fresh_sqlite_database_migrates_to_the_newest_version() {
    let url = sqlite_url();
    let store = SqliteStore::connect(&url).await.unwrap();
    assert!(store.list(10).await.unwrap().is_empty());
    let applied: Vec<i64> = sqlite_applied(&url)
        .await
        .into_iter()
        .map(|r| r.0)
        .collect();
    assert_eq!(applied, shipped_versions("sqlite"));
}

#[tokio::test]
async fn an_unversioned_sqlite_database_is_adopted_with_its_jobs() {
    let url = sqlite_url();
    let options = SqliteConnectOptions::from_str(&url)
        .unwrap()
        .create_if_missing(true);
    let pool = SqlitePoolOptions::new()
        .connect_with(options)
        .await
        .unwrap();
    for statement in UNVERSIONED_SQLITE {
        sqlx::query(statement).execute(&pool).await.unwrap();
    }
    let glb = old_glb();
    for (statement, bytes) in [
        (OLD_JOB, OLD_INPUTS),
        (OLD_OUTPUT, OLD_SUMMARY),
        (OLD_GLB, glb.as_slice()),
    ] {
        sqlx::query(statement)
            .bind(bytes)
            .execute(&pool)
            .await
            .unwrap();
    }
    pool.close().await;

    let store = SqliteStore::connect(&url).await.unwrap();

    assert_old_job_kept(&store).await;
    let applied: Vec<i64> = sqlite_applied(&url)
        .await
        .into_iter()
        .map(|r| r.0)
        .collect();
    assert_eq!(applied, shipped_versions("sqlite"));
}

#[tokio::test]
async fn migrating_a_sqlite_database_twice_changes_nothing() {
    let url = sqlite_url();
    let first = SqliteStore::connect(&url).await.unwrap();
    let job = first.submit(b"{}", 3, None, 5).await.unwrap();
    let applied = sqlite_applied(&url).await;

    let second = SqliteStore::connect(&url).await.unwrap();

    assert_eq!(sqlite_applied(&url).await, applied);
    assert_eq!(second.get(job.id).await.unwrap(), Some(job));
}

/// A URL and a fresh schema name, or `None` (a skip outside CI) without a database.
fn postgres_target() -> Option<(String, String)> {
    let url = std::env::var("WELLMESH_TEST_DATABASE_URL")
        .or_else(|_| std::env::var("DATABASE_URL"))
        .ok();
    let Some(url) = url else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must set WELLMESH_TEST_DATABASE_URL to run the PostgreSQL migrations"
        );
        eprintln!("PostgreSQL migrations skipped: set WELLMESH_TEST_DATABASE_URL");
        return None;
    };
    Some((url, format!("test_{}", Uuid::new_v4().simple())))
}

/// Creates the schema and runs the unversioned release's statements and its one job in it.
async fn postgres_unversioned(url: &str, schema: &str) {
    let admin = PgPoolOptions::new()
        .max_connections(1)
        .connect_with(PgConnectOptions::from_str(url).unwrap())
        .await
        .unwrap();
    sqlx::query(&format!("CREATE SCHEMA IF NOT EXISTS \"{schema}\""))
        .execute(&admin)
        .await
        .unwrap();
    admin.close().await;
    let options = PgConnectOptions::from_str(url)
        .unwrap()
        .options([("search_path", schema)]);
    let pool = PgPoolOptions::new()
        .max_connections(1)
        .connect_with(options)
        .await
        .unwrap();
    for statement in UNVERSIONED_POSTGRES {
        sqlx::query(statement).execute(&pool).await.unwrap();
    }
    let glb = old_glb();
    for (statement, bytes) in [
        (OLD_JOB, OLD_INPUTS),
        (OLD_OUTPUT, OLD_SUMMARY),
        (OLD_GLB, glb.as_slice()),
    ] {
        sqlx::query(statement)
            .bind(bytes)
            .execute(&pool)
            .await
            .unwrap();
    }
    pool.close().await;
}

async fn postgres_applied(url: &str, schema: &str) -> Vec<(i64, String)> {
    let options = PgConnectOptions::from_str(url)
        .unwrap()
        .options([("search_path", schema)]);
    let pool = PgPoolOptions::new()
        .max_connections(1)
        .connect_with(options)
        .await
        .unwrap();
    let rows = sqlx::query_as(
        "SELECT version, installed_on::TEXT FROM _sqlx_migrations
         WHERE success ORDER BY version",
    )
    .fetch_all(&pool)
    .await
    .unwrap();
    pool.close().await;
    rows
}

#[tokio::test]
async fn a_fresh_postgres_schema_migrates_to_the_newest_version() {
    let Some((url, schema)) = postgres_target() else {
        return;
    };
    let store = PostgresStore::connect_in_schema(&url, &schema)
        .await
        .unwrap();
    assert!(store.list(10).await.unwrap().is_empty());
    let applied: Vec<i64> = postgres_applied(&url, &schema)
        .await
        .into_iter()
        .map(|r| r.0)
        .collect();
    assert_eq!(applied, shipped_versions("postgres"));
}

#[tokio::test]
async fn an_unversioned_postgres_schema_is_adopted_with_its_jobs() {
    let Some((url, schema)) = postgres_target() else {
        return;
    };
    postgres_unversioned(&url, &schema).await;

    let store = PostgresStore::connect_in_schema(&url, &schema)
        .await
        .unwrap();

    assert_old_job_kept(&store).await;
    let applied: Vec<i64> = postgres_applied(&url, &schema)
        .await
        .into_iter()
        .map(|r| r.0)
        .collect();
    assert_eq!(applied, shipped_versions("postgres"));
}

#[tokio::test]
async fn migrating_a_postgres_schema_twice_changes_nothing() {
    let Some((url, schema)) = postgres_target() else {
        return;
    };
    let first = PostgresStore::connect_in_schema(&url, &schema)
        .await
        .unwrap();
    let job = first.submit(b"{}", 3, None, 5).await.unwrap();
    let applied = postgres_applied(&url, &schema).await;

    let second = PostgresStore::connect_in_schema(&url, &schema)
        .await
        .unwrap();

    assert_eq!(postgres_applied(&url, &schema).await, applied);
    assert_eq!(second.get(job.id).await.unwrap(), Some(job));
}
