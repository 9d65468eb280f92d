-- Outputs in parts of at most 256 KiB (`OUTPUT_PART_BYTES`), keyed by the offset of their
-- first byte, so a download reads one part at a time instead of the whole value; the
-- output's size is kept beside its name. Outputs stored before are cut into parts here.
CREATE TABLE job_output_parts (
    job_id TEXT NOT NULL,
    output_id TEXT NOT NULL,
    start_byte BIGINT NOT NULL,
    bytes BYTEA NOT NULL,
    PRIMARY KEY (job_id, output_id, start_byte),
    FOREIGN KEY (job_id, output_id) REFERENCES job_outputs (job_id, output_id)
        ON DELETE CASCADE
);

ALTER TABLE job_outputs ADD COLUMN size_bytes BIGINT NOT NULL DEFAULT 0;
UPDATE job_outputs SET size_bytes = octet_length(bytes);

INSERT INTO job_output_parts (job_id, output_id, start_byte, bytes)
SELECT o.job_id, o.output_id, s.start_byte,
    substring(o.bytes FROM (s.start_byte + 1)::INTEGER FOR 262144)
FROM job_outputs o
CROSS JOIN LATERAL generate_series(0::BIGINT, o.size_bytes - 1, 262144) AS s (start_byte);

ALTER TABLE job_outputs DROP COLUMN bytes;
