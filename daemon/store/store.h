/* The job store: what must outlive the process (accepted jobs, their tiles,
 * their images; grade records and grading batches), in SQLite (one
 * machine, the default) or PostgreSQL (several daemons sharing one queue
 * and rendering one job together). One interface, two engines; the schema
 * is the migrations of deploy/sql/, built into the binary and applied by
 * rd_store_open (docs/deploy.md).
 *
 * Errors are values: every call returns an rd_error_code and fills err
 * (which may be NULL).
 *   RD_ERR_UNAVAILABLE the store is unreachable or failing (disk, server
 *                      down, a statement past the timeout): answer 503. The
 *                      same handle reconnects on a later call.
 *   RD_ERR_IO          rd_store_open only: the folder cannot be made or
 *                      used.
 *   RD_ERR_BUSY        other writers held the store past the timeout, or a
 *                      transaction lost a conflict: try again.
 *   RD_ERR_NOT_FOUND   no job (grade, batch) of that id.
 *   RD_ERR_INVALID     a bad argument (an id, a status, a format), a job id
 *                      that exists already, a job in a state that does not
 *                      allow the call.
 *   RD_ERR_LIMIT       a scene, text, blob or tile count over the limits.
 *   RD_ERR_CANCELLED   the job has ended (done, failed, cancelled): it takes
 *                      no more tiles or results; the batch has ended (done,
 *                      cancelled): it takes no more grades.
 *   RD_ERR_TIMEOUT     a tile's lease ran out and another daemon claimed it.
 *   RD_ERR_UNSUPPORTED the store's schema is newer than this binary.
 *   RD_ERR_NOSPACE     no space left to write (a full disk; SQLite's
 *                      SQLITE_FULL, PostgreSQL's disk_full 53100): answer
 *                      507. Nothing was changed; the same call may work
 *                      once space is freed.
 *   RD_ERR_DAMAGED     the data is damaged (SQLite's SQLITE_CORRUPT and
 *                      SQLITE_NOTADB, a failed quick_check at open;
 *                      PostgreSQL's data_corrupted XX001 and
 *                      index_corrupted XX002): answer 503, an operator
 *                      must repair or restore it.
 *   RD_ERR_NOMEM       out of memory.
 * Each call is one transaction: on an error nothing was changed. Output
 * parameters are written only on RD_OK.
 *
 * Ownership: the caller keeps what it passes in (the store copies what it
 * keeps); what the store hands out is malloc'ed for the caller, who frees it
 * with free() or the matching *_free.
 *
 * Thread safety: a store is one connection behind a mutex. Every function
 * may be called from any thread; calls on one handle run one at a time.
 * For parallel calls, open one handle per thread: handles on the same
 * folder or database share its data through transactions, as separate
 * processes do. rd_store_wait holds the mutex only while it reads, so the
 * handle's other calls go on during a wait.
 *
 * Time: milliseconds since the Unix epoch. The caller gives a job's
 * submission time; the store's clock stamps starts, ends, leases and expiry
 * (SQLite: this machine's; PostgreSQL: the server's, so that daemons on
 * machines whose clocks differ agree on leases). */
#ifndef RD_STORE_H
#define RD_STORE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/clock.h"
#include "rayd/error.h"

/* Job and daemon ids: 1 to RD_STORE_ID_MAX - 1 of [A-Za-z0-9._:-]. */
#define RD_STORE_ID_MAX 64

typedef struct rd_store rd_store;

/* What the store accepts at most (RD_ERR_LIMIT past any of them): the
 * caller sets them from its own limits. */
typedef struct {
    size_t scene_bytes; /* a job's scene */
    size_t text_bytes;  /* the query text, a stats JSON text */
    size_t image_bytes; /* one PNG or EXR */
    size_t tile_bytes;  /* one tile's result */
    int tiles;          /* tiles of one job */
    int passes;         /* passes of one job */
} rd_store_limits;

typedef struct {
    rd_store_limits limits;
    /* The longest one call waits: for other writers (SQLite's busy
     * timeout), for a statement (PostgreSQL's statement_timeout, and the
     * client's own deadline beyond it), for a connection (at least 2 s,
     * libpq's connect_timeout counts whole seconds). */
    int timeout_ms;
    /* SQLite: synchronous=FULL, a commit survives the machine losing power;
     * 0 is NORMAL, a commit survives the process being killed but the last
     * ones may be lost with the machine. PostgreSQL commits are the
     * server's business (its synchronous_commit). */
    int sync_full;
} rd_store_options;

/* 16 MiB scenes, 1 MiB texts, 256 MiB images, 16 MiB tiles, 2^20 tiles,
 * 65536 passes, 5 s timeout, sync_full. */
rd_store_options rd_store_options_default(void);

/* Opens a store and applies the migrations it lacks (one transaction; two
 * daemons opening a new store at once apply them once). spec:
 *   postgresql://... or postgres://...  a PostgreSQL URL,
 *   KEY=VALUE ...                       a libpq conninfo (host=db dbname=rayd),
 *   anything else                       a folder (made when missing) holding
 *                                       rayd.sqlite3 (WAL, busy timeout).
 * A folder whose name starts KEY= is written ./KEY=... opt NULL: the
 * defaults. NULL with err set on failure (RD_ERR_UNAVAILABLE unreachable,
 * RD_ERR_IO a folder that cannot be made or used, RD_ERR_UNSUPPORTED schema
 * too new). */
rd_store *rd_store_open(const char *spec, const rd_store_options *opt, rd_error *err);

/* Closes the connection and frees the handle (NULL: nothing). */
void rd_store_close(rd_store *s);

/* "sqlite" or "postgresql". */
const char *rd_store_engine_name(const rd_store *s);

/* The readiness probe: RD_OK when the store can be written now: a small
 * write (committed, then deleted) round-trips, reconnecting first if the
 * connection was lost. RD_ERR_UNAVAILABLE when it is unreachable, RD_ERR_DAMAGED
 * when its data is damaged, RD_ERR_NOSPACE when the probe found no space.
 * What the probe's small write says of larger ones is the caller's to
 * judge (the farm remembers, farm_full). */
rd_error_code rd_store_ping(rd_store *s, rd_error *err);

/* The order and names of rd_jq_status. */
typedef enum { RD_STORE_QUEUED, RD_STORE_RUNNING, RD_STORE_DONE, RD_STORE_FAILED, RD_STORE_CANCELLED } rd_store_status;

#define RD_STORE_STATUS_COUNT 5

/* "queued", "running", "done", "failed", "cancelled"; "?" outside them. */
const char *rd_store_status_name(rd_store_status st);

/* A status mask for rd_store_jobs_list. */
#define RD_STORE_MASK(st) (1u << (st))

/* A job as submitted. */
typedef struct {
    const char *id;
    const char *scene; /* scene_len bytes, any bytes */
    size_t scene_len;
    const char *format;   /* "cfg" or "json" */
    const char *query;    /* the overrides as query text ("width=320&samples=4"); NULL is "" */
    int hdr;              /* keep an EXR beside the PNG */
    int width, height;    /* the image's size once overridden; 0 unknown */
    int64_t memory_bytes; /* its estimated footprint; 0 unknown */
    int64_t submitted_ms; /* orders the queue */
    int tiles, passes;    /* > 0: its tiles are made in the same transaction (rd_store_tiles_init) */
    /* Passes after the first become claimable only once rd_store_pass_open
     * opens them (whoever completes a pass decides whether and how the next
     * runs); 0: each pass opens as the one before completes. */
    int gated;
    const char *schedule; /* the job's schedule text (rd_store_pass_open); NULL: none */
} rd_store_job_spec;

/* Commits a new job, queued: once this returns RD_OK the job survives the
 * process being killed (and the machine, with sync_full or a durable
 * PostgreSQL). RD_ERR_INVALID when the id exists. Wakes waiting handles. */
rd_error_code rd_store_job_create(rd_store *s, const rd_store_job_spec *spec, rd_error *err);

/* What a client may ask about a job. */
typedef struct {
    char id[RD_STORE_ID_MAX];
    rd_store_status status;
    char format[8];
    int hdr, width, height;
    int64_t memory_bytes;
    int64_t submitted_ms, started_ms, finished_ms; /* 0: not yet */
    rd_error error;                                /* RD_OK unless failed */
    char *stats;                                   /* JSON text, malloc'ed; NULL when none */
    int tiles_total, tiles_done;                   /* tiles_done: of the pass in progress */
    int pass, passes;                              /* passes completed, of passes */
    size_t png_bytes, exr_bytes;                   /* 0: no such image */
    int gated;                                     /* as submitted */
    int open_pass;                                 /* gated: passes opened (1 at the start) */
    char *schedule;                                /* malloc'ed text; NULL when none */
} rd_store_job_info;

rd_error_code rd_store_job_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err);

/* Frees what info holds (not info itself). */
void rd_store_job_info_free(rd_store_job_info *info);

/* What a daemon needs to render a job it did not accept. */
typedef struct {
    char *scene; /* scene_len bytes, malloc'ed, with a NUL after them */
    size_t scene_len;
    char format[8];
    char *query; /* malloc'ed; "" when none */
    int hdr, width, height;
    int64_t memory_bytes, submitted_ms;
} rd_store_job_input;

rd_error_code rd_store_job_input_get(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err);

void rd_store_job_input_free(rd_store_job_input *in);

/* Queued to running (stamping its start) for a caller that renders it
 * without tiles; a claim does it too. Running already: RD_OK.
 * RD_ERR_CANCELLED when it has ended. */
rd_error_code rd_store_job_start(rd_store *s, const char *id, rd_error *err);

/* Replaces a queued or running job's statistics (JSON text; NULL clears). */
rd_error_code rd_store_job_stats(rd_store *s, const char *id, const char *stats, rd_error *err);

/* A finished job's images and last statistics (exr and stats may be NULL). */
typedef struct {
    const unsigned char *png;
    size_t png_len;
    const unsigned char *exr;
    size_t exr_len;
    const char *stats;
} rd_store_result;

/* Queued or running to done, with its images; its tiles are dropped.
 * RD_ERR_CANCELLED when it had ended. Wakes waiting handles. */
rd_error_code rd_store_job_finish(rd_store *s, const char *id, const rd_store_result *r, rd_error *err);

/* Queued or running to failed with why (its code, position and message);
 * its tiles are dropped. RD_ERR_CANCELLED when it had ended. */
rd_error_code rd_store_job_fail(rd_store *s, const char *id, const rd_error *why, const char *stats, rd_error *err);

/* Queued or running to cancelled; its tiles are dropped. *changed (may be
 * NULL) is 0 when it had ended already, which is not an error. Wakes
 * waiting handles (the daemons rendering it). */
rd_error_code rd_store_job_cancel(rd_store *s, const char *id, int *changed, rd_error *err);

/* Deletes a job whatever its state, with its tiles and images. */
rd_error_code rd_store_job_delete(rd_store *s, const char *id, rd_error *err);

typedef enum { RD_STORE_PNG, RD_STORE_EXR } rd_store_image_kind;

/* A finished job's image, malloc'ed. RD_ERR_INVALID when it has none of
 * that kind (not done, or no EXR asked for). */
rd_error_code rd_store_job_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data,
                                 size_t *len, rd_error *err);

typedef struct {
    char id[RD_STORE_ID_MAX];
    rd_store_status status;
    int64_t submitted_ms;
} rd_store_job_brief;

/* The jobs whose status is in mask (RD_STORE_MASK bits), oldest
 * submission first, at most max. *out is a malloc'ed array (NULL when
 * *n is 0). */
rd_error_code rd_store_jobs_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n,
                                 rd_error *err);

/* Deletes the jobs that ended more than ttl_ms ago, with their images;
 * *deleted (may be NULL) says how many. */
rd_error_code rd_store_jobs_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);

/* Tiles. A job is split into tiles numbered 0..tiles-1, each rendered
 * passes times; every tile holds its latest result (opaque bytes: the
 * renderer's accumulations). A pass's tiles are claimable once the pass
 * before is complete (and, for a gated job, once rd_store_pass_open opened
 * it). */
typedef struct {
    char job_id[RD_STORE_ID_MAX];
    int index;
    int pass; /* 0-based: the pass this claim is for */
} rd_store_tile;

/* Makes the tiles of a queued or running job that has none.
 * RD_ERR_INVALID when it has some. Wakes waiting handles. */
rd_error_code rd_store_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err);

/* Claims up to max tiles (out holds max) of the oldest runnable job (queued
 * or running, by submission) that has tiles of its current pass that
 * nobody holds a live lease on, for daemon, for lease_ms from now. The job
 * becomes running. *n is 0 when nothing is to be done. Two claims never get
 * the same tile while its lease lives, whichever handles or processes they
 * come from. */
rd_error_code rd_store_claim(rd_store *s, const char *daemon, int max, int lease_ms, rd_store_tile *out, int *n,
                             rd_error *err);

/* Which jobs a claim may take tiles of. */
typedef struct {
    const char *job_id;       /* only this job; NULL: any */
    int64_t max_memory_bytes; /* only jobs whose memory_bytes is at most this; <= 0: any */
} rd_store_claim_filter;

/* rd_store_claim among the jobs filter allows (NULL: all): a daemon goes
 * on with a job it holds, or takes a new one only if it fits its memory. */
rd_error_code rd_store_claim_where(rd_store *s, const char *daemon, int max, int lease_ms,
                                   const rd_store_claim_filter *filter, rd_store_tile *out, int *n, rd_error *err);

/* Extends to lease_ms from now every lease daemon holds; *renewed (may be
 * NULL) counts them. A lease that ran out is daemon's still until another
 * claim takes its tile. */
rd_error_code rd_store_renew(rd_store *s, const char *daemon, int lease_ms, int *renewed, rd_error *err);

/* Gives up every lease daemon holds, so others claim those tiles at once
 * (a graceful stop; a restarted daemon with the same id). */
rd_error_code rd_store_release(rd_store *s, const char *daemon, int *released, rd_error *err);

typedef enum {
    RD_STORE_TILE_MORE,      /* other tiles of the pass are not done */
    RD_STORE_TILE_PASS_DONE, /* it completed a pass that is not the last: the next is claimable (gated: once opened) */
    RD_STORE_TILE_JOB_DONE,  /* it completed the last pass: the caller assembles and finishes the job */
} rd_store_tile_outcome;

/* Stores a claimed tile's result for its pass (replacing the result of the
 * pass before) and ends the lease; exactly one call sees each pass
 * complete (outcome may be NULL). RD_ERR_TIMEOUT when the lease ran out and another daemon
 * claimed the tile (the result is not stored), RD_ERR_CANCELLED when the
 * job has ended. */
rd_error_code rd_store_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data, size_t len,
                                 rd_store_tile_outcome *outcome, rd_error *err);

/* Opens pass (>= 1) of a gated job, whose pass before has just completed
 * (its tile_done said PASS_DONE), and replaces the job's schedule text
 * (NULL keeps it; at most limits.text_bytes). Exactly one call opens a
 * pass: RD_ERR_INVALID when pass is not the job's next one (not completed
 * yet, or opened already) or the job is not gated, RD_ERR_CANCELLED when
 * it has ended. Wakes waiting handles (TILES). */
rd_error_code rd_store_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err);

typedef struct {
    int index;
    int passes; /* passes its result holds */
    unsigned char *data;
    size_t len;
} rd_store_tile_data;

/* The latest result of every tile of a job that has one, by index: to
 * assemble the image or resume. *out malloc'ed, freed with
 * rd_store_tiles_free (NULL when *n is 0). A job that has ended has no
 * tiles. */
rd_error_code rd_store_tiles_get(rd_store *s, const char *id, rd_store_tile_data **out, size_t *n, rd_error *err);

/* One tile's latest result (to go on accumulating it): passes 0 and data
 * NULL when it has none yet. RD_ERR_NOT_FOUND when there is no such tile. */
rd_error_code rd_store_tile_get(rd_store *s, const char *id, int index, rd_store_tile_data *out, rd_error *err);

void rd_store_tiles_free(rd_store_tile_data *t, size_t n);

typedef enum {
    RD_STORE_EV_NONE,      /* the timeout passed */
    RD_STORE_EV_SUBMITTED, /* a job was created */
    RD_STORE_EV_TILES,     /* tiles became claimable: made, a pass completed (ungated) or opened, leases released */
    RD_STORE_EV_ENDED,     /* a job was finished, failed or cancelled */
    RD_STORE_EV_CHANGED,   /* SQLite: another handle committed something (which, it cannot tell) */
} rd_store_event_kind;

typedef struct {
    rd_store_event_kind kind;
    char job_id[RD_STORE_ID_MAX]; /* "" for NONE and CHANGED */
} rd_store_event;

/* Waits up to timeout_ms for another handle's change, and says which. The
 * handle's own changes do not wake it.
 *   PostgreSQL: LISTEN/NOTIFY on channel rayd_jobs; one event per call,
 *     the ones after it stay queued (the newest 64: a handle that never
 *     waits does not pile them up). Events sent while the connection was
 *     down are lost: a caller also polls (claims) on every timeout.
 *   SQLite: looks at PRAGMA data_version every 10 ms, so any commit of
 *     another handle, in this process or another, wakes it as CHANGED.
 * An unreachable store is RD_ERR_UNAVAILABLE after the whole timeout, so that a
 * loop around this call does not spin. */
rd_error_code rd_store_wait(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err);

/* Grades. Every grade an instructor asks for, alone or as one of a batch,
 * is kept with its verdict until rd_store_grades_expire (--grade-ttl):
 * the row in grades, its diff PNG apart in grade_images, so that reading or
 * listing grades never reads an image. A batch counts the grades it has
 * been given, of its total. */

/* Assignments and students: at most RD_STORE_NAME_MAX - 1 bytes. */
#define RD_STORE_NAME_MAX 256

/* A grade. rd_store_grade_put reads it (the caller keeps what it points
 * to); rd_store_grade_get and rd_store_grades_list fill it with malloc'ed
 * copies, freed with rd_store_grade_free (NULL pointers for NULL values). */
typedef struct {
    const char *id;         /* the caller's unguessable id (api/util/capability.h) */
    const char *batch_id;   /* NULL: a grade of its own */
    const char *assignment; /* 1 to RD_STORE_NAME_MAX - 1 bytes of UTF-8 */
    const char *student;    /* 0 to RD_STORE_NAME_MAX - 1 bytes of UTF-8, "" when unknown (NULL is "") */
    int pass;               /* 1 passed, 0 failed; 0 when error is set */
    /* The metrics, kept exactly: finite (RD_ERR_INVALID otherwise). When
     * error is set they are not stored, and read back as NAN. */
    double failed_fraction, max_abs, psnr_db, ssim;
    const char *verdict;       /* the verdict JSON as the API answers it; required unless error is set */
    const char *reference_key; /* the reference's identity (scene and core hashes); required unless error is set */
    int64_t graded_ms;         /* when it was graded (the caller's clock), >= 0 */
    const char *error;         /* NULL: graded; else why the image could not be graded (not "") */
    /* The term (migration 6; docs/grading.md, "A term"). A record from
     * before it reads as an image submitted when graded, on time, with
     * score and points NAN. */
    const char *kind;     /* "image" or "code"; NULL is "image" */
    int64_t submitted_ms; /* when it was submitted; <= 0: graded_ms */
    int64_t late_ms;      /* how long after its due time, >= 0 */
    int closed;           /* submitted after the late window: it never counts */
    /* The score of the assignment's points: 0 <= score <= points, points
     * > 0; points 0 (or NAN) is no score, read back as both NAN. */
    double score, points;
    const char *regrade_of; /* migration 7: the record this one grades again; NULL: none */
} rd_store_grade;

/* Frees what g holds (not g itself) and sets its pointers to NULL. */
void rd_store_grade_free(rd_store_grade *g);

/* Commits a grade and, when diff_png is not NULL, its diff PNG (len
 * bytes, at most limits.image_bytes). Texts are limited to
 * limits.text_bytes and must be UTF-8. RD_ERR_INVALID when the id exists
 * or an argument is bad. A grade of a batch is counted in the same
 * transaction: the batch's done goes up by one and the batch becomes done
 * when done reaches its total, exactly once however many handles put its
 * last grades at once. RD_ERR_NOT_FOUND when there is no such batch,
 * RD_ERR_INVALID when it is of another assignment, RD_ERR_CANCELLED when
 * it has ended (done or cancelled): then nothing is stored. */
rd_error_code rd_store_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff_png, size_t len,
                                 rd_error *err);

/* RD_ERR_NOT_FOUND when there is no grade of that id. */
rd_error_code rd_store_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err);

typedef enum {
    RD_STORE_GRADE_DIFF,  /* the diff PNG of rd_store_grade_put */
    RD_STORE_GRADE_IMAGE, /* the image graded, for a regrade (rd_store_grade_image_put) */
} rd_store_grade_image_kind;

/* Stores a grade's image of kind (len bytes, at most limits.image_bytes),
 * replacing one it had. RD_ERR_NOT_FOUND when there is no such grade. */
rd_error_code rd_store_grade_image_put(rd_store *s, const char *id, rd_store_grade_image_kind kind,
                                       const unsigned char *data, size_t len, rd_error *err);

/* A grade's image, malloc'ed. RD_ERR_NOT_FOUND when there is no such grade,
 * RD_ERR_INVALID when it has no image of that kind. */
rd_error_code rd_store_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                   size_t *len, rd_error *err);

/* Which grades rd_store_grades_list gives. */
typedef struct {
    const char *assignment; /* NULL: any */
    const char *student;    /* NULL: any ("" is the unknown student) */
    const char *batch_id;   /* NULL: any, a batch's or not */
    int64_t since_ms;       /* graded at or after this */
    size_t max;             /* at most this many */
} rd_store_grade_filter;

/* The grades f allows (NULL: every one), by graded_ms then id, at most
 * f->max (0: none). *out is a malloc'ed array (NULL when *n is 0), freed
 * with rd_store_grades_free. */
rd_error_code rd_store_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                   rd_error *err);

void rd_store_grades_free(rd_store_grade *g, size_t n);

/* Deletes the grades graded more than ttl_ms ago (graded_ms against the
 * store's clock), with their images, and the batches created more than
 * ttl_ms ago that have no grade left: a batch goes only after its last
 * grade, so that no grade goes before its own time (through the batch's
 * cascade). *deleted (may be NULL) counts the grades. */
rd_error_code rd_store_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);

/* The order and names of the batches' statuses. */
typedef enum { RD_STORE_BATCH_RUNNING, RD_STORE_BATCH_DONE, RD_STORE_BATCH_CANCELLED } rd_store_batch_status;

/* "running", "done", "cancelled"; "?" outside them. */
const char *rd_store_batch_status_name(rd_store_batch_status st);

/* Commits a new batch of total (>= 1) grades of assignment, running, with
 * none done, created now (the store's clock). daemon is the daemon that
 * grades it (its id, as job ids; NULL or "": none), students its
 * students' ids, each followed by '\n' (UTF-8, at most
 * limits.text_bytes, RD_ERR_LIMIT past it; NULL: ""), so that the daemon,
 * restarted, can end it (rd_store_batches_running). RD_ERR_INVALID when
 * the id exists. */
rd_error_code rd_store_batch_create(rd_store *s, const char *id, const char *assignment, int total, const char *daemon,
                                    const char *students, rd_error *err);

typedef struct {
    char id[RD_STORE_ID_MAX];
    char assignment[RD_STORE_NAME_MAX];
    int total, done; /* done: grades put so far, of total */
    rd_store_batch_status status;
    int64_t created_ms;
} rd_store_batch;

/* RD_ERR_NOT_FOUND when there is no batch of that id. */
rd_error_code rd_store_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err);

/* The batches still running that daemon (not NULL or "") created, oldest
 * first, at most max: at its start, the ones it was grading when it was
 * killed. *out is a malloc'ed array (NULL when *n is 0). */
rd_error_code rd_store_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                       rd_error *err);

/* A batch's students as rd_store_batch_create was given them ("" when
 * none), malloc'ed. RD_ERR_NOT_FOUND when there is no batch of that id. */
rd_error_code rd_store_batch_students(rd_store *s, const char *id, char **students, rd_error *err);

/* Running to cancelled: it takes no more grades, and keeps those it has.
 * *changed (may be NULL) is 0 when it had ended already, which is not an
 * error. */
rd_error_code rd_store_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err);

/* Which batches rd_store_batches_list gives. */
typedef struct {
    const char *assignment; /* NULL: any */
    int64_t until_ms;       /* created at or before this; 0: any time */
    size_t max;             /* at most this many */
} rd_store_batch_filter;

/* The batches f allows (NULL: every one), newest first (created_ms, then
 * id, both descending), at most f->max (0: none). A longer list is read in
 * pages: until_ms the last one's created_ms gives the next page, which
 * begins with those of that millisecond again (none is skipped). *out is a
 * malloc'ed array (NULL when *n is 0). */
rd_error_code rd_store_batches_list(rd_store *s, const rd_store_batch_filter *f, rd_store_batch **out, size_t *n,
                                    rd_error *err);

/* A deleted grade's id: the daemon forgets what it kept of it. */
typedef struct {
    char id[RD_STORE_ID_MAX];
} rd_store_grade_id;

/* Deletes a batch that has ended (done or cancelled) with its grades and
 * their images. *ids (ids may be NULL; else a malloc'ed array, NULL when
 * *n is 0) the deleted grades' ids, *n (n may be NULL) how many. RD_ERR_NOT_FOUND when
 * there is no batch of that id, RD_ERR_INVALID when it is still running
 * (cancel it first): then nothing is deleted. */
rd_error_code rd_store_batch_delete(rd_store *s, const char *id, rd_store_grade_id **ids, size_t *n, rd_error *err);

/* Deletes every grade of student (UTF-8; "" the unknown student) with its
 * images, whichever batch it belongs to: the batch keeps its count (done
 * counts the grades it was given), its rows no longer show the student.
 * ids and n as rd_store_batch_delete; no grade of that student is *n 0,
 * not an error. */
rd_error_code rd_store_grades_delete(rd_store *s, const char *student, rd_store_grade_id **ids, size_t *n,
                                     rd_error *err);

/* Deletes one grade with its images. RD_ERR_NOT_FOUND when there is no
 * grade of that id. */
rd_error_code rd_store_grade_delete(rd_store *s, const char *id, rd_error *err);

#endif
