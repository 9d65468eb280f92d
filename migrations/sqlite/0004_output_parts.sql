-- Outputs in parts of at most 256 KiB (`OUTPUT_PART_BYTES`), keyed by the offset of their
-- first byte, so a download reads one part at a time instead of the whole blob; the
-- output's size is kept beside its name. Outputs stored before are cut into parts here.
CREATE TABLE job_output_parts (
    job_id TEXT NOT NULL,
    output_id TEXT NOT NULL,
    start_byte INTEGER NOT NULL,
    bytes BLOB NOT NULL,
    PRIMARY KEY (job_id, output_id, start_byte),
    FOREIGN KEY (job_id, output_id) REFERENCES job_outputs (job_id, output_id)
        ON DELETE CASCADE
);

ALTER TABLE job_outputs ADD COLUMN size_bytes INTEGER NOT NULL DEFAULT 0;
UPDATE job_outputs SET size_bytes = length(bytes);

INSERT INTO job_output_parts (job_id, output_id, start_byte, bytes)
WITH RECURSIVE cut (job_id, output_id, start_byte) AS (
    SELECT job_id, output_id, 0 FROM job_outputs WHERE size_bytes > 0
    UNION ALL
    SELECT c.job_id, c.output_id, c.start_byte + 262144
    FROM cut c JOIN job_outputs o ON o.job_id = c.job_id AND o.output_id = c.output_id
    WHERE c.start_byte + 262144 < o.size_bytes
)
SELECT c.job_id, c.output_id, c.start_byte, substr(o.bytes, c.start_byte + 1, 262144)
FROM cut c JOIN job_outputs o ON o.job_id = c.job_id AND o.output_id = c.output_id;

ALTER TABLE job_outputs DROP COLUMN bytes;
