/* Between store.c (arguments, limits, the mutex) and the two engines
 * (store_sqlite.c, store_pg.c). The engines get arguments already checked
 * and run with the handle's mutex held, except wait, which takes it itself
 * only while it reads. */
#ifndef RD_STORE_INTERNAL_H
#define RD_STORE_INTERNAL_H

#include <pthread.h>

#include "store.h"

typedef struct {
    const char *name;
    void (*close)(rd_store *s);
    rd_error_code (*ping)(rd_store *s, rd_error *err);
    rd_error_code (*job_create)(rd_store *s, const rd_store_job_spec *spec, rd_error *err);
    rd_error_code (*job_get)(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err);
    rd_error_code (*job_input)(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err);
    rd_error_code (*job_start)(rd_store *s, const char *id, rd_error *err);
    rd_error_code (*job_stats)(rd_store *s, const char *id, const char *stats, rd_error *err);
    /* Queued or running to `to` (done, failed or cancelled), dropping the
     * tiles: why for failed, r for done (its stats also for the others).
     * *changed 0 (and RD_OK) when it had ended. */
    rd_error_code (*job_end)(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                             const rd_store_result *r, int *changed, rd_error *err);
    rd_error_code (*job_delete)(rd_store *s, const char *id, rd_error *err);
    rd_error_code (*job_image)(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data, size_t *len,
                               rd_error *err);
    rd_error_code (*jobs_list)(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n,
                               rd_error *err);
    rd_error_code (*jobs_expire)(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);
    rd_error_code (*tiles_init)(rd_store *s, const char *id, int tiles, int passes, rd_error *err);
    rd_error_code (*claim)(rd_store *s, const char *daemon, int max, int lease_ms, const rd_store_claim_filter *f,
                           rd_store_tile *out, int *n, rd_error *err);
    /* lease_ms < 0: release them. */
    rd_error_code (*leases)(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err);
    rd_error_code (*tile_done)(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data, size_t len,
                               rd_store_tile_outcome *outcome, rd_error *err);
    rd_error_code (*pass_open)(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err);
    /* index < 0: every tile that has a result. */
    rd_error_code (*tiles_get)(rd_store *s, const char *id, int index, rd_store_tile_data **out, size_t *n,
                               rd_error *err);
    rd_error_code (*wait)(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err);
    /* g checked, its student never NULL, its pass 0 or 1 (0 with an
     * error, whose metrics are to be stored as NULL). */
    rd_error_code (*grade_put)(rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                               rd_error *err);
    rd_error_code (*grade_get)(rd_store *s, const char *id, rd_store_grade *out, rd_error *err);
    rd_error_code (*grade_image)(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                 size_t *len, rd_error *err);
    /* f never NULL, f->max > 0. */
    rd_error_code (*grades_list)(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                 rd_error *err);
    rd_error_code (*grades_expire)(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);
    /* daemon and students never NULL. */
    rd_error_code (*batch_create)(rd_store *s, const char *id, const char *assignment, int total, const char *daemon,
                                  const char *students, rd_error *err);
    rd_error_code (*batch_get)(rd_store *s, const char *id, rd_store_batch *out, rd_error *err);
    /* max > 0. */
    rd_error_code (*batches_running)(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                     rd_error *err);
    rd_error_code (*batch_students)(rd_store *s, const char *id, char **students, rd_error *err);
    /* *changed 0 (and RD_OK) when it had ended. */
    rd_error_code (*batch_cancel)(rd_store *s, const char *id, int *changed, rd_error *err);
} rd_store_ops;

/* The start of every engine's handle. */
struct rd_store {
    const rd_store_ops *ops;
    pthread_mutex_t lock;
    rd_store_options opt;
    /* When a write last failed for want of space (RD_ERR_NOSPACE), 0 since
     * a commit went through: the readiness probe says so for a while,
     * since a probe's small write may fit where a real one does not.
     * Under lock. */
    int64_t nospace_ms;
};

/* How long rd_store_ping answers RD_ERR_NOSPACE after a write failed for
 * want of space, unless a commit goes through meanwhile. */
#define RD_STORE_NOSPACE_MS 30000

/* The engines tell of each failed call's code and each commit. */
void rd_store_saw(rd_store *s, rd_error_code c);
void rd_store_committed(rd_store *s);

/* Engines: a handle with base filled but for ops and lock, or NULL. */
rd_store *rd_store_sqlite_open(const char *folder, const rd_store_options *opt, rd_error *err);
rd_store *rd_store_pg_open(const char *conninfo, const rd_store_options *opt, rd_error *err);

/* Why tile_done changed no tile, from the job's status st: it ended
 * (RD_ERR_CANCELLED), or the tile is not, or no longer, daemon's for this
 * pass (RD_ERR_TIMEOUT). */
rd_error_code rd_store_refusal(rd_store_status st, const char *daemon, const rd_store_tile *t, rd_error *err);

/* Why pass_open opened nothing, from the job's row as it is now (its
 * status, gated, passes completed, passes, passes opened): ended
 * (RD_ERR_CANCELLED), else not gated or not the next pass (RD_ERR_INVALID).
 * Both engines answer with the same messages. */
rd_error_code rd_store_pass_refusal(const char *id, int pass, rd_store_status st, int gated, int done, int passes,
                                    int opened, rd_error *err);

/* The statuses' names as the schema spells them; -1 for another text. */
int rd_store_status_parse(const char *name);

/* The batches' statuses as the schema spells them; -1 for another text. */
int rd_store_batch_status_parse(const char *name);

/* "diff" or "image", as grade_images.kind spells them. */
const char *rd_store_grade_image_name(rd_store_grade_image_kind kind);

/* The columns a grade is read from, in this order by both engines. */
#define RD_STORE_GRADE_COLUMNS                                                                                         \
    "id, batch_id, assignment, student, pass, failed_fraction, max_abs, psnr_db, ssim, verdict, reference_key, "       \
    "graded_ms, error"

/* Its texts, in the order of rd_store_grade_texts. */
#define RD_STORE_GRADE_TEXTS 7

/* Copies a row's texts (id, batch_id, assignment, student, verdict,
 * reference_key, error; NULL for SQL NULL) into g's malloc'ed ones;
 * RD_ERR_NOMEM (and g's texts freed) when out of memory. */
rd_error_code rd_store_grade_texts(rd_store_grade *g, const char *const texts[RD_STORE_GRADE_TEXTS], rd_error *err);

/* Why a batch refused to count a grade of assignment, from its row as it is
 * now: ended (RD_ERR_CANCELLED) or of another assignment (RD_ERR_INVALID).
 * Both engines answer with the same messages. */
rd_error_code rd_store_batch_refusal(const char *batch_id, const char *assignment, rd_store_batch_status st,
                                     const char *batch_assignment, int done, int total, rd_error *err);

/* The code of a stable error name (rd_error_name); RD_ERR_IO for another. */
rd_error_code rd_store_code_parse(const char *name);

/* The migration's text with @BLOB@ written blob (BLOB, BYTEA); malloc'ed,
 * NULL when out of memory. */
char *rd_store_migration_text(const char *sql, const char *blob);

/* The payload of a NOTIFY ("s:ID" submitted, "t:ID" tiles, "e:ID" ended)
 * and back. */
void rd_store_event_payload(char *out, size_t outsz, rd_store_event_kind kind, const char *id);
void rd_store_event_parse(const char *payload, rd_store_event *ev);

/* A malloc'ed copy of len bytes with a NUL after them; NULL on no memory. */
void *rd_store_dup(const void *data, size_t len);

#endif
