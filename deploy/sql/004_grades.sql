-- Version 4: grade records. Every grade an instructor asks for is kept, with
-- its verdict, until the grade TTL (rd_store_grades_expire): one graded
-- alone has no batch; one of a class graded together belongs to its batch,
-- which counts them. Times are milliseconds since the Unix epoch.
--
-- The metrics are DOUBLE PRECISION: an 8-byte float on PostgreSQL, and
-- REAL affinity (an 8-byte float too) on SQLite, so both give back the
-- double they were given. REAL would be a 4-byte float on PostgreSQL.

-- A batch: total grades of one assignment, done of them put so far. It is
-- done once done reaches total, in the transaction that puts the last
-- grade; cancelled, it takes no more.
CREATE TABLE batches (
    id         TEXT PRIMARY KEY,
    assignment TEXT NOT NULL,
    total      INTEGER NOT NULL CHECK (total >= 1),
    done       INTEGER NOT NULL DEFAULT 0 CHECK (done >= 0 AND done <= total),
    status     TEXT NOT NULL CHECK (status IN ('running', 'done', 'cancelled')),
    created_ms BIGINT NOT NULL
);

-- Expiry.
CREATE INDEX batches_by_created ON batches (created_ms);

-- A grade: its id is the caller's (unguessable), student is '' when
-- unknown, verdict the verdict JSON as the API answered it, reference_key
-- the reference's identity (scene hash and core hash). A student whose
-- image could not be graded has its message in error, did not pass, and
-- has no metrics.
CREATE TABLE grades (
    id              TEXT PRIMARY KEY,
    batch_id        TEXT REFERENCES batches (id) ON DELETE CASCADE,
    assignment      TEXT NOT NULL,
    student         TEXT NOT NULL,
    pass            INTEGER NOT NULL CHECK (pass IN (0, 1)),
    failed_fraction DOUBLE PRECISION,
    max_abs         DOUBLE PRECISION,
    psnr_db         DOUBLE PRECISION,
    ssim            DOUBLE PRECISION,
    verdict         TEXT,
    reference_key   TEXT,
    graded_ms       BIGINT NOT NULL,
    error           TEXT,
    CHECK ((error IS NULL AND failed_fraction IS NOT NULL AND max_abs IS NOT NULL AND psnr_db IS NOT NULL
            AND ssim IS NOT NULL)
           OR (error IS NOT NULL AND pass = 0 AND failed_fraction IS NULL AND max_abs IS NULL AND psnr_db IS NULL
               AND ssim IS NULL))
);

-- Listing an assignment's grades, a student's, a batch's (and the cascade
-- from batches), all in graded_ms order; expiry and the unfiltered listing.
CREATE INDEX grades_by_assignment ON grades (assignment, graded_ms);
CREATE INDEX grades_by_student ON grades (student, graded_ms);
CREATE INDEX grades_by_batch ON grades (batch_id, graded_ms);
CREATE INDEX grades_by_time ON grades (graded_ms);

-- Images live apart from their grade, so that reading or listing grades
-- never reads them: the diff PNG, and room for the student's upload.
CREATE TABLE grade_images (
    grade_id TEXT NOT NULL REFERENCES grades (id) ON DELETE CASCADE,
    kind     TEXT NOT NULL CHECK (kind IN ('diff', 'image')),
    data     @BLOB@ NOT NULL,
    PRIMARY KEY (grade_id, kind)
);
