-- Version 2: the tiles of jobs, for several daemons rendering one job and
-- for resuming one. A tile is claimable in its job's current pass
-- (passes_done = jobs.pass) when nobody holds it (owner NULL) or its lease
-- ran out (lease_until in the past). data is its latest result: the
-- renderer's accumulations, opaque to the store.

CREATE TABLE tiles (
    job_id      TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    tile        INTEGER NOT NULL,
    passes_done INTEGER NOT NULL DEFAULT 0,
    owner       TEXT,
    lease_until BIGINT,
    data        @BLOB@,
    PRIMARY KEY (job_id, tile)
);

-- Renewing and releasing a daemon's leases.
CREATE INDEX tiles_by_owner ON tiles (owner) WHERE owner IS NOT NULL;
