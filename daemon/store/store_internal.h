/* Between store.c (arguments, limits, the mutex), store_ops.c (every
 * operation's SQL, written once) and the two engines (store_sqlite.c,
 * store_pg.c), which supply only a driver: a connection, statements, values
 * and transactions, plus the few fragments of SQL in which they differ.
 *
 * The operations get arguments already checked and run with the handle's
 * mutex held; the driver's wait takes it itself, only while it reads.
 * Errors as in store.h: a code, with err set (never NULL here). */
#ifndef RD_STORE_INTERNAL_H
#define RD_STORE_INTERNAL_H

#include <pthread.h>

#include "store.h"

/* A prepared statement of an engine, opaque outside it; freed with the
 * driver's finalize. */
typedef struct rd_store_stmt rd_store_stmt;

/* What the engines' SQL really differs in. store_ops.c writes @NAME@ where a
 * fragment goes, and ? (or ?N) for every value; rd_store_sql expands them. */
typedef struct {
    const char *now;            /* @NOW@: the store's clock, milliseconds since the epoch, one value a statement */
    const char *lock;           /* @LOCK@: after a SELECT whose rows the transaction then holds */
    const char *skip_locked;    /* @SKIP_LOCKED@: after the claim's SELECT of tiles, passing those others hold */
    const char *blob;           /* @BLOB@: the migrations' type of bytes */
    const char *migration_lock; /* a statement that makes concurrent openers migrate one at a time; NULL: none */
    int dollar;                 /* placeholders are $N, not ?N */
} rd_store_dialect;

/* An engine. Statements: prepare, bind by 1-based position, step, read the
 * row's columns by 0-based position, finalize. A bind keeps the caller's
 * pointer (text or bytes) until finalize; a bind that fails is told by the
 * next step. step returns 1 for a row, 0 at the end, or a negated
 * rd_error_code with err set. Columns read NULL as 0, NULL text or no bytes
 * (is_null tells), and stay valid until the next step. */
typedef struct {
    const char *name;
    rd_store_dialect sql;
    void (*close)(rd_store *s);
    /* Several statements with no values (a migration, named what). */
    rd_error_code (*script)(rd_store *s, const char *sql, const char *what, rd_error *err);
    rd_error_code (*begin)(rd_store *s, rd_error *err);
    /* The transaction is over either way. */
    rd_error_code (*commit)(rd_store *s, rd_error *err);
    /* Ends a transaction if one is open; nothing to report. */
    void (*rollback)(rd_store *s);
    rd_error_code (*prepare)(rd_store *s, const char *sql, rd_store_stmt **st, rd_error *err);
    void (*bind_int)(rd_store_stmt *st, int i, int64_t v);
    void (*bind_double)(rd_store_stmt *st, int i, double v);
    void (*bind_text)(rd_store_stmt *st, int i, const char *text); /* NULL binds a NULL text */
    void (*bind_blob)(rd_store_stmt *st, int i, const void *data, size_t len);
    void (*bind_null)(rd_store_stmt *st, int i); /* of the type its place calls for */
    int (*step)(rd_store_stmt *st, rd_error *err);
    /* Rows a finished INSERT, UPDATE or DELETE changed. */
    int (*changes)(rd_store_stmt *st);
    int (*is_null)(rd_store_stmt *st, int col);
    int64_t (*col_int)(rd_store_stmt *st, int col);
    double (*col_double)(rd_store_stmt *st, int col);
    const char *(*col_text)(rd_store_stmt *st, int col);
    const void *(*col_blob)(rd_store_stmt *st, int col, size_t *len);
    void (*finalize)(rd_store_stmt *st);
    /* Tells other handles, at commit, what happened to a job; NULL: the
     * commit itself is what wait sees. */
    rd_error_code (*notify)(rd_store *s, rd_store_event_kind kind, const char *id, rd_error *err);
    rd_error_code (*wait)(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err);
} rd_store_driver;

/* The start of every engine's handle. */
struct rd_store {
    const rd_store_driver *drv;
    pthread_mutex_t lock;
    rd_store_options opt;
};

/* Engines: a handle with base filled but for lock, migrated, or NULL. */
rd_store *rd_store_sqlite_open(const char *folder, const rd_store_options *opt, rd_error *err);
rd_store *rd_store_pg_open(const char *conninfo, const rd_store_options *opt, rd_error *err);

/* sql with d's fragments in place of the @NAME@ marks and, when values is
 * set and d->dollar, $N for ? and ?N (as SQLite numbers them); malloc'ed,
 * NULL when out of memory. */
char *rd_store_sql(const char *sql, const rd_store_dialect *d, int values);

/* The migration's text with @BLOB@ written blob (BLOB, BYTEA); malloc'ed,
 * NULL when out of memory. */
char *rd_store_migration_text(const char *sql, const char *blob);

/* Applies the migrations the store lacks, in one transaction;
 * RD_ERR_UNSUPPORTED when its schema is newer than this binary's. */
rd_error_code rd_store_migrate(rd_store *s, rd_error *err);

/* A malloc'ed copy of len bytes with a NUL after them; NULL on no memory. */
void *rd_store_dup(const void *data, size_t len);

/* The statuses' names as the schema spells them; -1 for another text. */
int rd_store_status_parse(const char *name);

/* The batches' statuses as the schema spells them; -1 for another text. */
int rd_store_batch_status_parse(const char *name);

/* The operations (store_ops.c), each one transaction, as store.h says of
 * the call of the same name but for what store.c does before and after. */
rd_error_code rd_store_op_ping(rd_store *s, rd_error *err);
rd_error_code rd_store_op_job_create(rd_store *s, const rd_store_job_spec *spec, rd_error *err);
rd_error_code rd_store_op_job_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err);
rd_error_code rd_store_op_job_input(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err);
rd_error_code rd_store_op_job_start(rd_store *s, const char *id, rd_error *err);
rd_error_code rd_store_op_job_stats(rd_store *s, const char *id, const char *stats, rd_error *err);
/* Queued or running to `to` (done, failed or cancelled), dropping the
 * tiles: why for failed, r for done (its stats also for the others).
 * *changed 0 (and RD_OK) when it had ended. */
rd_error_code rd_store_op_job_end(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                                  const rd_store_result *r, int *changed, rd_error *err);
rd_error_code rd_store_op_job_delete(rd_store *s, const char *id, rd_error *err);
rd_error_code rd_store_op_job_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data,
                                    size_t *len, rd_error *err);
/* mask and max not 0. */
rd_error_code rd_store_op_jobs_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n,
                                    rd_error *err);
rd_error_code rd_store_op_jobs_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);
rd_error_code rd_store_op_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err);
/* f never NULL. */
rd_error_code rd_store_op_claim(rd_store *s, const char *daemon, int max, int lease_ms, const rd_store_claim_filter *f,
                                rd_store_tile *out, int *n, rd_error *err);
/* lease_ms < 0: release them. */
rd_error_code rd_store_op_leases(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err);
rd_error_code rd_store_op_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data,
                                    size_t len, rd_store_tile_outcome *outcome, rd_error *err);
rd_error_code rd_store_op_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err);
/* index < 0: every tile that has a result. */
rd_error_code rd_store_op_tiles_get(rd_store *s, const char *id, int index, rd_store_tile_data **out, size_t *n,
                                    rd_error *err);
/* g checked, its student never NULL, its pass 0 or 1 (0 with an error,
 * whose metrics are stored as NULL). */
rd_error_code rd_store_op_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                                    rd_error *err);
rd_error_code rd_store_op_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err);
rd_error_code rd_store_op_grade_image_put(rd_store *s, const char *id, rd_store_grade_image_kind kind,
                                          const unsigned char *data, size_t len, rd_error *err);
rd_error_code rd_store_op_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                      size_t *len, rd_error *err);
/* f never NULL, f->max > 0. */
rd_error_code rd_store_op_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                      rd_error *err);
rd_error_code rd_store_op_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err);
/* daemon and students never NULL. */
rd_error_code rd_store_op_batch_create(rd_store *s, const char *id, const char *assignment, int total,
                                       const char *daemon, const char *students, rd_error *err);
rd_error_code rd_store_op_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err);
/* max > 0. */
rd_error_code rd_store_op_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                          rd_error *err);
rd_error_code rd_store_op_batch_students(rd_store *s, const char *id, char **students, rd_error *err);
/* *changed 0 (and RD_OK) when it had ended. */
rd_error_code rd_store_op_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err);
/* f never NULL, f->max > 0. */
rd_error_code rd_store_op_batches_list(rd_store *s, const rd_store_batch_filter *f, rd_store_batch **out, size_t *n,
                                       rd_error *err);
/* ids never NULL. */
rd_error_code rd_store_op_batch_delete(rd_store *s, const char *id, rd_store_grade_id **ids, size_t *n, rd_error *err);
/* The grades whose column ("id" or "student") is value; ids never NULL. */
rd_error_code rd_store_op_grades_delete(rd_store *s, const char *column, const char *value, rd_store_grade_id **ids,
                                        size_t *n, rd_error *err);

#endif
