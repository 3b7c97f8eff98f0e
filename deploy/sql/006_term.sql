-- Version 6: a term's records (docs/grading.md, "A term"): what a grade is
-- (an image or code), when it was submitted, how long after its due time,
-- whether that was after the late window (closed: it never counts), and its
-- score of the points its assignment's .grade gave when it was graded.
-- Records from before this version read as images submitted when graded,
-- on time, with no score.
ALTER TABLE grades ADD COLUMN kind TEXT NOT NULL DEFAULT 'image' CHECK (kind IN ('image', 'code'));
ALTER TABLE grades ADD COLUMN submitted_ms BIGINT;
ALTER TABLE grades ADD COLUMN late_ms BIGINT NOT NULL DEFAULT 0 CHECK (late_ms >= 0);
ALTER TABLE grades ADD COLUMN closed INTEGER NOT NULL DEFAULT 0 CHECK (closed IN (0, 1));
ALTER TABLE grades ADD COLUMN score DOUBLE PRECISION;
ALTER TABLE grades ADD COLUMN points DOUBLE PRECISION;

-- Which of a student's grades counts: an assignment's grades by student.
CREATE INDEX grades_by_assignment_student ON grades (assignment, student, submitted_ms);
