-- The job queue as first released: jobs with their inputs, and their outputs as blobs.
-- IF NOT EXISTS so that a database created before migrations were kept (by the same
-- statements, run at every start) is adopted as it is, its jobs untouched.
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    state TEXT NOT NULL,
    message TEXT NOT NULL DEFAULT '',
    progress BIGINT NOT NULL DEFAULT 0,
    inputs BYTEA NOT NULL,
    attempt BIGINT NOT NULL DEFAULT 0,
    released BIGINT NOT NULL DEFAULT 0,
    max_attempts BIGINT NOT NULL,
    failure TEXT,
    lease_owner TEXT,
    lease_expires_ms BIGINT,
    created_ms BIGINT NOT NULL,
    started_ms BIGINT,
    finished_ms BIGINT,
    updated_ms BIGINT NOT NULL
);

CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state, created_ms);

CREATE TABLE IF NOT EXISTS job_outputs (
    job_id TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    output_id TEXT NOT NULL,
    file_name TEXT NOT NULL,
    media_type TEXT NOT NULL,
    bytes BYTEA NOT NULL,
    PRIMARY KEY (job_id, output_id)
);
