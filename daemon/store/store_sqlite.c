/* The store in SQLite: one file, rayd.sqlite3, in WAL mode (readers do not
 * wait for the writer) with a busy timeout. Every write is one BEGIN
 * IMMEDIATE transaction: it takes the file's write lock first, so two
 * handles (threads or processes) never interleave a claim, and a busy store
 * is known before anything is done. Values are bound, never written into
 * SQL. */
#include <errno.h>
#include <math.h>
#include <sqlite3.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "migrations.h"
#include "rayd/memory.h"
#include "store_internal.h"

typedef struct {
    rd_store base;
    sqlite3 *db;
    long long data_version; /* PRAGMA data_version when last looked at (wait) */
} sq_store;

static sq_store *sq(rd_store *s) { return (sq_store *)s; }

static rd_error_code sq_fail(sq_store *q, int rc, const char *what, rd_error *err)
{
    rd_error_code c;
    switch (rc & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED: c = RD_ERR_BUSY; break;
    case SQLITE_CONSTRAINT:
    case SQLITE_MISMATCH:
    case SQLITE_RANGE: c = RD_ERR_INVALID; break;
    case SQLITE_TOOBIG: c = RD_ERR_LIMIT; break;
    case SQLITE_NOMEM: c = RD_ERR_NOMEM; break;
    case SQLITE_FULL: c = RD_ERR_NOSPACE; break;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB: c = RD_ERR_DAMAGED; break;
    default: c = RD_ERR_UNAVAILABLE;
    }
    rd_store_saw(&q->base, c);
    return rd_error_set(err, c, 0, 0, "store: %s: %s%s", what,
                        c == RD_ERR_DAMAGED   ? "the database is damaged: "
                        : c == RD_ERR_NOSPACE ? "no space left: "
                                              : "",
                        q->db ? sqlite3_errmsg(q->db) : sqlite3_errstr(rc));
}

/* Binds by fmt, one letter a value: t text (const char *, NULL binds
 * NULL), b bytes (const void *, size_t), i int, I int64_t, d a double
 * (const double *, NULL binds NULL). */
static int sq_bind(sqlite3_stmt *st, const char *fmt, va_list ap)
{
    int rc = SQLITE_OK;
    for (int i = 1; *fmt && rc == SQLITE_OK; fmt++, i++) {
        if (*fmt == 't') {
            const char *t = va_arg(ap, const char *);
            rc = t ? sqlite3_bind_text(st, i, t, -1, SQLITE_STATIC) : sqlite3_bind_null(st, i);
        } else if (*fmt == 'b') {
            const void *d = va_arg(ap, const void *);
            size_t n = va_arg(ap, size_t);
            /* Zero bytes are an empty blob, not NULL. */
            rc = n ? sqlite3_bind_blob64(st, i, d, n, SQLITE_STATIC) : sqlite3_bind_zeroblob(st, i, 0);
        } else if (*fmt == 'i') {
            rc = sqlite3_bind_int(st, i, va_arg(ap, int));
        } else if (*fmt == 'd') {
            const double *d = va_arg(ap, const double *);
            rc = d ? sqlite3_bind_double(st, i, *d) : sqlite3_bind_null(st, i);
        } else {
            rc = sqlite3_bind_int64(st, i, va_arg(ap, int64_t));
        }
    }
    return rc;
}

/* A statement ready to step, or an error. */
static rd_error_code sq_vprep(sq_store *q, sqlite3_stmt **st, rd_error *err, const char *sql, const char *fmt,
                              va_list ap)
{
    int rc = sqlite3_prepare_v2(q->db, sql, -1, st, NULL);
    if (rc == SQLITE_OK)
        rc = sq_bind(*st, fmt, ap);
    if (rc == SQLITE_OK)
        return RD_OK;
    rd_error_code c = sq_fail(q, rc, "preparing a statement", err);
    sqlite3_finalize(*st);
    *st = NULL;
    return c;
}

static rd_error_code sq_prep(sq_store *q, sqlite3_stmt **st, rd_error *err, const char *sql, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = sq_vprep(q, st, err, sql, fmt, ap);
    va_end(ap);
    return c;
}

/* Runs a statement that returns no rows; *changes (may be NULL) the rows it
 * changed. */
static rd_error_code sq_run(sq_store *q, int *changes, rd_error *err, const char *sql, const char *fmt, ...)
{
    sqlite3_stmt *st;
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = sq_vprep(q, &st, err, sql, fmt, ap);
    va_end(ap);
    if (c)
        return c;
    int rc = sqlite3_step(st);
    if (rc == SQLITE_DONE || rc == SQLITE_ROW) {
        if (changes)
            *changes = sqlite3_changes(q->db);
    } else {
        c = sq_fail(q, rc, "writing", err);
    }
    sqlite3_finalize(st);
    return c;
}

/* Steps: 1 a row, 0 the end, or an error code (negated) with err set. */
static int sq_step(sq_store *q, sqlite3_stmt *st, rd_error *err)
{
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW)
        return 1;
    if (rc == SQLITE_DONE)
        return 0;
    return -(int)sq_fail(q, rc, "reading", err);
}

static rd_error_code sq_begin(sq_store *q, rd_error *err)
{
    int rc = sqlite3_exec(q->db, "BEGIN IMMEDIATE", NULL, NULL, NULL);
    return rc == SQLITE_OK ? RD_OK : sq_fail(q, rc, "beginning a transaction", err);
}

/* Commits when c is RD_OK, else rolls back (if SQLite has not already);
 * returns c or the commit's error. */
static rd_error_code sq_end(sq_store *q, rd_error_code c, rd_error *err)
{
    if (c == RD_OK) {
        int rc = sqlite3_exec(q->db, "COMMIT", NULL, NULL, NULL);
        if (rc == SQLITE_OK) {
            rd_store_committed(&q->base);
            return RD_OK;
        }
        c = sq_fail(q, rc, "committing", err);
    }
    if (!sqlite3_get_autocommit(q->db))
        sqlite3_exec(q->db, "ROLLBACK", NULL, NULL, NULL);
    return c;
}

static const char *col_text(sqlite3_stmt *st, int i)
{
    const unsigned char *t = sqlite3_column_text(st, i);
    return t ? (const char *)t : "";
}

/* The status of job id: RD_ERR_NOT_FOUND when there is none. */
static rd_error_code sq_status(sq_store *q, const char *id, rd_store_status *out, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT status FROM jobs WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        *out = (rd_store_status)rd_store_status_parse(col_text(st, 0));
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

/* Why a job that is not queued or running refused a change: gone, or
 * ended (RD_ERR_CANCELLED). */
static rd_error_code sq_not_runnable(sq_store *q, const char *id, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = sq_status(q, id, &st, err);
    if (c)
        return c;
    return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
}

/* A read, then a committed write of a few pages (deleted in the same
 * transaction): a store that cannot be written is not ready. */
static rd_error_code sq_ping(rd_store *s, rd_error *err)
{
    sq_store *q = sq(s);
    int changes;
    rd_error_code c = sq_run(q, &changes, err, "SELECT count(*) FROM schema_version", "");
    if (!c)
        c = sq_begin(q, err);
    if (!c)
        c = sq_run(q, NULL, err, "INSERT INTO write_probe (pad) VALUES (zeroblob(65536))", "");
    if (!c)
        c = sq_run(q, NULL, err, "DELETE FROM write_probe", "");
    return sq_end(q, c, err);
}

static rd_error_code sq_insert_tiles(sq_store *q, const char *id, int tiles, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "INSERT INTO tiles (job_id, tile) VALUES (?, ?)", "t", id);
    for (int i = 0; !c && i < tiles; i++) {
        int rc = sqlite3_bind_int(st, 2, i);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(st);
        if (rc != SQLITE_DONE)
            c = sq_fail(q, rc, "making tiles", err);
        sqlite3_reset(st);
    }
    sqlite3_finalize(st);
    return c;
}

static rd_error_code sq_create(rd_store *s, const rd_store_job_spec *j, rd_error *err)
{
    sq_store *q = sq(s);
    rd_store_status old;
    rd_error look;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_status(q, j->id, &old, &look);
    if (c != RD_OK && c != RD_ERR_NOT_FOUND)
        *err = look;
    else if (c == RD_OK)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s exists already", j->id);
    else if (c == RD_ERR_NOT_FOUND)
        c = sq_run(q, NULL, err,
                   "INSERT INTO jobs (id, status, scene, format, query, hdr, width, height, memory_bytes, "
                   "submitted_ms, tiles_total, passes, gated, schedule) "
                   "VALUES (?, 'queued', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                   "tbttiiiIIiiit", j->id, j->scene, j->scene_len, j->format, j->query ? j->query : "", j->hdr != 0,
                   j->width, j->height, j->memory_bytes, j->submitted_ms, j->tiles, j->passes, j->gated != 0,
                   j->schedule);
    if (!c && j->tiles)
        c = sq_insert_tiles(q, j->id, j->tiles, err);
    return sq_end(q, c, err);
}

static void sq_info_row(sqlite3_stmt *st, rd_store_job_info *o)
{
    memset(o, 0, sizeof *o);
    snprintf(o->id, sizeof o->id, "%s", col_text(st, 0));
    o->status = (rd_store_status)rd_store_status_parse(col_text(st, 1));
    snprintf(o->format, sizeof o->format, "%s", col_text(st, 2));
    o->hdr = sqlite3_column_int(st, 3);
    o->width = sqlite3_column_int(st, 4);
    o->height = sqlite3_column_int(st, 5);
    o->memory_bytes = sqlite3_column_int64(st, 6);
    o->submitted_ms = sqlite3_column_int64(st, 7);
    o->started_ms = sqlite3_column_int64(st, 8);
    o->finished_ms = sqlite3_column_int64(st, 9);
    if (sqlite3_column_type(st, 10) != SQLITE_NULL) {
        o->error.code = rd_store_code_parse(col_text(st, 10));
        o->error.line = sqlite3_column_int(st, 11);
        o->error.column = sqlite3_column_int(st, 12);
        snprintf(o->error.message, sizeof o->error.message, "%s", col_text(st, 13));
    }
    o->tiles_total = sqlite3_column_int(st, 15);
    o->tiles_done = sqlite3_column_int(st, 16);
    o->pass = sqlite3_column_int(st, 17);
    o->passes = sqlite3_column_int(st, 18);
    o->png_bytes = (size_t)sqlite3_column_int64(st, 19);
    o->exr_bytes = (size_t)sqlite3_column_int64(st, 20);
    o->gated = sqlite3_column_int(st, 21);
    o->open_pass = sqlite3_column_int(st, 22);
}

static rd_error_code sq_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "SELECT id, status, format, hdr, width, height, memory_bytes, submitted_ms, started_ms, "
                              "finished_ms, error_code, error_line, error_column, error_message, stats, tiles_total, "
                              "tiles_done, pass, passes, "
                              "(SELECT length(data) FROM results WHERE job_id = jobs.id AND kind = 'png'), "
                              "(SELECT length(data) FROM results WHERE job_id = jobs.id AND kind = 'exr'), "
                              "gated, open_pass, schedule FROM jobs WHERE id = ?",
                              "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1) {
        rd_store_job_info o;
        sq_info_row(st, &o);
        if ((sqlite3_column_type(st, 14) != SQLITE_NULL &&
             !(o.stats = rd_store_dup(col_text(st, 14), strlen(col_text(st, 14))))) ||
            (sqlite3_column_type(st, 23) != SQLITE_NULL &&
             !(o.schedule = rd_store_dup(col_text(st, 23), strlen(col_text(st, 23))))))
            c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's texts");
        if (!c)
            *out = o;
        else
            rd_store_job_info_free(&o);
    }
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return r < 0 ? (rd_error_code)-r : c;
}

static rd_error_code sq_input_row(sqlite3_stmt *st, rd_store_job_input *out, rd_error *err)
{
    rd_store_job_input in;
    memset(&in, 0, sizeof in);
    in.scene_len = (size_t)sqlite3_column_bytes(st, 0);
    in.scene = rd_store_dup(sqlite3_column_blob(st, 0), in.scene_len);
    snprintf(in.format, sizeof in.format, "%s", col_text(st, 1));
    in.query = rd_store_dup(col_text(st, 2), strlen(col_text(st, 2)));
    in.hdr = sqlite3_column_int(st, 3);
    in.width = sqlite3_column_int(st, 4);
    in.height = sqlite3_column_int(st, 5);
    in.memory_bytes = sqlite3_column_int64(st, 6);
    in.submitted_ms = sqlite3_column_int64(st, 7);
    if (!in.scene || !in.query) {
        rd_store_job_input_free(&in);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's scene");
    }
    *out = in;
    return RD_OK;
}

static rd_error_code sq_input(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "SELECT scene, format, query, hdr, width, height, memory_bytes, submitted_ms "
                              "FROM jobs WHERE id = ?",
                              "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        c = sq_input_row(st, out, err);
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return r < 0 ? (rd_error_code)-r : c;
}

/* Runs an UPDATE of a queued or running job; none changed: why. */
static rd_error_code sq_update_runnable(sq_store *q, const char *id, int changes, rd_error_code c, rd_error *err)
{
    if (c == RD_OK && changes == 0)
        c = sq_not_runnable(q, id, err);
    return c;
}

static rd_error_code sq_start(rd_store *s, const char *id, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err,
               "UPDATE jobs SET status = 'running', started_ms = coalesce(started_ms, ?) "
               "WHERE id = ? AND status IN ('queued', 'running')",
               "It", rd_wall_ms(), id);
    return sq_end(q, sq_update_runnable(q, id, n, c, err), err);
}

static rd_error_code sq_stats(rd_store *s, const char *id, const char *stats, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err, "UPDATE jobs SET stats = ? WHERE id = ? AND status IN ('queued', 'running')", "tt", stats,
               id);
    return sq_end(q, sq_update_runnable(q, id, n, c, err), err);
}

static rd_error_code sq_images(sq_store *q, const char *id, const rd_store_result *r, rd_error *err)
{
    const char *sql = "INSERT INTO results (job_id, kind, data) VALUES (?, ?, ?)";
    rd_error_code c = sq_run(q, NULL, err, sql, "ttb", id, "png", r->png, r->png_len);
    if (!c && r->exr)
        c = sq_run(q, NULL, err, sql, "ttb", id, "exr", r->exr, r->exr_len);
    return c;
}

static rd_error_code sq_end_job(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                                const rd_store_result *r, int *changed, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_store_status st;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err,
               "UPDATE jobs SET status = ?, finished_ms = ?, stats = coalesce(?, stats), error_code = ?, "
               "error_line = ?, error_column = ?, error_message = ? WHERE id = ? AND status IN ('queued', 'running')",
               "tIttiitt", rd_store_status_name(to), rd_wall_ms(), r ? r->stats : NULL,
               why ? rd_error_name(why->code) : NULL, why ? why->line : 0, why ? why->column : 0,
               why ? why->message : NULL, id);
    if (!c && n == 0)
        c = sq_status(q, id, &st, err);
    else if (!c)
        c = sq_run(q, NULL, err, "DELETE FROM tiles WHERE job_id = ?", "t", id);
    if (!c && n && to == RD_STORE_DONE)
        c = sq_images(q, id, r, err);
    *changed = n;
    return sq_end(q, c, err);
}

static rd_error_code sq_delete(rd_store *s, const char *id, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (!c)
        c = sq_run(q, NULL, err, "DELETE FROM tiles WHERE job_id = ?", "t", id);
    if (!c)
        c = sq_run(q, NULL, err, "DELETE FROM results WHERE job_id = ?", "t", id);
    if (!c)
        c = sq_run(q, &n, err, "DELETE FROM jobs WHERE id = ?", "t", id);
    if (!c && n == 0)
        c = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return sq_end(q, c, err);
}

static rd_error_code sq_no_image(sq_store *q, const char *id, rd_store_image_kind kind, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = sq_status(q, id, &st, err);
    if (c)
        return c;
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s (%s) has no %s", id, rd_store_status_name(st),
                        kind == RD_STORE_PNG ? "PNG" : "EXR");
}

static rd_error_code sq_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data, size_t *len,
                              rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT data FROM results WHERE job_id = ? AND kind = ?", "tt", id,
                              kind == RD_STORE_PNG ? "png" : "exr");
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1) {
        size_t n = (size_t)sqlite3_column_bytes(st, 0);
        unsigned char *d = rd_store_dup(sqlite3_column_blob(st, 0), n);
        if (d) {
            *data = d;
            *len = n;
        } else {
            c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for an image");
        }
    }
    sqlite3_finalize(st);
    if (r == 0)
        return sq_no_image(q, id, kind, err);
    return r < 0 ? (rd_error_code)-r : c;
}

/* Room for entry k of a list read row by row, doubling it when full. */
static rd_error_code room_for(size_t k, size_t *cap, void **list, size_t size, const char *what, rd_error *err)
{
    if (!rd_grow_array(list, cap, k + 1, size, 16))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for %s", what);
    return RD_OK;
}

static rd_error_code sq_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n, rd_error *err)
{
    sq_store *q = sq(s);
    const char *names[RD_STORE_STATUS_COUNT];
    for (int i = 0; i < RD_STORE_STATUS_COUNT; i++)
        names[i] = mask & RD_STORE_MASK(i) ? rd_store_status_name((rd_store_status)i) : NULL;
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "SELECT id, status, submitted_ms FROM jobs WHERE status IN (?, ?, ?, ?, ?) "
                              "ORDER BY submitted_ms, id LIMIT ?",
                              "tttttI", names[0], names[1], names[2], names[3], names[4],
                              (int64_t)(max > INT64_MAX ? INT64_MAX : max));
    rd_store_job_brief *list = NULL;
    size_t k = 0, cap = 0;
    int r = 0;
    while (!c && (r = sq_step(q, st, err)) == 1) {
        if ((c = room_for(k, &cap, (void **)&list, sizeof *list, "a job list", err)))
            break;
        snprintf(list[k].id, sizeof list[k].id, "%s", col_text(st, 0));
        list[k].status = (rd_store_status)rd_store_status_parse(col_text(st, 1));
        list[k++].submitted_ms = sqlite3_column_int64(st, 2);
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    sqlite3_finalize(st);
    if (c) {
        free(list);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

static rd_error_code sq_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    sq_store *q = sq(s);
    int64_t cut = rd_wall_ms() - ttl_ms;
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (!c)
        c = sq_run(q, NULL, err,
                   "DELETE FROM results WHERE job_id IN (SELECT id FROM jobs "
                   "WHERE status IN ('done', 'failed', 'cancelled') AND finished_ms < ?)",
                   "I", cut);
    if (!c)
        c = sq_run(q, &n, err, "DELETE FROM jobs WHERE status IN ('done', 'failed', 'cancelled') AND finished_ms < ?",
                   "I", cut);
    *deleted = (size_t)n;
    return sq_end(q, c, err);
}

static rd_error_code sq_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err,
               "UPDATE jobs SET tiles_total = ?, passes = ?, tiles_done = 0, pass = 0, open_pass = 1 "
               "WHERE id = ? AND status IN ('queued', 'running') AND tiles_total = 0",
               "iit", tiles, passes, id);
    if (!c && n == 0) {
        rd_store_status st;
        c = sq_status(q, id, &st, err);
        if (!c && (st == RD_STORE_QUEUED || st == RD_STORE_RUNNING))
            c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s has its tiles already", id);
        else if (!c)
            c = rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
    }
    if (!c)
        c = sq_insert_tiles(q, id, tiles, err);
    return sq_end(q, c, err);
}

/* The oldest runnable job with a claimable tile: *found 0 when none. A
 * gated job whose current pass is not open yet is passed over here, not
 * after, so that it does not hold up the jobs behind it. */
static rd_error_code sq_claimable_job(sq_store *q, int64_t now, const rd_store_claim_filter *f, char *id, int *pass,
                                      int *found, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c =
        sq_prep(q, &st, err,
                "SELECT j.id, j.pass FROM jobs j WHERE j.status IN ('queued', 'running') AND j.pass < j.passes "
                "AND (j.gated = 0 OR j.pass < j.open_pass) AND (?2 IS NULL OR j.id = ?2) "
                "AND (?3 <= 0 OR j.memory_bytes <= ?3) AND EXISTS "
                "(SELECT 1 FROM tiles t WHERE t.job_id = j.id AND t.passes_done = j.pass "
                "AND (t.owner IS NULL OR t.lease_until < ?1)) ORDER BY j.submitted_ms, j.id LIMIT 1",
                "ItI", now, f->job_id, f->max_memory_bytes);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1) {
        snprintf(id, RD_STORE_ID_MAX, "%s", col_text(st, 0));
        *pass = sqlite3_column_int(st, 1);
    }
    *found = r == 1;
    sqlite3_finalize(st);
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

static int tile_cmp(const void *a, const void *b)
{
    const rd_store_tile *x = a, *y = b;
    return (x->index > y->index) - (x->index < y->index);
}

static rd_error_code sq_take_tiles(sq_store *q, const char *daemon, const char *id, int pass, int max, int64_t now,
                                   int lease_ms, rd_store_tile *out, int *n, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "UPDATE tiles SET owner = ?1, lease_until = ?2 WHERE job_id = ?3 AND tile IN "
                              "(SELECT tile FROM tiles WHERE job_id = ?3 AND passes_done = ?4 "
                              "AND (owner IS NULL OR lease_until < ?5) ORDER BY tile LIMIT ?6) RETURNING tile",
                              "tItiIi", daemon, now + lease_ms, id, pass, now, max);
    int k = 0, r = 0;
    while (!c && (r = sq_step(q, st, err)) == 1 && k < max) {
        snprintf(out[k].job_id, sizeof out[k].job_id, "%s", id);
        out[k].pass = pass;
        out[k++].index = sqlite3_column_int(st, 0);
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    sqlite3_finalize(st);
    qsort(out, (size_t)k, sizeof *out, tile_cmp);
    *n = k;
    return c;
}

static rd_error_code sq_claim(rd_store *s, const char *daemon, int max, int lease_ms, const rd_store_claim_filter *f,
                              rd_store_tile *out, int *n, rd_error *err)
{
    sq_store *q = sq(s);
    char id[RD_STORE_ID_MAX];
    int pass = 0, found = 0, k = 0;
    int64_t now = rd_wall_ms();
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_claimable_job(q, now, f, id, &pass, &found, err);
    if (!c && found)
        c = sq_take_tiles(q, daemon, id, pass, max, now, lease_ms, out, &k, err);
    if (!c && k)
        c = sq_run(q, NULL, err,
                   "UPDATE jobs SET status = 'running', started_ms = ? WHERE id = ? AND status = 'queued'", "It", now,
                   id);
    c = sq_end(q, c, err);
    if (!c)
        *n = k;
    return c;
}

static rd_error_code sq_leases(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err)
{
    sq_store *q = sq(s);
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    if (lease_ms < 0)
        c = sq_run(q, count, err, "UPDATE tiles SET owner = NULL, lease_until = NULL WHERE owner = ?", "t", daemon);
    else
        c = sq_run(q, count, err, "UPDATE tiles SET lease_until = ? WHERE owner = ?", "It", rd_wall_ms() + lease_ms,
                   daemon);
    return sq_end(q, c, err);
}

/* Why tile_done changed no tile: the job is gone or ended, else the tile is
 * not (or no longer) this daemon's for this pass. */
static rd_error_code sq_tile_refused(sq_store *q, const char *daemon, const rd_store_tile *t, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = sq_status(q, t->job_id, &st, err);
    return c ? c : rd_store_refusal(st, daemon, t, err);
}

/* Counts a tile of the current pass done; advances the pass when it was
 * the last. */
static rd_error_code sq_count_tile(sq_store *q, const rd_store_tile *t, rd_store_tile_outcome *outcome, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "UPDATE jobs SET tiles_done = tiles_done + 1 WHERE id = ? AND pass = ? "
                              "AND status IN ('queued', 'running') RETURNING tiles_done, tiles_total, passes",
                              "ti", t->job_id, t->pass);
    if (c)
        return c;
    int r = sq_step(q, st, err), done = 0, total = 0, passes = 0;
    if (r == 1) {
        done = sqlite3_column_int(st, 0);
        total = sqlite3_column_int(st, 1);
        passes = sqlite3_column_int(st, 2);
        sq_step(q, st, NULL);
    }
    sqlite3_finalize(st);
    if (r <= 0)
        return r < 0 ? (rd_error_code)-r : sq_not_runnable(q, t->job_id, err);
    *outcome = RD_STORE_TILE_MORE;
    if (done < total)
        return RD_OK;
    int last = t->pass + 1 >= passes;
    *outcome = last ? RD_STORE_TILE_JOB_DONE : RD_STORE_TILE_PASS_DONE;
    return sq_run(q, NULL, err, "UPDATE jobs SET pass = ?, tiles_done = ? WHERE id = ?", "iit", t->pass + 1,
                  last ? total : 0, t->job_id);
}

static rd_error_code sq_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data, size_t len,
                                  rd_store_tile_outcome *outcome, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_store_tile_outcome o = RD_STORE_TILE_MORE;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err,
               "UPDATE tiles SET passes_done = passes_done + 1, owner = NULL, lease_until = NULL, data = ? "
               "WHERE job_id = ? AND tile = ? AND passes_done = ? AND owner = ?",
               "btiit", data, len, t->job_id, t->index, t->pass, daemon);
    if (!c)
        c = n ? sq_count_tile(q, t, &o, err) : sq_tile_refused(q, daemon, t, err);
    c = sq_end(q, c, err);
    if (!c)
        *outcome = o;
    return c;
}

/* Why an UPDATE that opens a pass changed nothing. */
static rd_error_code sq_pass_refused(sq_store *q, const char *id, int pass, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c =
        sq_prep(q, &st, err, "SELECT status, gated, pass, passes, open_pass FROM jobs WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        c = rd_store_pass_refusal(id, pass, (rd_store_status)rd_store_status_parse(col_text(st, 0)),
                                  sqlite3_column_int(st, 1), sqlite3_column_int(st, 2), sqlite3_column_int(st, 3),
                                  sqlite3_column_int(st, 4), err);
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return r < 0 ? (rd_error_code)-r : c;
}

/* The WHERE is the whole rule (gated, running, pass - 1 complete, pass not
 * yet open): under BEGIN IMMEDIATE two openers run one after the other,
 * and the second finds open_pass moved on. Waiting handles see the commit
 * through data_version. */
static rd_error_code sq_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err)
{
    sq_store *q = sq(s);
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err,
               "UPDATE jobs SET open_pass = ?1 + 1, schedule = coalesce(?2, schedule) "
               "WHERE id = ?3 AND gated = 1 AND status IN ('queued', 'running') "
               "AND pass = ?1 AND open_pass = ?1 AND pass < passes",
               "itt", pass, schedule, id);
    if (!c && n == 0)
        c = sq_pass_refused(q, id, pass, err);
    return sq_end(q, c, err);
}

static rd_error_code sq_tile_row(sqlite3_stmt *st, rd_store_tile_data *t, rd_error *err)
{
    t->index = sqlite3_column_int(st, 0);
    t->passes = sqlite3_column_int(st, 1);
    t->len = (size_t)sqlite3_column_bytes(st, 2);
    t->data = NULL;
    if (sqlite3_column_type(st, 2) == SQLITE_NULL)
        return RD_OK;
    t->data = rd_store_dup(sqlite3_column_blob(st, 2), t->len);
    return t->data ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a tile");
}

static rd_error_code sq_tiles_get(rd_store *s, const char *id, int index, rd_store_tile_data **out, size_t *n,
                                  rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c =
        index < 0 ? sq_prep(q, &st, err,
                            "SELECT tile, passes_done, data FROM tiles WHERE job_id = ? AND passes_done > 0 "
                            "ORDER BY tile",
                            "t", id)
                  : sq_prep(q, &st, err, "SELECT tile, passes_done, data FROM tiles WHERE job_id = ? AND tile = ?",
                            "ti", id, index);
    rd_store_tile_data *list = NULL;
    size_t k = 0, cap = 0;
    int r = 0;
    while (!c && (r = sq_step(q, st, err)) == 1) {
        if ((c = room_for(k, &cap, (void **)&list, sizeof *list, "tiles", err)))
            break;
        if (!(c = sq_tile_row(st, &list[k], err)))
            k++;
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    sqlite3_finalize(st);
    rd_store_status status;
    if (!c && k == 0)
        c = sq_status(q, id, &status, err);
    if (c) {
        rd_store_tiles_free(list, k);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

static rd_error_code sq_data_version(sq_store *q, long long *v, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "PRAGMA data_version", "");
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        *v = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

/* One process, one file: nothing to listen to, so it looks at
 * data_version, which moves with every other connection's commit. */
static rd_error_code sq_wait(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err)
{
    sq_store *q = sq(s);
    for (int waited = 0;; waited += 10) {
        long long v = 0;
        pthread_mutex_lock(&s->lock);
        rd_error_code c = sq_data_version(q, &v, err);
        int changed = !c && v != q->data_version;
        q->data_version = v;
        pthread_mutex_unlock(&s->lock);
        if (c || changed || waited >= timeout_ms) {
            ev->kind = changed ? RD_STORE_EV_CHANGED : RD_STORE_EV_NONE;
            return c;
        }
        struct timespec ts = {0, 10 * 1000000L};
        nanosleep(&ts, NULL);
    }
}

/* Grades and batches. */

/* *found: whether sql (a SELECT on id) has a row. */
static rd_error_code sq_exists(sq_store *q, const char *sql, const char *id, int *found, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, sql, "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    sqlite3_finalize(st);
    *found = r == 1;
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

/* RD_ERR_INVALID when a grade of that id exists. */
static rd_error_code sq_grade_new(sq_store *q, const char *id, rd_error *err)
{
    int found = 0;
    rd_error_code c = sq_exists(q, "SELECT 1 FROM grades WHERE id = ?", id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s exists already", id);
    return c;
}

/* Why a batch counted no grade of assignment. */
static rd_error_code sq_batch_refused(sq_store *q, const char *id, const char *assignment, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT status, assignment, done, total FROM batches WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        c = rd_store_batch_refusal(id, assignment, (rd_store_batch_status)rd_store_batch_status_parse(col_text(st, 0)),
                                   col_text(st, 1), sqlite3_column_int(st, 2), sqlite3_column_int(st, 3), err);
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    return r < 0 ? (rd_error_code)-r : c;
}

/* Counts a grade of its batch, which becomes done with its last: the
 * WHERE is the whole rule, and BEGIN IMMEDIATE runs two puts one after
 * the other, so the second sees the first's count. */
static rd_error_code sq_count_grade(sq_store *q, const rd_store_grade *g, rd_error *err)
{
    int n = 0;
    rd_error_code c = sq_run(q, &n, err,
                             "UPDATE batches SET done = done + 1, "
                             "status = CASE WHEN done + 1 >= total THEN 'done' ELSE status END "
                             "WHERE id = ? AND status = 'running' AND assignment = ? AND done < total",
                             "tt", g->batch_id, g->assignment);
    if (!c && n == 0)
        c = sq_batch_refused(q, g->batch_id, g->assignment, err);
    return c;
}

static rd_error_code sq_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                                  rd_error *err)
{
    sq_store *q = sq(s);
    int graded = !g->error;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_grade_new(q, g->id, err);
    if (!c && g->batch_id)
        c = sq_count_grade(q, g, err);
    if (!c)
        c = sq_run(q, NULL, err,
                   "INSERT INTO grades (" RD_STORE_GRADE_COLUMNS ") VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                   "ttttiddddttIt", g->id, g->batch_id, g->assignment, g->student, g->pass,
                   graded ? &g->failed_fraction : NULL, graded ? &g->max_abs : NULL, graded ? &g->psnr_db : NULL,
                   graded ? &g->ssim : NULL, g->verdict, g->reference_key, g->graded_ms, g->error);
    if (!c && diff)
        c = sq_run(q, NULL, err, "INSERT INTO grade_images (grade_id, kind, data) VALUES (?, 'diff', ?)", "tb", g->id,
                   (const void *)diff, len);
    return sq_end(q, c, err);
}

static const char *col_text_or_null(sqlite3_stmt *st, int i)
{
    return sqlite3_column_type(st, i) == SQLITE_NULL ? NULL : col_text(st, i);
}

static double col_metric(sqlite3_stmt *st, int i)
{
    return sqlite3_column_type(st, i) == SQLITE_NULL ? NAN : sqlite3_column_double(st, i);
}

/* A row of RD_STORE_GRADE_COLUMNS. */
static rd_error_code sq_grade_row(sqlite3_stmt *st, rd_store_grade *g, rd_error *err)
{
    memset(g, 0, sizeof *g);
    g->pass = sqlite3_column_int(st, 4);
    g->failed_fraction = col_metric(st, 5);
    g->max_abs = col_metric(st, 6);
    g->psnr_db = col_metric(st, 7);
    g->ssim = col_metric(st, 8);
    g->graded_ms = sqlite3_column_int64(st, 11);
    const char *texts[RD_STORE_GRADE_TEXTS] = {
        col_text_or_null(st, 0), col_text_or_null(st, 1),  col_text_or_null(st, 2), col_text_or_null(st, 3),
        col_text_or_null(st, 9), col_text_or_null(st, 10), col_text_or_null(st, 12)};
    return rd_store_grade_texts(g, texts, err);
}

static rd_error_code sq_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT " RD_STORE_GRADE_COLUMNS " FROM grades WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    rd_store_grade g;
    if (r == 1 && !(c = sq_grade_row(st, &g, err)))
        *out = g;
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no grade %s", id);
    return r < 0 ? (rd_error_code)-r : c;
}

static rd_error_code sq_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                    size_t *len, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    const char *name = rd_store_grade_image_name(kind);
    rd_error_code c =
        sq_prep(q, &st, err, "SELECT data FROM grade_images WHERE grade_id = ? AND kind = ?", "tt", id, name);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1) {
        size_t n = (size_t)sqlite3_column_bytes(st, 0);
        unsigned char *d = rd_store_dup(sqlite3_column_blob(st, 0), n);
        if (d) {
            *data = d;
            *len = n;
        } else {
            c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for an image");
        }
    }
    sqlite3_finalize(st);
    if (r < 0 || r == 1)
        return r < 0 ? (rd_error_code)-r : c;
    int found = 0;
    if ((c = sq_exists(q, "SELECT 1 FROM grades WHERE id = ?", id, &found, err)))
        return c;
    if (!found)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no grade %s", id);
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s has no %s image", id, name);
}

/* The filter's conditions are written in only when given, so that each
 * listing can use its index; the values are bound (?1 to ?5) all the same. */
static rd_error_code sq_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                    rd_error *err)
{
    sq_store *q = sq(s);
    char sql[400];
    snprintf(sql, sizeof sql,
             "SELECT " RD_STORE_GRADE_COLUMNS " FROM grades WHERE graded_ms >= ?1%s%s%s "
             "ORDER BY graded_ms, id LIMIT ?5",
             f->assignment ? " AND assignment = ?2" : "", f->student ? " AND student = ?3" : "",
             f->batch_id ? " AND batch_id = ?4" : "");
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, sql, "ItttI", f->since_ms, f->assignment, f->student, f->batch_id,
                              (int64_t)(f->max > INT64_MAX ? INT64_MAX : f->max));
    rd_store_grade *list = NULL;
    size_t k = 0, cap = 0;
    int r = 0;
    while (!c && (r = sq_step(q, st, err)) == 1) {
        if ((c = room_for(k, &cap, (void **)&list, sizeof *list, "a grade list", err)))
            break;
        if (!(c = sq_grade_row(st, &list[k], err)))
            k++;
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    sqlite3_finalize(st);
    if (c) {
        rd_store_grades_free(list, k);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

/* BEGIN IMMEDIATE holds off every put meanwhile, so a batch found with no
 * grade left cannot be given one before it goes. */
static rd_error_code sq_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    sq_store *q = sq(s);
    int64_t cut = rd_wall_ms() - ttl_ms;
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (!c)
        c = sq_run(q, NULL, err,
                   "DELETE FROM grade_images WHERE grade_id IN (SELECT id FROM grades WHERE graded_ms < ?)", "I", cut);
    if (!c)
        c = sq_run(q, &n, err, "DELETE FROM grades WHERE graded_ms < ?", "I", cut);
    if (!c)
        c = sq_run(q, NULL, err,
                   "DELETE FROM batches WHERE created_ms < ? "
                   "AND NOT EXISTS (SELECT 1 FROM grades WHERE batch_id = batches.id)",
                   "I", cut);
    *deleted = (size_t)n;
    return sq_end(q, c, err);
}

static rd_error_code sq_batch_create(rd_store *s, const char *id, const char *assignment, int total, const char *daemon,
                                     const char *students, rd_error *err)
{
    sq_store *q = sq(s);
    int found = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_exists(q, "SELECT 1 FROM batches WHERE id = ?", id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: batch %s exists already", id);
    if (!c)
        c = sq_run(q, NULL, err,
                   "INSERT INTO batches (id, assignment, total, done, status, created_ms, daemon, students) "
                   "VALUES (?, ?, ?, 0, 'running', ?, ?, ?)",
                   "ttiItt", id, assignment, total, rd_wall_ms(), daemon, students);
    return sq_end(q, c, err);
}

#define BATCH_COLUMNS "id, assignment, total, done, status, created_ms"

/* The batch of a row of BATCH_COLUMNS. */
static rd_store_batch sq_batch_of(sqlite3_stmt *st)
{
    rd_store_batch b;
    memset(&b, 0, sizeof b);
    snprintf(b.id, sizeof b.id, "%s", col_text(st, 0));
    snprintf(b.assignment, sizeof b.assignment, "%s", col_text(st, 1));
    b.total = sqlite3_column_int(st, 2);
    b.done = sqlite3_column_int(st, 3);
    b.status = (rd_store_batch_status)rd_store_batch_status_parse(col_text(st, 4));
    b.created_ms = sqlite3_column_int64(st, 5);
    return b;
}

static rd_error_code sq_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT " BATCH_COLUMNS " FROM batches WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    if (r == 1)
        *out = sq_batch_of(st);
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

static rd_error_code sq_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                        rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err,
                              "SELECT " BATCH_COLUMNS " FROM batches WHERE daemon = ? AND status = 'running' "
                              "ORDER BY created_ms, id LIMIT ?",
                              "tI", daemon, (int64_t)(max > INT64_MAX ? INT64_MAX : max));
    rd_store_batch *list = NULL;
    size_t k = 0, cap = 0;
    int r = 0;
    while (!c && (r = sq_step(q, st, err)) == 1) {
        if ((c = room_for(k, &cap, (void **)&list, sizeof *list, "a batch list", err)))
            break;
        list[k++] = sq_batch_of(st);
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    sqlite3_finalize(st);
    if (c) {
        free(list);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

static rd_error_code sq_batch_students(rd_store *s, const char *id, char **students, rd_error *err)
{
    sq_store *q = sq(s);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT students FROM batches WHERE id = ?", "t", id);
    if (c)
        return c;
    int r = sq_step(q, st, err);
    char *t = NULL;
    if (r == 1 && !(t = rd_store_dup(col_text(st, 0), strlen(col_text(st, 0)))))
        r = -(int)rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: out of memory reading a batch's students");
    sqlite3_finalize(st);
    if (r == 0)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    if (r < 0)
        return (rd_error_code)-r;
    *students = t;
    return RD_OK;
}

static rd_error_code sq_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err)
{
    sq_store *q = sq(s);
    rd_store_batch b;
    int n = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, &n, err, "UPDATE batches SET status = 'cancelled' WHERE id = ? AND status = 'running'", "t", id);
    if (!c && n == 0)
        c = sq_batch_get(s, id, &b, err);
    *changed = n;
    return sq_end(q, c, err);
}

static void sq_close(rd_store *s)
{
    sqlite3_close(sq(s)->db);
    free(s);
}

static rd_error_code sq_migrate(sq_store *q, rd_error *err);

static const rd_store_ops sq_ops = {
    .name = "sqlite",
    .close = sq_close,
    .ping = sq_ping,
    .job_create = sq_create,
    .job_get = sq_get,
    .job_input = sq_input,
    .job_start = sq_start,
    .job_stats = sq_stats,
    .job_end = sq_end_job,
    .job_delete = sq_delete,
    .job_image = sq_image,
    .jobs_list = sq_list,
    .jobs_expire = sq_expire,
    .tiles_init = sq_tiles_init,
    .claim = sq_claim,
    .leases = sq_leases,
    .tile_done = sq_tile_done,
    .pass_open = sq_pass_open,
    .tiles_get = sq_tiles_get,
    .wait = sq_wait,
    .grade_put = sq_grade_put,
    .grade_get = sq_grade_get,
    .grade_image = sq_grade_image,
    .grades_list = sq_grades_list,
    .grades_expire = sq_grades_expire,
    .batch_create = sq_batch_create,
    .batch_get = sq_batch_get,
    .batches_running = sq_batches_running,
    .batch_students = sq_batch_students,
    .batch_cancel = sq_batch_cancel,
};

/* Migrations. */

static rd_error_code sq_version(sq_store *q, int *v, rd_error *err)
{
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "SELECT coalesce(max(version), 0) FROM schema_version", "");
    if (c)
        return c;
    int r = sq_step(q, st, err);
    *v = r == 1 ? sqlite3_column_int(st, 0) : 0;
    sqlite3_finalize(st);
    return r < 0 ? (rd_error_code)-r : RD_OK;
}

static rd_error_code sq_apply(sq_store *q, const rd_store_migration *m, rd_error *err)
{
    char *sql = rd_store_migration_text(m->sql, "BLOB");
    if (!sql)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for migration %s", m->name);
    int rc = sqlite3_exec(q->db, sql, NULL, NULL, NULL);
    free(sql);
    if (rc != SQLITE_OK) {
        char what[96];
        snprintf(what, sizeof what, "migration %s", m->name);
        return sq_fail(q, rc, what, err);
    }
    return sq_run(q, NULL, err, "INSERT INTO schema_version (version, name, applied_ms) VALUES (?, ?, ?)", "itI",
                  m->version, m->name, rd_wall_ms());
}

static rd_error_code sq_migrate(sq_store *q, rd_error *err)
{
    int v = 0;
    rd_error_code c = sq_begin(q, err);
    if (c)
        return c;
    c = sq_run(q, NULL, err,
               "CREATE TABLE IF NOT EXISTS schema_version (version INTEGER PRIMARY KEY, name TEXT NOT NULL, "
               "applied_ms BIGINT NOT NULL)",
               "");
    if (!c)
        c = sq_version(q, &v, err);
    if (!c && v > rd_store_migration_count)
        c = rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0,
                         "store: its schema is version %d, newer than this rayd's %d: run a newer rayd", v,
                         rd_store_migration_count);
    for (int i = v; !c && i < rd_store_migration_count; i++)
        c = sq_apply(q, &rd_store_migrations[i], err);
    return sq_end(q, c, err);
}

/* Opening. */

/* mkdir -p, each missing folder 0750. */
static rd_error_code make_folder(const char *path, rd_error *err)
{
    char p[4096];
    if (snprintf(p, sizeof p, "%s", path) >= (int)sizeof p)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: folder name too long");
    for (char *s = p + 1;; s++) {
        if (*s && *s != '/')
            continue;
        char keep = *s;
        *s = '\0';
        if (mkdir(p, 0750) != 0 && errno != EEXIST)
            return rd_error_set(err, RD_ERR_IO, 0, 0, "store: cannot make folder %s: %s", p, strerror(errno));
        if (!(*s = keep))
            break;
    }
    struct stat sb;
    if (stat(p, &sb) != 0 || !S_ISDIR(sb.st_mode))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "store: %s is not a folder", path);
    return RD_OK;
}

static rd_error_code sq_pragmas(sq_store *q, int sync_full, rd_error *err)
{
    char mode[16] = "";
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "PRAGMA journal_mode = WAL", "");
    if (c)
        return c;
    if (sq_step(q, st, err) == 1)
        snprintf(mode, sizeof mode, "%s", col_text(st, 0));
    sqlite3_finalize(st);
    if (strcmp(mode, "wal") != 0)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "store: %s cannot be in WAL mode (journal mode %s)",
                            sqlite3_db_filename(q->db, "main"), mode[0] ? mode : "unknown");
    int rc =
        sqlite3_exec(q->db, sync_full ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL", NULL, NULL, NULL);
    if (rc == SQLITE_OK)
        rc = sqlite3_exec(q->db, "PRAGMA foreign_keys = ON", NULL, NULL, NULL);
    return rc == SQLITE_OK ? RD_OK : sq_fail(q, rc, "setting up", err);
}

/* A bounded PRAGMA quick_check: a damaged page is found at the start,
 * not by the request that reads it. The check stops after QUICK_CHECK_MS
 * (a large store is checked as far as that goes), never holding the start
 * up longer. */
enum { QUICK_CHECK_MS = 5000 };

static int past_deadline(void *deadline) { return rd_wall_ms() > *(long long *)deadline; }

static rd_error_code sq_quick_check(sq_store *q, rd_error *err)
{
    long long deadline = rd_wall_ms() + QUICK_CHECK_MS;
    sqlite3_progress_handler(q->db, 10000, past_deadline, &deadline);
    sqlite3_stmt *st;
    rd_error_code c = sq_prep(q, &st, err, "PRAGMA quick_check(1)", "");
    int r = c ? 0 : sqlite3_step(st);
    if (r == SQLITE_ROW && strcmp(col_text(st, 0), "ok") != 0)
        c = rd_error_set(err, RD_ERR_DAMAGED, 0, 0, "store: %s is damaged (PRAGMA quick_check: %.300s)",
                         sqlite3_db_filename(q->db, "main"), col_text(st, 0));
    else if (r != SQLITE_ROW && r != SQLITE_DONE && r != SQLITE_INTERRUPT && !c)
        c = sq_fail(q, r, "checking the database (PRAGMA quick_check)", err);
    sqlite3_finalize(st);
    sqlite3_progress_handler(q->db, 0, NULL, NULL);
    return c;
}

/* A zero-length rayd.sqlite3 would open as an empty store: the jobs and
 * grades it held are gone, and starting over must be an operator's
 * choice. */
static rd_error_code refuse_empty_file(const char *path, rd_error *err)
{
    struct stat sb;
    if (stat(path, &sb) == 0 && S_ISREG(sb.st_mode) && sb.st_size == 0)
        return rd_error_set(err, RD_ERR_DAMAGED, 0, 0,
                            "store: %s is empty (0 bytes), not a store: its data is lost; move it away to start an "
                            "empty store",
                            path);
    return RD_OK;
}

rd_store *rd_store_sqlite_open(const char *folder, const rd_store_options *opt, rd_error *err)
{
    char path[4200];
    if (make_folder(folder, err))
        return NULL;
    snprintf(path, sizeof path, "%s/rayd.sqlite3", folder);
    if (refuse_empty_file(path, err))
        return NULL;
    sq_store *q = calloc(1, sizeof *q);
    if (!q) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory");
        return NULL;
    }
    q->base.ops = &sq_ops;
    q->base.opt = *opt;
    int rc = sqlite3_open_v2(path, &q->db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, NULL);
    rd_error_code c = rc == SQLITE_OK ? RD_OK : sq_fail(q, rc, path, err);
    if (!c)
        sqlite3_busy_timeout(q->db, opt->timeout_ms);
    if (!c)
        c = sq_pragmas(q, opt->sync_full, err);
    if (!c)
        c = sq_quick_check(q, err);
    if (!c)
        c = sq_migrate(q, err);
    if (!c)
        c = sq_data_version(q, &q->data_version, err);
    if (c) {
        sq_close(&q->base);
        return NULL;
    }
    return &q->base;
}
