-- The job store's schema, version 1: jobs as submitted and as they end, and
-- their finished images. The same text runs on SQLite and PostgreSQL:
-- @BLOB@ is BLOB on one and BYTEA on the other (docs/deploy.md); every other
-- type is one both read the same way. Times are milliseconds since the Unix
-- epoch.

CREATE TABLE jobs (
    id            TEXT PRIMARY KEY,
    status        TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed', 'cancelled')),
    scene         @BLOB@ NOT NULL,
    format        TEXT NOT NULL CHECK (format IN ('cfg', 'json')),
    query         TEXT NOT NULL,
    hdr           INTEGER NOT NULL,
    width         INTEGER NOT NULL,
    height        INTEGER NOT NULL,
    memory_bytes  BIGINT NOT NULL,
    submitted_ms  BIGINT NOT NULL,
    started_ms    BIGINT,
    finished_ms   BIGINT,
    error_code    TEXT,
    error_line    INTEGER,
    error_column  INTEGER,
    error_message TEXT,
    stats         TEXT,
    -- Tiles of the pass in progress that are done, of tiles_total; pass is
    -- the passes completed, of passes (rd_store_tile_done).
    tiles_total   INTEGER NOT NULL DEFAULT 0,
    tiles_done    INTEGER NOT NULL DEFAULT 0,
    pass          INTEGER NOT NULL DEFAULT 0,
    passes        INTEGER NOT NULL DEFAULT 0
);

-- The queue's order (claims, lists) and expiry.
CREATE INDEX jobs_by_status ON jobs (status, submitted_ms);

-- Images live apart from their job, so that reading a status never reads
-- them.
CREATE TABLE results (
    job_id TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    kind   TEXT NOT NULL CHECK (kind IN ('png', 'exr')),
    data   @BLOB@ NOT NULL,
    PRIMARY KEY (job_id, kind)
);
