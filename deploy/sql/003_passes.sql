-- Version 3: gated passes. A gated job's passes after the first wait for
-- whoever completed the pass before to open them (rd_store_pass_open), so
-- that it can decide from the image so far whether, and how, the next pass
-- runs; its schedule is that decision as text, opaque to the store.
--
-- Columns added to jobs rather than a table of their own: a claim reads
-- them with the job's pass on the row it already reads, and opening a pass
-- is one conditional UPDATE of that row, which is what makes exactly one
-- opener win. One column per ALTER TABLE, as SQLite requires; the defaults
-- are constants, so neither engine rewrites the table (PostgreSQL 11 and
-- later store such a default once), and the jobs already there read as
-- ungated jobs with no schedule, which is what they were.

-- 1 for a gated job, 0 for one whose passes open by themselves.
ALTER TABLE jobs ADD COLUMN gated INTEGER NOT NULL DEFAULT 0 CHECK (gated IN (0, 1));

-- Passes opened, of a gated job: pass 0 is open from the start, and pass p
-- is claimable while pass = p < open_pass. Ungated jobs keep the default,
-- which no claim reads.
ALTER TABLE jobs ADD COLUMN open_pass INTEGER NOT NULL DEFAULT 1;

-- The job's schedule, as submitted and as the latest pass_open replaced it.
ALTER TABLE jobs ADD COLUMN schedule TEXT;
