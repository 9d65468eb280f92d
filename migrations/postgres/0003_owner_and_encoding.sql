-- Who submitted a job (an API key's principal; NULL without keys), and how its inputs
-- are stored: `gzip` for jobs submitted from this version on, `identity` before.
ALTER TABLE jobs ADD COLUMN owner TEXT;
ALTER TABLE jobs ADD COLUMN inputs_encoding TEXT NOT NULL DEFAULT 'identity';
CREATE INDEX IF NOT EXISTS jobs_by_owner ON jobs (owner, created_ms);
CREATE INDEX IF NOT EXISTS jobs_by_finish ON jobs (finished_ms);
