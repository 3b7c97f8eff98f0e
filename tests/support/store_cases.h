/* The job store's properties, written once and run against each engine
 * (tests/unit/daemon/test_store.c for SQLite, test_store_pg.c for
 * PostgreSQL): every case opens its handles from a store_env, so that it
 * can open several (daemons) or reopen one (a restart). */
#ifndef RD_TEST_STORE_CASES_H
#define RD_TEST_STORE_CASES_H

#include "store.h"

typedef struct {
    char spec[256];
    rd_store_options opt;
    /* SQLite: another handle's commit wakes rd_store_wait as CHANGED, with
     * no job id; PostgreSQL: as what happened, with the id. */
    int events_named;
} store_env;

/* A new handle; asserts it opened. */
rd_store *store_env_open(const store_env *e);

void sleep_ms_store(long ms);

/* A queued job with a small scene; tiles/passes 0 for none. */
void store_put_job(rd_store *s, const char *id, int64_t submitted_ms, int tiles, int passes);

void case_create_get(const store_env *e);
void case_lifecycle(const store_env *e);
void case_list_expire_delete(const store_env *e);
void case_tiles_and_passes(const store_env *e);
void case_claim_oldest_job_first(const store_env *e);
void case_lease_expiry(const store_env *e);
void case_renew_and_release(const store_env *e);
/* threads handles render one job together (tiles x passes), and one more
 * "dies" holding tiles: every tile of every pass is done exactly once and
 * exactly one call sees each pass end. */
void case_concurrent_claims(const store_env *e, int threads, int tiles, int passes);
void case_durable_across_reopen(const store_env *e);
void case_survives_kill(const store_env *e);
void case_limits_and_bad_arguments(const store_env *e);
/* A waiting handle wakes within max_ms of another's commit, not for its
 * own, and sleeps out its timeout otherwise. */
void case_wait_wakes(const store_env *e, double max_ms);
/* Gated passes: pass p opens only by rd_store_pass_open, once, after pass
 * p - 1 completed; claims pass over a pass not open (and take the jobs
 * behind it); the schedule it replaces. */
void case_gated_passes(const store_env *e);
/* Each refusal of pass_open (not complete, twice, skipping, past the last,
 * ended, ungated, no job) and its code, changing nothing. */
void case_gated_refusals(const store_env *e);
/* The schedule round-trips through create, job_get and pass_open (NULL
 * keeps it, "" replaces it), within the text limit. */
void case_gated_schedule(const store_env *e);
/* An opened pass wakes a waiting handle (TILES on PostgreSQL, which a
 * completed gated pass does not send; CHANGED on SQLite); a refused one
 * does not. */
void case_gated_wait(const store_env *e);
/* threads handles open each of rounds passes at once: exactly one wins
 * each, and its schedule is the job's. */
void case_gated_race(const store_env *e, int threads, int rounds);
/* A store of schema version 2, made by exec (SQL run by the engine's own
 * client, @BLOB@ written blob), with a job half done: opening it applies
 * migration 3, and the job goes on ungated. */
void case_upgrade_from_version_2(const store_env *e, void (*exec)(const char *sql), const char *blob);

/* A version-3 store upgrades to 4 (see case_upgrade_from_version_2): its
 * job is kept, and it takes grades and batches. */
void case_upgrade_from_version_3(const store_env *e, void (*exec)(const char *sql), const char *blob);

/* Grades: every field round-trips (doubles bit for bit; non-finite
 * metrics refused), an id once. */
void case_grade_round_trip(const store_env *e);
/* A grade that could not be graded: its message, no metrics (NAN), no
 * pass, no diff; a graded one needs its verdict and reference. */
void case_grade_error_row(const store_env *e);
/* The diff PNG round-trips; absent, it is told apart from no grade. */
void case_grade_images(const store_env *e);
/* A grade's term (kind, submission, lateness, score, regrade_of) round-trips,
 * is refused out of range, and the image graded is put and replaced. */
void case_grade_term(const store_env *e);
/* Listing by assignment, student, batch, since, at most max, in
 * graded_ms then id order. */
void case_grades_list(const store_env *e);
/* A batch counts its grades to done exactly once, refuses what is not its
 * (ended, another assignment, a refused grade), and cancels. */
void case_batch_progress(const store_env *e);
/* A batch's daemon and students: the running batches of a daemon, a
 * batch's students as given. */
void case_batches_running(const store_env *e);
/* Handles racing puts of a batch's last grades: exactly its total is
 * counted, and it is done (two handles for two grades, four for two). */
void case_batch_race(const store_env *e, int rounds);
/* Grades older than the TTL go with their images; batches once older and
 * with no grade left. */
void case_grades_expire(const store_env *e);
/* Text, name and image limits, UTF-8, ids: refused, nothing counted. */
void case_grade_limits(const store_env *e);

/* Batches newest first, by assignment, at most max, paged by until_ms. */
void case_batches_list(const store_env *e);
/* An ended batch goes with its grades and their images, and gives their
 * ids; a running one is refused; other grades stay. */
void case_batch_delete(const store_env *e);
/* A student's grades go, whichever batch (which keeps its count); one
 * grade by its id. */
void case_grades_delete(const store_env *e);

#endif
