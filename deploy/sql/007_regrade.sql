-- Version 7: regrades (docs/grading.md, "Regrading"). A regrade grades a
-- record's stored image again, against the assignment's reference as it is
-- now, into a new record whose regrade_of names the one it regrades: the
-- old verdict stays beside the new, and only the newest of a line of
-- regrades may count. The image a record was graded from is kept in
-- grade_images (kind 'image') from this version on; older records have
-- none and cannot be regraded.
ALTER TABLE grades ADD COLUMN regrade_of TEXT;
