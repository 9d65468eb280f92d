-- The job queue as first released: jobs with their inputs, and their outputs as blobs.
-- IF NOT EXISTS so that a database created before migrations were kept (by the same
-- statements, run at every start) is adopted as it is, its jobs untouched.
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    state TEXT NOT NULL,
    message TEXT NOT NULL DEFAULT '',
    progress INTEGER NOT NULL DEFAULT 0,
    inputs BLOB NOT NULL,
    attempt INTEGER NOT NULL DEFAULT 0,
    released INTEGER NOT NULL DEFAULT 0,
    max_attempts INTEGER NOT NULL,
    failure TEXT,
    lease_owner TEXT,
    lease_expires_ms INTEGER,
    created_ms INTEGER NOT NULL,
    started_ms INTEGER,
    finished_ms INTEGER,
    updated_ms INTEGER NOT NULL
);

CREATE INDEX IF NOT EXISTS jobs_by_state ON jobs (state, created_ms);

CREATE TABLE IF NOT EXISTS job_outputs (
    job_id TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    output_id TEXT NOT NULL,
    file_name TEXT NOT NULL,
    media_type TEXT NOT NULL,
    bytes BLOB NOT NULL,
    PRIMARY KEY (job_id, output_id)
);
