-- Version 5: who grades a batch, and whom; and the readiness probe's table.
-- A batch is graded in the memory
-- of the daemon that took it (its --daemon-id in daemon); students lists
-- its students' ids, each followed by a newline. A daemon killed while
-- grading leaves the batch running: restarted under the same id, it finds
-- its running batches and ends them, with an error row for every student
-- that has none (rd_store_batches_running). Batches made before this
-- version belong to no daemon ('') and name no student.
ALTER TABLE batches ADD COLUMN daemon TEXT NOT NULL DEFAULT '';
ALTER TABLE batches ADD COLUMN students TEXT NOT NULL DEFAULT '';

-- A daemon's running batches, at its start.
CREATE INDEX batches_by_daemon ON batches (daemon, status);

-- The readiness probe's write (rd_store_ping): a row put and deleted in
-- one transaction, so that a store that cannot be written is not ready.
CREATE TABLE write_probe (pad @BLOB@);
