/* Every operation of the store, written once: one SQL text each, which both
 * engines run through their drivers (store_internal.h). Where the engines
 * really differ the text names a fragment of the dialect:
 *   @NOW@          the store's clock, in milliseconds: SQLite's is this
 *                  machine's (the driver's rayd_now()); PostgreSQL's the
 *                  server's, so that daemons on machines whose clocks
 *                  differ agree on leases.
 *   @LOCK@         PostgreSQL runs writers side by side, so a transaction
 *                  locks the rows it decides on; SQLite's BEGIN IMMEDIATE
 *                  lets one writer in at a time, and needs nothing.
 *   @SKIP_LOCKED@  the same for the claim: concurrent claims pass each
 *                  other's tiles instead of waiting for them.
 * Values are bound, never written into SQL.
 *
 * Locks are always taken tiles first, then the job, and a grade's batch
 * before the grade, so that two PostgreSQL transactions never wait for each
 * other in a circle. */
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "migrations.h"
#include "rayd/memory.h"
#include "store_internal.h"
#include "strbuf.h"

/* SQL text. */

static const char *fragment(const rd_store_dialect *d, const char *name, size_t len)
{
    const struct {
        const char *name, *text;
    } marks[] = {{"NOW", d->now}, {"LOCK", d->lock}, {"SKIP_LOCKED", d->skip_locked}, {"BLOB", d->blob}};
    for (size_t i = 0; i < sizeof marks / sizeof marks[0]; i++)
        if (strlen(marks[i].name) == len && memcmp(marks[i].name, name, len) == 0)
            return marks[i].text ? marks[i].text : "";
    return NULL;
}

char *rd_store_sql(const char *sql, const rd_store_dialect *d, int values)
{
    rd_strbuf b = {0};
    int dollar = values && d->dollar, quoted = 0, top = 0;
    for (const char *p = sql; *p;) {
        size_t n = strcspn(p, dollar ? "@?'" : "@");
        rd_strbuf_append(&b, p, n);
        p += n;
        const char *close = *p == '@' ? strchr(p + 1, '@') : NULL;
        const char *f = close ? fragment(d, p + 1, (size_t)(close - p - 1)) : NULL;
        if (f) {
            rd_strbuf_append(&b, f, strlen(f));
            p = close + 1;
        } else if (*p == '?' && !quoted) {
            /* As SQLite numbers them: ?N is N, a bare ? one past the highest so far. */
            char *end = (char *)p + 1;
            int k = isdigit((unsigned char)*end) ? (int)strtol(end, &end, 10) : top + 1;
            top = k > top ? k : top;
            rd_strbuf_printf(&b, "$%d", k);
            p = end;
        } else if (*p) {
            quoted ^= *p == '\'';
            rd_strbuf_append(&b, p++, 1);
        }
    }
    return rd_strbuf_take(&b, NULL);
}

char *rd_store_migration_text(const char *sql, const char *blob)
{
    rd_store_dialect d = {.blob = blob};
    return rd_store_sql(sql, &d, 0);
}

/* Statements. */

typedef struct {
    const rd_store_driver *d;
    rd_store_stmt *st;
} stmt;

/* Binds by fmt, one letter a value: t text (const char *, NULL binds
 * NULL), b bytes (const void *, size_t), i int, I int64_t, n an int that
 * may be NULL (const int *), d a double that may be NULL (const double *). */
static void bind(stmt *q, const char *fmt, va_list ap)
{
    for (int i = 1; *fmt; fmt++, i++) {
        if (*fmt == 't') {
            q->d->bind_text(q->st, i, va_arg(ap, const char *));
        } else if (*fmt == 'b') {
            const void *data = va_arg(ap, const void *);
            q->d->bind_blob(q->st, i, data, va_arg(ap, size_t));
        } else if (*fmt == 'i') {
            q->d->bind_int(q->st, i, va_arg(ap, int));
        } else if (*fmt == 'n') {
            const int *v = va_arg(ap, const int *);
            if (v)
                q->d->bind_int(q->st, i, *v);
            else
                q->d->bind_null(q->st, i);
        } else if (*fmt == 'd') {
            const double *v = va_arg(ap, const double *);
            if (v)
                q->d->bind_double(q->st, i, *v);
            else
                q->d->bind_null(q->st, i);
        } else {
            q->d->bind_int(q->st, i, va_arg(ap, int64_t));
        }
    }
}

static rd_error_code vprep(rd_store *s, stmt *q, rd_error *err, const char *sql, const char *fmt, va_list ap)
{
    q->d = s->drv;
    q->st = NULL;
    char *text = rd_store_sql(sql, &s->drv->sql, 1);
    if (!text)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a statement");
    rd_error_code c = q->d->prepare(s, text, &q->st, err);
    free(text);
    if (!c)
        bind(q, fmt, ap);
    return c;
}

/* A statement ready to step, or an error. */
static rd_error_code prep(rd_store *s, stmt *q, rd_error *err, const char *sql, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = vprep(s, q, err, sql, fmt, ap);
    va_end(ap);
    return c;
}

/* 1 a row, 0 the end, or an error code (negated) with err set. */
static int step(stmt *q, rd_error *err) { return q->d->step(q->st, err); }

static void done(stmt *q) { q->d->finalize(q->st); }

/* Reads q's row into entry; on an error entry holds nothing to free. */
typedef rd_error_code (*row_reader)(const stmt *q, void *entry, rd_error *err);

/* Runs sql (with ap's values): its first row, if any, read into entry by
 * row (NULL: not read), *found (may be NULL) whether it had one, *changes
 * (may be NULL) the rows it changed. */
static rd_error_code vrun(rd_store *s, row_reader row, void *entry, int *found, int *changes, rd_error *err,
                          const char *sql, const char *fmt, va_list ap)
{
    stmt q;
    rd_error_code c = vprep(s, &q, err, sql, fmt, ap);
    if (c)
        return c;
    int r = step(&q, err);
    if (r == 1 && row)
        c = row(&q, entry, err);
    if (r >= 0 && changes)
        *changes = q.d->changes(q.st);
    if (found)
        *found = r == 1;
    done(&q);
    return r < 0 ? (rd_error_code)-r : c;
}

/* Runs a statement whose rows are not needed; *changes (may be NULL) the
 * rows it changed. */
static rd_error_code run(rd_store *s, int *changes, rd_error *err, const char *sql, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = vrun(s, NULL, NULL, NULL, changes, err, sql, fmt, ap);
    va_end(ap);
    return c;
}

/* The first row of sql (with fmt's values) read into entry by row (NULL:
 * not read); *found 0, and entry untouched, when it has none. */
static rd_error_code read_row(rd_store *s, row_reader row, void *entry, int *found, rd_error *err, const char *sql,
                              const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = vrun(s, row, entry, found, NULL, err, sql, fmt, ap);
    va_end(ap);
    return c;
}

static int64_t col_int(const stmt *q, int i) { return q->d->col_int(q->st, i); }

static int is_null(const stmt *q, int i) { return q->d->is_null(q->st, i); }

static const char *col_text_or_null(const stmt *q, int i) { return q->d->col_text(q->st, i); }

static const char *col_text(const stmt *q, int i)
{
    const char *t = col_text_or_null(q, i);
    return t ? t : "";
}

/* A malloc'ed copy of a text column; NULL for NULL, and *ok 0 when out of
 * memory. */
static char *col_dup(const stmt *q, int i, int *ok)
{
    const char *t = col_text_or_null(q, i);
    char *copy = t ? rd_store_dup(t, strlen(t)) : NULL;
    *ok = *ok && (!t || copy);
    return copy;
}

static unsigned char *col_blob_dup(const stmt *q, int i, size_t *len)
{
    const void *data = q->d->col_blob(q->st, i, len);
    return rd_store_dup(data, *len);
}

static rd_error_code begin(rd_store *s, rd_error *err) { return s->drv->begin(s, err); }

/* Commits when c is RD_OK, else rolls back; returns c or the commit's
 * error. */
static rd_error_code end(rd_store *s, rd_error_code c, rd_error *err)
{
    if (c) {
        s->drv->rollback(s);
        return c;
    }
    return s->drv->commit(s, err);
}

static rd_error_code notify(rd_store *s, rd_store_event_kind kind, const char *id, rd_error *err)
{
    return s->drv->notify ? s->drv->notify(s, kind, id, err) : RD_OK;
}

static int64_t clamp_max(size_t max) { return (int64_t)(max > INT64_MAX ? INT64_MAX : max); }

/* Every row of sql (with fmt's values) into *out, a malloc'ed array of
 * size-byte entries (NULL when none) that free_list frees; on an error the
 * entries read are freed and nothing is given. */
static rd_error_code read_rows(rd_store *s, size_t size, row_reader row, void (*free_list)(void *, size_t),
                               const char *what, void **out, size_t *n, rd_error *err, const char *sql, const char *fmt,
                               ...)
{
    stmt q;
    va_list ap;
    va_start(ap, fmt);
    rd_error_code c = vprep(s, &q, err, sql, fmt, ap);
    va_end(ap);
    if (c)
        return c;
    char *list = NULL;
    size_t k = 0, cap = 0;
    int r = 0;
    while (!c && (r = step(&q, err)) == 1) {
        if (!rd_grow_array((void **)&list, &cap, k + 1, size, 16))
            c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for %s", what);
        else if (!(c = row(&q, list + k * size, err)))
            k++;
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    done(&q);
    if (c) {
        free_list(list, k);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

static void free_plain(void *list, size_t n)
{
    (void)n;
    free(list);
}

static rd_error_code absent(rd_error *err, const char *what, const char *id)
{
    return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no %s %s", what, id);
}

static rd_error_code int_row(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    *(int64_t *)entry = col_int(q, 0);
    return RD_OK;
}

/* A text column's malloc'ed copy, "" for NULL, into a char *. */
static rd_error_code text_row(const stmt *q, void *entry, rd_error *err)
{
    const char *t = col_text(q, 0);
    if (!(*(char **)entry = rd_store_dup(t, strlen(t))))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a text");
    return RD_OK;
}

typedef struct {
    unsigned char *data;
    size_t len;
} bytes;

static rd_error_code bytes_row(const stmt *q, void *entry, rd_error *err)
{
    bytes *b = entry;
    if (!(b->data = col_blob_dup(q, 0, &b->len)))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for an image");
    return RD_OK;
}

/* *found: whether sql (a SELECT on one id) has a row. */
static rd_error_code exists(rd_store *s, const char *sql, const char *id, int *found, rd_error *err)
{
    return read_row(s, NULL, NULL, found, err, sql, "t", id);
}

/* Begins an expiry: its transaction, and the cut (ttl_ms before now) read
 * once, so that its statements all delete by the same time. */
static rd_error_code begin_expiry(rd_store *s, int64_t ttl_ms, int64_t *cut, rd_error *err)
{
    int found = 0;
    rd_error_code c = begin(s, err);
    return c ? c : read_row(s, int_row, cut, &found, err, "SELECT @NOW@ - ?", "I", ttl_ms);
}

/* Jobs. */

static rd_error_code code_parse(const char *name)
{
    for (int c = 0; c < RD_ERROR_COUNT; c++)
        if (strcmp(name, rd_error_name((rd_error_code)c)) == 0)
            return (rd_error_code)c;
    return RD_ERR_IO;
}

static rd_error_code status_row(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    *(rd_store_status *)entry = (rd_store_status)rd_store_status_parse(col_text(q, 0));
    return RD_OK;
}

/* The status of job id: RD_ERR_NOT_FOUND when there is none. */
static rd_error_code job_status(rd_store *s, const char *id, rd_store_status *out, rd_error *err)
{
    int found = 0;
    rd_error_code c = read_row(s, status_row, out, &found, err, "SELECT status FROM jobs WHERE id = ?", "t", id);
    return c || found ? c : absent(err, "job", id);
}

/* Why a change of a queued or running job changed nothing (changes 0
 * after c): gone, or ended (RD_ERR_CANCELLED). */
static rd_error_code runnable(rd_store *s, const char *id, int changes, rd_error_code c, rd_error *err)
{
    rd_store_status st;
    if (c || changes)
        return c;
    if ((c = job_status(s, id, &st, err)))
        return c;
    return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
}

/* What the probe writes: 64 KiB of zeros, a few pages. */
static const unsigned char probe_pad[65536];

/* A read, then a committed write of a few pages (deleted in the same
 * transaction): a store that cannot be written is not ready. */
rd_error_code rd_store_op_ping(rd_store *s, rd_error *err)
{
    rd_error_code c = run(s, NULL, err, "SELECT count(*) FROM schema_version", "");
    if (!c)
        c = begin(s, err);
    if (c)
        return c;
    c = run(s, NULL, err, "INSERT INTO write_probe (pad) VALUES (?)", "b", (const void *)probe_pad, sizeof probe_pad);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM write_probe", "");
    return end(s, c, err);
}

static rd_error_code insert_tiles(rd_store *s, const char *id, int tiles, rd_error *err)
{
    return run(s, NULL, err,
               "WITH RECURSIVE n(i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM n WHERE i + 1 < ?) "
               "INSERT INTO tiles (job_id, tile) SELECT ?, i FROM n",
               "it", tiles, id);
}

rd_error_code rd_store_op_job_create(rd_store *s, const rd_store_job_spec *j, rd_error *err)
{
    rd_store_status old;
    rd_error look;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = job_status(s, j->id, &old, &look);
    if (c == RD_OK)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s exists already", j->id);
    else if (c != RD_ERR_NOT_FOUND)
        *err = look;
    else
        c = run(s, NULL, err,
                "INSERT INTO jobs (id, status, scene, format, query, hdr, width, height, memory_bytes, "
                "submitted_ms, tiles_total, passes, gated, schedule) "
                "VALUES (?, 'queued', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                "tbttiiiIIiiit", j->id, (const void *)j->scene, j->scene_len, j->format, j->query ? j->query : "",
                j->hdr != 0, j->width, j->height, j->memory_bytes, j->submitted_ms, j->tiles, j->passes, j->gated != 0,
                j->schedule);
    if (!c && j->tiles)
        c = insert_tiles(s, j->id, j->tiles, err);
    if (!c)
        c = notify(s, RD_STORE_EV_SUBMITTED, j->id, err);
    return end(s, c, err);
}

static rd_error_code info_row(const stmt *q, void *entry, rd_error *err)
{
    rd_store_job_info *o = entry;
    int ok = 1;
    memset(o, 0, sizeof *o);
    snprintf(o->id, sizeof o->id, "%s", col_text(q, 0));
    o->status = (rd_store_status)rd_store_status_parse(col_text(q, 1));
    snprintf(o->format, sizeof o->format, "%s", col_text(q, 2));
    o->hdr = (int)col_int(q, 3);
    o->width = (int)col_int(q, 4);
    o->height = (int)col_int(q, 5);
    o->memory_bytes = col_int(q, 6);
    o->submitted_ms = col_int(q, 7);
    o->started_ms = col_int(q, 8);
    o->finished_ms = col_int(q, 9);
    if (!is_null(q, 10)) {
        o->error.code = code_parse(col_text(q, 10));
        o->error.line = (int)col_int(q, 11);
        o->error.column = (int)col_int(q, 12);
        snprintf(o->error.message, sizeof o->error.message, "%s", col_text(q, 13));
    }
    o->tiles_total = (int)col_int(q, 15);
    o->tiles_done = (int)col_int(q, 16);
    o->pass = (int)col_int(q, 17);
    o->passes = (int)col_int(q, 18);
    o->png_bytes = (size_t)col_int(q, 19);
    o->exr_bytes = (size_t)col_int(q, 20);
    o->gated = (int)col_int(q, 21);
    o->open_pass = (int)col_int(q, 22);
    o->stats = col_dup(q, 14, &ok);
    o->schedule = col_dup(q, 23, &ok);
    if (ok)
        return RD_OK;
    rd_store_job_info_free(o);
    return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's texts");
}

rd_error_code rd_store_op_job_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err)
{
    rd_store_job_info o;
    int found = 0;
    rd_error_code c = read_row(s, info_row, &o, &found, err,
                               "SELECT id, status, format, hdr, width, height, memory_bytes, submitted_ms, started_ms, "
                               "finished_ms, error_code, error_line, error_column, error_message, stats, tiles_total, "
                               "tiles_done, pass, passes, "
                               "(SELECT length(data) FROM results WHERE job_id = jobs.id AND kind = 'png'), "
                               "(SELECT length(data) FROM results WHERE job_id = jobs.id AND kind = 'exr'), "
                               "gated, open_pass, schedule FROM jobs WHERE id = ?",
                               "t", id);
    if (!c && found)
        *out = o;
    return c || found ? c : absent(err, "job", id);
}

static rd_error_code input_row(const stmt *q, void *entry, rd_error *err)
{
    rd_store_job_input in;
    memset(&in, 0, sizeof in);
    in.scene = (char *)col_blob_dup(q, 0, &in.scene_len);
    snprintf(in.format, sizeof in.format, "%s", col_text(q, 1));
    in.query = rd_store_dup(col_text(q, 2), strlen(col_text(q, 2)));
    in.hdr = (int)col_int(q, 3);
    in.width = (int)col_int(q, 4);
    in.height = (int)col_int(q, 5);
    in.memory_bytes = col_int(q, 6);
    in.submitted_ms = col_int(q, 7);
    if (!in.scene || !in.query) {
        rd_store_job_input_free(&in);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's scene");
    }
    *(rd_store_job_input *)entry = in;
    return RD_OK;
}

rd_error_code rd_store_op_job_input(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err)
{
    int found = 0;
    rd_error_code c = read_row(s, input_row, out, &found, err,
                               "SELECT scene, format, query, hdr, width, height, memory_bytes, submitted_ms "
                               "FROM jobs WHERE id = ?",
                               "t", id);
    return c || found ? c : absent(err, "job", id);
}

rd_error_code rd_store_op_job_start(rd_store *s, const char *id, rd_error *err)
{
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err,
            "UPDATE jobs SET status = 'running', started_ms = coalesce(started_ms, @NOW@) "
            "WHERE id = ? AND status IN ('queued', 'running')",
            "t", id);
    return end(s, runnable(s, id, n, c, err), err);
}

rd_error_code rd_store_op_job_stats(rd_store *s, const char *id, const char *stats, rd_error *err)
{
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err, "UPDATE jobs SET stats = ? WHERE id = ? AND status IN ('queued', 'running')", "tt", stats, id);
    return end(s, runnable(s, id, n, c, err), err);
}

static rd_error_code put_images(rd_store *s, const char *id, const rd_store_result *r, rd_error *err)
{
    const char *sql = "INSERT INTO results (job_id, kind, data) VALUES (?, ?, ?)";
    rd_error_code c = run(s, NULL, err, sql, "ttb", id, "png", (const void *)r->png, r->png_len);
    if (!c && r->exr)
        c = run(s, NULL, err, sql, "ttb", id, "exr", (const void *)r->exr, r->exr_len);
    return c;
}

static rd_error_code mark_ended(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                                const rd_store_result *r, int *n, rd_error *err)
{
    return run(s, n, err,
               "UPDATE jobs SET status = ?, finished_ms = @NOW@, stats = coalesce(?, stats), error_code = ?, "
               "error_line = ?, error_column = ?, error_message = ? WHERE id = ? AND status IN ('queued', 'running')",
               "tttnntt", rd_store_status_name(to), r ? r->stats : NULL, why ? rd_error_name(why->code) : NULL,
               why ? &why->line : NULL, why ? &why->column : NULL, why ? why->message : NULL, id);
}

rd_error_code rd_store_op_job_end(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                                  const rd_store_result *r, int *changed, rd_error *err)
{
    rd_store_status st;
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, NULL, err, "SELECT count(*) FROM (SELECT 1 FROM tiles WHERE job_id = ?@LOCK@) AS locked", "t", id);
    if (!c)
        c = mark_ended(s, id, to, why, r, &n, err);
    if (!c && n == 0)
        c = job_status(s, id, &st, err);
    else if (!c)
        c = run(s, NULL, err, "DELETE FROM tiles WHERE job_id = ?", "t", id);
    if (!c && n && to == RD_STORE_DONE)
        c = put_images(s, id, r, err);
    if (!c && n)
        c = notify(s, RD_STORE_EV_ENDED, id, err);
    *changed = n;
    return end(s, c, err);
}

rd_error_code rd_store_op_job_delete(rd_store *s, const char *id, rd_error *err)
{
    int n = 0;
    rd_error_code c = begin(s, err);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM tiles WHERE job_id = ?", "t", id);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM results WHERE job_id = ?", "t", id);
    if (!c)
        c = run(s, &n, err, "DELETE FROM jobs WHERE id = ?", "t", id);
    if (!c && n == 0)
        c = absent(err, "job", id);
    return end(s, c, err);
}

static rd_error_code no_image(rd_store *s, const char *id, rd_store_image_kind kind, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = job_status(s, id, &st, err);
    if (c)
        return c;
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s (%s) has no %s", id, rd_store_status_name(st),
                        kind == RD_STORE_PNG ? "PNG" : "EXR");
}

/* The first column of sql's one row (given id and kind) as malloc'ed
 * bytes; *found 0 when it has no row. */
static rd_error_code bytes_of(rd_store *s, const char *sql, const char *id, const char *kind, unsigned char **data,
                              size_t *len, int *found, rd_error *err)
{
    bytes b = {0};
    rd_error_code c = read_row(s, bytes_row, &b, found, err, sql, "tt", id, kind);
    if (!c && *found) {
        *data = b.data;
        *len = b.len;
    }
    return c;
}

rd_error_code rd_store_op_job_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data,
                                    size_t *len, rd_error *err)
{
    int found = 0;
    rd_error_code c = bytes_of(s, "SELECT data FROM results WHERE job_id = ? AND kind = ?", id,
                               kind == RD_STORE_PNG ? "png" : "exr", data, len, &found, err);
    return c || found ? c : no_image(s, id, kind, err);
}

static rd_error_code brief_row(const stmt *q, void *entry, rd_error *err)
{
    rd_store_job_brief *b = entry;
    (void)err;
    snprintf(b->id, sizeof b->id, "%s", col_text(q, 0));
    b->status = (rd_store_status)rd_store_status_parse(col_text(q, 1));
    b->submitted_ms = col_int(q, 2);
    return RD_OK;
}

rd_error_code rd_store_op_jobs_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n,
                                    rd_error *err)
{
    const char *names[RD_STORE_STATUS_COUNT];
    for (int i = 0; i < RD_STORE_STATUS_COUNT; i++)
        names[i] = mask & RD_STORE_MASK(i) ? rd_store_status_name((rd_store_status)i) : NULL;
    void *list = NULL;
    rd_error_code c = read_rows(s, sizeof **out, brief_row, free_plain, "a job list", &list, n, err,
                                "SELECT id, status, submitted_ms FROM jobs WHERE status IN (?, ?, ?, ?, ?) "
                                "ORDER BY submitted_ms, id LIMIT ?",
                                "tttttI", names[0], names[1], names[2], names[3], names[4], clamp_max(max));
    if (!c)
        *out = list;
    return c;
}

rd_error_code rd_store_op_jobs_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    int64_t cut = 0;
    int n = 0;
    rd_error_code c = begin_expiry(s, ttl_ms, &cut, err);
    if (!c)
        c = run(s, NULL, err,
                "DELETE FROM results WHERE job_id IN (SELECT id FROM jobs "
                "WHERE status IN ('done', 'failed', 'cancelled') AND finished_ms < ?)",
                "I", cut);
    if (!c)
        c = run(s, &n, err, "DELETE FROM jobs WHERE status IN ('done', 'failed', 'cancelled') AND finished_ms < ?", "I",
                cut);
    *deleted = (size_t)n;
    return end(s, c, err);
}

/* Tiles. */

rd_error_code rd_store_op_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err)
{
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err,
            "UPDATE jobs SET tiles_total = ?, passes = ?, tiles_done = 0, pass = 0, open_pass = 1 "
            "WHERE id = ? AND status IN ('queued', 'running') AND tiles_total = 0",
            "iit", tiles, passes, id);
    if (!c && n == 0) {
        rd_store_status st;
        c = job_status(s, id, &st, err);
        if (!c && (st == RD_STORE_QUEUED || st == RD_STORE_RUNNING))
            c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s has its tiles already", id);
        else if (!c)
            c = rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
    }
    if (!c)
        c = insert_tiles(s, id, tiles, err);
    if (!c)
        c = notify(s, RD_STORE_EV_TILES, id, err);
    return end(s, c, err);
}

/* The oldest runnable job after the one at (?2, ?3) when ?1 is set, among
 * those the filter (?4, ?5) allows, that has a tile of its current pass
 * nobody holds a live lease on. A gated job whose current pass is not open
 * has none, so it does not hold up the jobs behind it. On PostgreSQL the
 * job row may be older than a concurrent tile_done or pass_open; but a pass
 * once open stays open, so a stale row can make a claim miss a pass just
 * opened (the next claim takes it), never take one that is not. */
static const char claimable_sql[] =
    "SELECT j.id, j.pass, j.submitted_ms FROM jobs AS j WHERE j.status IN ('queued', 'running') AND j.pass < j.passes"
    " AND (j.gated = 0 OR j.pass < j.open_pass)"
    " AND (?1 = 0 OR j.submitted_ms > ?2 OR (j.submitted_ms = ?2 AND j.id > ?3))"
    " AND (?4 IS NULL OR j.id = ?4) AND (?5 <= 0 OR j.memory_bytes <= ?5)"
    " AND EXISTS (SELECT 1 FROM tiles AS t WHERE t.job_id = j.id AND t.passes_done = j.pass"
    " AND (t.owner IS NULL OR t.lease_until < @NOW@))"
    " ORDER BY j.submitted_ms, j.id LIMIT 1";

/* Up to ?5 of job ?3's claimable tiles of pass ?4, leased to ?1 for ?2 ms.
 * With SKIP LOCKED a tile another claim holds is passed over, and one it
 * has just claimed fails the re-check of its lease. */
static const char take_sql[] =
    "WITH picked AS MATERIALIZED (SELECT tile AS pick FROM tiles WHERE job_id = ?3 AND passes_done = ?4"
    " AND (owner IS NULL OR lease_until < @NOW@) ORDER BY tile LIMIT ?5@SKIP_LOCKED@)"
    " UPDATE tiles SET owner = ?1, lease_until = @NOW@ + ?2 FROM picked WHERE job_id = ?3 AND tile = pick"
    " RETURNING tile";

typedef struct {
    char id[RD_STORE_ID_MAX];
    int pass;
    int64_t submitted_ms;
} claimable;

static rd_error_code claimable_row(const stmt *q, void *entry, rd_error *err)
{
    claimable *j = entry;
    (void)err;
    snprintf(j->id, sizeof j->id, "%s", col_text(q, 0));
    j->pass = (int)col_int(q, 1);
    j->submitted_ms = col_int(q, 2);
    return RD_OK;
}

static int tile_cmp(const void *a, const void *b)
{
    const rd_store_tile *x = a, *y = b;
    return (x->index > y->index) - (x->index < y->index);
}

static rd_error_code take_tiles(rd_store *s, const char *daemon, const claimable *j, int max, int lease_ms,
                                rd_store_tile *out, int *n, rd_error *err)
{
    stmt q;
    rd_error_code c = prep(s, &q, err, take_sql, "titii", daemon, lease_ms, j->id, j->pass, max);
    int k = 0, r = 0;
    while (!c && (r = step(&q, err)) == 1 && k < max) {
        snprintf(out[k].job_id, sizeof out[k].job_id, "%s", j->id);
        out[k].pass = j->pass;
        out[k++].index = (int)col_int(&q, 0);
    }
    if (!c && r < 0)
        c = (rd_error_code)-r;
    done(&q);
    qsort(out, (size_t)k, sizeof *out, tile_cmp);
    *n = k;
    return c;
}

/* Job by job in queue order until one gives tiles: under SQLite's single
 * writer the first does, unless the job is gone; on PostgreSQL claims not
 * yet committed may hold all the claimable tiles of the oldest job, and a
 * claim then takes the next job's, as it would once they commit. */
rd_error_code rd_store_op_claim(rd_store *s, const char *daemon, int max, int lease_ms, const rd_store_claim_filter *f,
                                rd_store_tile *out, int *n, rd_error *err)
{
    claimable j = {"", 0, 0}, after;
    int k = 0, found = 1;
    rd_error_code c = begin(s, err);
    for (int more = 0; !c && !k && found; more = 1) {
        after = j;
        c = read_row(s, claimable_row, &j, &found, err, claimable_sql, "iIttI", more, after.submitted_ms, after.id,
                     f->job_id, f->max_memory_bytes);
        if (!c && found)
            c = take_tiles(s, daemon, &j, max, lease_ms, out, &k, err);
    }
    if (!c && k)
        c = run(s, NULL, err,
                "UPDATE jobs SET status = 'running', started_ms = @NOW@ WHERE id = ? AND status = 'queued'", "t", j.id);
    c = end(s, c, err);
    if (!c)
        *n = k;
    return c;
}

rd_error_code rd_store_op_leases(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err)
{
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    if (lease_ms < 0) {
        c = run(s, count, err, "UPDATE tiles SET owner = NULL, lease_until = NULL WHERE owner = ?", "t", daemon);
        if (!c && *count)
            c = notify(s, RD_STORE_EV_TILES, "", err);
    } else {
        c = run(s, count, err, "UPDATE tiles SET lease_until = @NOW@ + ? WHERE owner = ?", "it", lease_ms, daemon);
    }
    return end(s, c, err);
}

/* Why tile_done changed no tile, from the job's status: it ended
 * (RD_ERR_CANCELLED), or the tile is not, or no longer, daemon's for this
 * pass (RD_ERR_TIMEOUT). */
static rd_error_code tile_refused(rd_store *s, const char *daemon, const rd_store_tile *t, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = job_status(s, t->job_id, &st, err);
    if (c)
        return c;
    if (st != RD_STORE_QUEUED && st != RD_STORE_RUNNING)
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", t->job_id, rd_store_status_name(st));
    return rd_error_set(err, RD_ERR_TIMEOUT, 0, 0, "store: tile %d of pass %d of job %s is not leased to %s", t->index,
                        t->pass, t->job_id, daemon);
}

/* Moves the job to the next pass. A gated job's next pass is not claimable
 * yet: its TILES event is sent by pass_open, so that a waiting daemon is not
 * woken for nothing. */
static rd_error_code advance(rd_store *s, const rd_store_tile *t, int last, int total, int gated, rd_error *err)
{
    rd_error_code c = run(s, NULL, err, "UPDATE jobs SET pass = ?, tiles_done = ? WHERE id = ?", "iit", t->pass + 1,
                          last ? total : 0, t->job_id);
    return c || last || gated ? c : notify(s, RD_STORE_EV_TILES, t->job_id, err);
}

/* A tile count's row: tiles done, of total, passes, gated. */
static rd_error_code counts_row(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    for (int i = 0; i < 4; i++)
        ((int64_t *)entry)[i] = col_int(q, i);
    return RD_OK;
}

/* Counts a tile of the current pass done; advances the pass when it was
 * the last. The WHERE is the whole rule: on PostgreSQL the job's row lock
 * makes a second tile_done of the pass evaluate it again on the first's
 * committed row; on SQLite BEGIN IMMEDIATE runs them one after the other. */
static rd_error_code count_tile(rd_store *s, const rd_store_tile *t, rd_store_tile_outcome *outcome, rd_error *err)
{
    int64_t v[4];
    int found = 0;
    rd_error_code c = read_row(s, counts_row, v, &found, err,
                               "UPDATE jobs SET tiles_done = tiles_done + 1 WHERE id = ? AND pass = ? "
                               "AND status IN ('queued', 'running') RETURNING tiles_done, tiles_total, passes, gated",
                               "ti", t->job_id, t->pass);
    if (c || !found)
        return c ? c : runnable(s, t->job_id, 0, RD_OK, err);
    int counted = (int)v[0], total = (int)v[1], passes = (int)v[2], gated = (int)v[3];
    *outcome = RD_STORE_TILE_MORE;
    if (counted < total)
        return RD_OK;
    int last = t->pass + 1 >= passes;
    *outcome = last ? RD_STORE_TILE_JOB_DONE : RD_STORE_TILE_PASS_DONE;
    return advance(s, t, last, total, gated, err);
}

rd_error_code rd_store_op_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data,
                                    size_t len, rd_store_tile_outcome *outcome, rd_error *err)
{
    int n = 0;
    rd_store_tile_outcome o = RD_STORE_TILE_MORE;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err,
            "UPDATE tiles SET passes_done = passes_done + 1, owner = NULL, lease_until = NULL, data = ? "
            "WHERE job_id = ? AND tile = ? AND passes_done = ? AND owner = ?",
            "btiit", data, len, t->job_id, t->index, t->pass, daemon);
    if (!c)
        c = n ? count_tile(s, t, &o, err) : tile_refused(s, daemon, t, err);
    c = end(s, c, err);
    if (!c)
        *outcome = o;
    return c;
}

/* Why pass_open opened nothing, from the job's row as it is now (status,
 * gated, passes completed, passes, passes opened): ended
 * (RD_ERR_CANCELLED), else not gated or not the next pass (RD_ERR_INVALID). */
typedef struct {
    const char *id;
    int pass;
} pass_ask;

static rd_error_code pass_refusal(const stmt *q, void *entry, rd_error *err)
{
    const pass_ask *a = entry;
    const char *id = a->id;
    int pass = a->pass, gated = (int)col_int(q, 1), done = (int)col_int(q, 2), passes = (int)col_int(q, 3);
    rd_store_status st = (rd_store_status)rd_store_status_parse(col_text(q, 0));
    if (st != RD_STORE_QUEUED && st != RD_STORE_RUNNING)
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
    if (!gated)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s is not gated: its passes open by themselves", id);
    if (pass >= passes)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s has no pass %d: it has %d", id, pass, passes);
    if (col_int(q, 4) > pass)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: pass %d of job %s is open already", pass, id);
    return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                        "store: pass %d of job %s cannot open: %d of its passes are complete, not %d", pass, id, done,
                        pass);
}

static rd_error_code pass_refused(rd_store *s, const char *id, int pass, rd_error *err)
{
    pass_ask a = {id, pass};
    int found = 0;
    rd_error_code c = read_row(s, pass_refusal, &a, &found, err,
                               "SELECT status, gated, pass, passes, open_pass FROM jobs WHERE id = ?", "t", id);
    return c || found ? c : absent(err, "job", id);
}

/* The WHERE is the whole rule (gated, running, pass - 1 complete, pass not
 * yet open). Of two openers at once the second finds open_pass moved on:
 * SQLite runs them one after the other; on PostgreSQL the second waits for
 * the first's row lock and, at read committed, evaluates the WHERE again on
 * the row the first committed. Only the job's row is locked, and nothing
 * after it, so the tiles-then-job order holds. */
rd_error_code rd_store_op_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err)
{
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err,
            "UPDATE jobs SET open_pass = ?1 + 1, schedule = coalesce(?2, schedule) "
            "WHERE id = ?3 AND gated = 1 AND status IN ('queued', 'running') "
            "AND pass = ?1 AND open_pass = ?1 AND pass < passes",
            "itt", pass, schedule, id);
    if (!c && n == 0)
        c = pass_refused(s, id, pass, err);
    if (!c)
        c = notify(s, RD_STORE_EV_TILES, id, err);
    return end(s, c, err);
}

static void free_tiles(void *list, size_t n) { rd_store_tiles_free(list, n); }

static rd_error_code tile_row(const stmt *q, void *entry, rd_error *err)
{
    rd_store_tile_data *t = entry;
    t->index = (int)col_int(q, 0);
    t->passes = (int)col_int(q, 1);
    t->len = 0;
    t->data = NULL;
    if (is_null(q, 2))
        return RD_OK;
    t->data = col_blob_dup(q, 2, &t->len);
    return t->data ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a tile");
}

rd_error_code rd_store_op_tiles_get(rd_store *s, const char *id, int index, rd_store_tile_data **out, size_t *n,
                                    rd_error *err)
{
    void *list = NULL;
    size_t k = 0;
    rd_store_status st;
    rd_error_code c =
        index < 0
            ? read_rows(s, sizeof **out, tile_row, free_tiles, "tiles", &list, &k, err,
                        "SELECT tile, passes_done, data FROM tiles WHERE job_id = ? AND passes_done > 0 "
                        "ORDER BY tile",
                        "t", id)
            : read_rows(s, sizeof **out, tile_row, free_tiles, "tiles", &list, &k, err,
                        "SELECT tile, passes_done, data FROM tiles WHERE job_id = ? AND tile = ?", "ti", id, index);
    if (!c && k == 0)
        c = job_status(s, id, &st, err);
    if (!c) {
        *out = list;
        *n = k;
    }
    return c;
}

/* Grades and batches. A put takes the batch's row lock (its count) before
 * it inserts the grade, and expiry takes the old batches' row locks first
 * too, so neither waits for the other in a circle. */

/* The columns a grade is read from, in this order. */
#define GRADE_COLUMNS                                                                                                  \
    "id, batch_id, assignment, student, pass, failed_fraction, max_abs, psnr_db, ssim, verdict, reference_key, "       \
    "graded_ms, error, kind, submitted_ms, late_ms, closed, score, points, regrade_of"

static const char *grade_image_name(rd_store_grade_image_kind kind)
{
    return kind == RD_STORE_GRADE_DIFF ? "diff" : "image";
}

/* Why a batch refused to count a grade of assignment, from its row as it is
 * now (status, assignment, done, total): ended (RD_ERR_CANCELLED) or of
 * another assignment (RD_ERR_INVALID). */
typedef struct {
    const char *batch_id, *assignment;
} batch_ask;

static rd_error_code batch_refusal(const stmt *q, void *entry, rd_error *err)
{
    const batch_ask *a = entry;
    rd_store_batch_status st = (rd_store_batch_status)rd_store_batch_status_parse(col_text(q, 0));
    int done = (int)col_int(q, 2), total = (int)col_int(q, 3);
    if (st != RD_STORE_BATCH_RUNNING)
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: batch %s is %s (%d of %d grades)", a->batch_id,
                            rd_store_batch_status_name(st), done, total);
    if (strcmp(a->assignment, col_text(q, 1)) != 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: batch %s grades %s, not %s", a->batch_id, col_text(q, 1),
                            a->assignment);
    return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: batch %s has all its %d grades", a->batch_id, total);
}

static rd_error_code batch_refused(rd_store *s, const char *id, const char *assignment, rd_error *err)
{
    batch_ask a = {id, assignment};
    int found = 0;
    rd_error_code c = read_row(s, batch_refusal, &a, &found, err,
                               "SELECT status, assignment, done, total FROM batches WHERE id = ?", "t", id);
    return c || found ? c : absent(err, "batch", id);
}

/* Counts a grade of its batch, which becomes done with its last. The WHERE
 * is the whole rule: SQLite runs two puts one after the other; on
 * PostgreSQL the second waits for the first's row lock and, at read
 * committed, evaluates the WHERE again on the row the first committed. */
static rd_error_code count_grade(rd_store *s, const rd_store_grade *g, rd_error *err)
{
    int n = 0;
    rd_error_code c = run(s, &n, err,
                          "UPDATE batches SET done = done + 1, "
                          "status = CASE WHEN done + 1 >= total THEN 'done' ELSE status END "
                          "WHERE id = ? AND status = 'running' AND assignment = ? AND done < total",
                          "tt", g->batch_id, g->assignment);
    if (!c && n == 0)
        c = batch_refused(s, g->batch_id, g->assignment, err);
    return c;
}

static rd_error_code insert_grade(rd_store *s, const rd_store_grade *g, rd_error *err)
{
    int graded = !g->error, scored = isfinite(g->points) && g->points > 0;
    return run(s, NULL, err,
               "INSERT INTO grades (" GRADE_COLUMNS
               ") VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
               "ttttiddddttIttIIiddt", g->id, g->batch_id, g->assignment, g->student, g->pass,
               graded ? &g->failed_fraction : NULL, graded ? &g->max_abs : NULL, graded ? &g->psnr_db : NULL,
               graded ? &g->ssim : NULL, g->verdict, g->reference_key, g->graded_ms, g->error, g->kind, g->submitted_ms,
               g->late_ms, g->closed, scored ? &g->score : NULL, scored ? &g->points : NULL, g->regrade_of);
}

rd_error_code rd_store_op_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                                    rd_error *err)
{
    int found = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = exists(s, "SELECT 1 FROM grades WHERE id = ?", g->id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s exists already", g->id);
    if (!c && g->batch_id)
        c = count_grade(s, g, err);
    if (!c)
        c = insert_grade(s, g, err);
    if (!c && diff)
        c = run(s, NULL, err, "INSERT INTO grade_images (grade_id, kind, data) VALUES (?, 'diff', ?)", "tb", g->id,
                (const void *)diff, len);
    return end(s, c, err);
}

static double col_metric(const stmt *q, int i) { return is_null(q, i) ? NAN : q->d->col_double(q->st, i); }

/* A row of GRADE_COLUMNS. */
static rd_error_code grade_row(const stmt *q, rd_store_grade *g, rd_error *err)
{
    memset(g, 0, sizeof *g);
    g->pass = (int)col_int(q, 4);
    g->failed_fraction = col_metric(q, 5);
    g->max_abs = col_metric(q, 6);
    g->psnr_db = col_metric(q, 7);
    g->ssim = col_metric(q, 8);
    g->graded_ms = col_int(q, 11);
    /* A record from before version 6 has no submission time: its grading's. */
    g->submitted_ms = is_null(q, 14) ? g->graded_ms : col_int(q, 14);
    g->late_ms = col_int(q, 15);
    g->closed = (int)col_int(q, 16);
    g->score = col_metric(q, 17);
    g->points = col_metric(q, 18);
    int ok = 1;
    g->id = col_dup(q, 0, &ok);
    g->batch_id = col_dup(q, 1, &ok);
    g->assignment = col_dup(q, 2, &ok);
    g->student = col_dup(q, 3, &ok);
    g->verdict = col_dup(q, 9, &ok);
    g->reference_key = col_dup(q, 10, &ok);
    g->error = col_dup(q, 12, &ok);
    g->kind = col_dup(q, 13, &ok);
    g->regrade_of = col_dup(q, 19, &ok);
    if (ok)
        return RD_OK;
    rd_store_grade_free(g);
    return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a grade");
}

static rd_error_code grade_entry(const stmt *q, void *entry, rd_error *err) { return grade_row(q, entry, err); }

static void free_grades(void *list, size_t n) { rd_store_grades_free(list, n); }

rd_error_code rd_store_op_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err)
{
    rd_store_grade g;
    int found = 0;
    rd_error_code c =
        read_row(s, grade_entry, &g, &found, err, "SELECT " GRADE_COLUMNS " FROM grades WHERE id = ?", "t", id);
    if (!c && found)
        *out = g;
    return c || found ? c : absent(err, "grade", id);
}

rd_error_code rd_store_op_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                      size_t *len, rd_error *err)
{
    const char *name = grade_image_name(kind);
    int found = 0;
    rd_error_code c =
        bytes_of(s, "SELECT data FROM grade_images WHERE grade_id = ? AND kind = ?", id, name, data, len, &found, err);
    if (c || found)
        return c;
    if ((c = exists(s, "SELECT 1 FROM grades WHERE id = ?", id, &found, err)))
        return c;
    if (!found)
        return absent(err, "grade", id);
    return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s has no %s image", id, name);
}

rd_error_code rd_store_op_grade_image_put(rd_store *s, const char *id, rd_store_grade_image_kind kind,
                                          const unsigned char *data, size_t len, rd_error *err)
{
    int found = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = exists(s, "SELECT 1 FROM grades WHERE id = ?", id, &found, err);
    if (!c && !found)
        c = absent(err, "grade", id);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM grade_images WHERE grade_id = ? AND kind = ?", "tt", id,
                grade_image_name(kind));
    if (!c)
        c = run(s, NULL, err, "INSERT INTO grade_images (grade_id, kind, data) VALUES (?, ?, ?)", "ttb", id,
                grade_image_name(kind), (const void *)data, len);
    return end(s, c, err);
}

/* The filter's conditions are written in only when given, so that each
 * listing can use its index; the values are bound (?1 to ?5) all the same. */
rd_error_code rd_store_op_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                      rd_error *err)
{
    char sql[400];
    snprintf(sql, sizeof sql,
             "SELECT " GRADE_COLUMNS " FROM grades WHERE graded_ms >= ?1%s%s%s ORDER BY graded_ms, id LIMIT ?5",
             f->assignment ? " AND assignment = ?2" : "", f->student ? " AND student = ?3" : "",
             f->batch_id ? " AND batch_id = ?4" : "");
    void *list = NULL;
    rd_error_code c = read_rows(s, sizeof **out, grade_entry, free_grades, "a grade list", &list, n, err, sql, "ItttI",
                                f->since_ms, f->assignment, f->student, f->batch_id, clamp_max(f->max));
    if (!c)
        *out = list;
    return c;
}

/* The old batches are locked first (PostgreSQL; SQLite's BEGIN IMMEDIATE
 * holds off every put meanwhile): a put of a grade to one of them has
 * committed before, or waits until after, and so the batches found with no
 * grade left cannot be given one before they go, and the cascade deletes no
 * grade. */
rd_error_code rd_store_op_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    int64_t cut = 0;
    int n = 0;
    rd_error_code c = begin_expiry(s, ttl_ms, &cut, err);
    if (!c)
        c = run(s, NULL, err,
                "SELECT count(*) FROM (SELECT 1 FROM batches WHERE created_ms < ? ORDER BY id@LOCK@) AS locked", "I",
                cut);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM grade_images WHERE grade_id IN (SELECT id FROM grades WHERE graded_ms < ?)",
                "I", cut);
    if (!c)
        c = run(s, &n, err, "DELETE FROM grades WHERE graded_ms < ?", "I", cut);
    if (!c)
        c = run(s, NULL, err,
                "DELETE FROM batches WHERE created_ms < ? "
                "AND NOT EXISTS (SELECT 1 FROM grades WHERE batch_id = batches.id)",
                "I", cut);
    *deleted = (size_t)n;
    return end(s, c, err);
}

rd_error_code rd_store_op_batch_create(rd_store *s, const char *id, const char *assignment, int total,
                                       const char *daemon, const char *students, rd_error *err)
{
    int found = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = exists(s, "SELECT 1 FROM batches WHERE id = ?", id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: batch %s exists already", id);
    if (!c)
        c = run(s, NULL, err,
                "INSERT INTO batches (id, assignment, total, done, status, created_ms, daemon, students) "
                "VALUES (?, ?, ?, 0, 'running', @NOW@, ?, ?)",
                "ttitt", id, assignment, total, daemon, students);
    return end(s, c, err);
}

#define BATCH_COLUMNS "id, assignment, total, done, status, created_ms"

/* The batch of a row of BATCH_COLUMNS. */
static rd_store_batch batch_of(const stmt *q)
{
    rd_store_batch b;
    memset(&b, 0, sizeof b);
    snprintf(b.id, sizeof b.id, "%s", col_text(q, 0));
    snprintf(b.assignment, sizeof b.assignment, "%s", col_text(q, 1));
    b.total = (int)col_int(q, 2);
    b.done = (int)col_int(q, 3);
    b.status = (rd_store_batch_status)rd_store_batch_status_parse(col_text(q, 4));
    b.created_ms = col_int(q, 5);
    return b;
}

static rd_error_code batch_entry(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    *(rd_store_batch *)entry = batch_of(q);
    return RD_OK;
}

rd_error_code rd_store_op_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err)
{
    int found = 0;
    rd_error_code c =
        read_row(s, batch_entry, out, &found, err, "SELECT " BATCH_COLUMNS " FROM batches WHERE id = ?", "t", id);
    return c || found ? c : absent(err, "batch", id);
}

rd_error_code rd_store_op_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                          rd_error *err)
{
    void *list = NULL;
    rd_error_code c = read_rows(s, sizeof **out, batch_entry, free_plain, "a batch list", &list, n, err,
                                "SELECT " BATCH_COLUMNS " FROM batches WHERE daemon = ? AND status = 'running' "
                                "ORDER BY created_ms, id LIMIT ?",
                                "tI", daemon, clamp_max(max));
    if (!c)
        *out = list;
    return c;
}

rd_error_code rd_store_op_batch_students(rd_store *s, const char *id, char **students, rd_error *err)
{
    int found = 0;
    rd_error_code c =
        read_row(s, text_row, students, &found, err, "SELECT students FROM batches WHERE id = ?", "t", id);
    return c || found ? c : absent(err, "batch", id);
}

rd_error_code rd_store_op_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err)
{
    rd_store_batch b;
    int n = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = run(s, &n, err, "UPDATE batches SET status = 'cancelled' WHERE id = ? AND status = 'running'", "t", id);
    if (!c && n == 0)
        c = rd_store_op_batch_get(s, id, &b, err);
    *changed = n;
    return end(s, c, err);
}

/* Newest first, the way an instructor looks for last week's batch; the
 * assignment is written in only when given, as in rd_store_op_grades_list. */
rd_error_code rd_store_op_batches_list(rd_store *s, const rd_store_batch_filter *f, rd_store_batch **out, size_t *n,
                                       rd_error *err)
{
    char sql[300];
    snprintf(sql, sizeof sql,
             "SELECT " BATCH_COLUMNS " FROM batches WHERE created_ms <= ?1%s "
             "ORDER BY created_ms DESC, id DESC LIMIT ?3",
             f->assignment ? " AND assignment = ?2" : "");
    void *list = NULL;
    int64_t until = f->until_ms > 0 ? f->until_ms : INT64_MAX;
    rd_error_code c = read_rows(s, sizeof **out, batch_entry, free_plain, "a batch list", &list, n, err, sql, "ItI",
                                until, f->assignment, clamp_max(f->max));
    if (!c)
        *out = list;
    return c;
}

static rd_error_code grade_id_row(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    snprintf(((rd_store_grade_id *)entry)->id, RD_STORE_ID_MAX, "%s", col_text(q, 0));
    return RD_OK;
}

/* In the caller's transaction: the grades whose column (a name of this
 * file, never the caller's text) is value, their images first, and their
 * ids. The images go explicitly, as in expiry, rather than trusting the
 * cascade to be on in every connection. */
static rd_error_code delete_grades(rd_store *s, const char *column, const char *value, rd_store_grade_id **ids,
                                   size_t *n, rd_error *err)
{
    char sql[160];
    snprintf(sql, sizeof sql, "DELETE FROM grade_images WHERE grade_id IN (SELECT id FROM grades WHERE %s = ?)",
             column);
    rd_error_code c = run(s, NULL, err, sql, "t", value);
    if (c)
        return c;
    snprintf(sql, sizeof sql, "DELETE FROM grades WHERE %s = ? RETURNING id", column);
    void *list = NULL;
    c = read_rows(s, sizeof **ids, grade_id_row, free_plain, "the deleted grades", &list, n, err, sql, "t", value);
    if (!c)
        *ids = list;
    return c;
}

/* Commits what delete_grades did; the ids are given only once it is
 * committed. */
static rd_error_code end_delete(rd_store *s, rd_error_code c, rd_store_grade_id *list, size_t k,
                                rd_store_grade_id **ids, size_t *n, rd_error *err)
{
    c = end(s, c, err);
    if (c) {
        free(list);
        return c;
    }
    *ids = list;
    *n = k;
    return RD_OK;
}

rd_error_code rd_store_op_grades_delete(rd_store *s, const char *column, const char *value, rd_store_grade_id **ids,
                                        size_t *n, rd_error *err)
{
    rd_store_grade_id *list = NULL;
    size_t k = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = delete_grades(s, column, value, &list, &k, err);
    return end_delete(s, c, list, k, ids, n, err);
}

static rd_error_code batch_status_row(const stmt *q, void *entry, rd_error *err)
{
    (void)err;
    *(int *)entry = rd_store_batch_status_parse(col_text(q, 0));
    return RD_OK;
}

/* The batch's row is locked before its grades, as a put locks it: a put
 * to it has committed before, or finds it gone. Only an ended batch goes,
 * so that no grade of a running one is put after its rows were deleted. */
rd_error_code rd_store_op_batch_delete(rd_store *s, const char *id, rd_store_grade_id **ids, size_t *n, rd_error *err)
{
    rd_store_grade_id *list = NULL;
    size_t k = 0;
    int st = -1, found = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    c = read_row(s, batch_status_row, &st, &found, err, "SELECT status FROM batches WHERE id = ?@LOCK@", "t", id);
    if (!c && !found)
        c = absent(err, "batch", id);
    else if (!c && st == RD_STORE_BATCH_RUNNING)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: batch %s is running: cancel it first", id);
    if (!c)
        c = delete_grades(s, "batch_id", id, &list, &k, err);
    if (!c)
        c = run(s, NULL, err, "DELETE FROM batches WHERE id = ?", "t", id);
    return end_delete(s, c, list, k, ids, n, err);
}

/* Migrations. */

static rd_error_code schema_version(rd_store *s, int64_t *v, rd_error *err)
{
    int found = 0;
    return read_row(s, int_row, v, &found, err, "SELECT coalesce(max(version), 0) FROM schema_version", "");
}

static rd_error_code apply(rd_store *s, const rd_store_migration *m, rd_error *err)
{
    char *sql = rd_store_sql(m->sql, &s->drv->sql, 0);
    if (!sql)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for migration %s", m->name);
    char what[96];
    snprintf(what, sizeof what, "migration %s", m->name);
    rd_error_code c = s->drv->script(s, sql, what, err);
    free(sql);
    if (c)
        return c;
    return run(s, NULL, err, "INSERT INTO schema_version (version, name, applied_ms) VALUES (?, ?, @NOW@)", "it",
               m->version, m->name);
}

rd_error_code rd_store_migrate(rd_store *s, rd_error *err)
{
    const char *lock = s->drv->sql.migration_lock;
    int64_t v = 0;
    rd_error_code c = begin(s, err);
    if (c)
        return c;
    if (lock)
        c = run(s, NULL, err, lock, "");
    if (!c)
        c = run(s, NULL, err,
                "CREATE TABLE IF NOT EXISTS schema_version (version INTEGER PRIMARY KEY, name TEXT NOT NULL, "
                "applied_ms BIGINT NOT NULL)",
                "");
    if (!c)
        c = schema_version(s, &v, err);
    if (!c && v > rd_store_migration_count)
        c = rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0,
                         "store: its schema is version %lld, newer than this rayd's %d: run a newer rayd", (long long)v,
                         rd_store_migration_count);
    for (int i = (int)v; !c && i < rd_store_migration_count; i++)
        c = apply(s, &rd_store_migrations[i], err);
    return end(s, c, err);
}
