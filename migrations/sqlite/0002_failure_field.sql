-- The input a failed job's inputs were refused for (`samples_csv`, `thresholds`, ...),
-- where the failure names one, so a job-time failure answers like a refused request.
ALTER TABLE jobs ADD COLUMN failure_field TEXT;
