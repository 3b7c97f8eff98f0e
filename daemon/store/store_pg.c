/* The store in PostgreSQL, for several daemons sharing one queue. Claims
 * take tiles with SELECT ... FOR UPDATE SKIP LOCKED, so concurrent claims
 * pass each other instead of waiting; creations, completed (or opened)
 * passes and ends send NOTIFY rayd_jobs inside their transaction,
 * delivered at commit.
 *
 * Never hang, never crash when the server is away: the connection is
 * non-blocking and every statement has a deadline here (beyond the server's
 * statement_timeout); connecting is bounded by connect_timeout; a
 * connection found broken, or past a deadline, is closed, and the next call
 * connects anew. Locks are always taken tiles first, then the job, so two
 * transactions never wait for each other in a circle. */
#include <errno.h>
#include <libpq-fe.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "migrations.h"
#include "rayd/clock.h"
#include "store_internal.h"

/* The server's clock in milliseconds, read once per statement. */
#define NOW "(extract(epoch FROM statement_timestamp()) * 1000)::bigint"

#define CHANNEL "rayd_jobs"

/* PostgreSQL takes at most 1 GB in one field. */
#define PG_FIELD_MAX ((size_t)1 << 30)

/* Notifications kept for rd_store_wait: libpq's own queue grows without
 * bound on a handle that never waits, so they are moved here, the oldest
 * dropped when it is full. */
#define EVENTS_KEPT 64

typedef struct {
    rd_store base;
    PGconn *conn; /* NULL when not connected */
    char *conninfo;
    int backend; /* the server process of conn: its own NOTIFYs are not events */
    rd_store_event events[EVENTS_KEPT];
    int first, count;
} pg_store;

static pg_store *pg(rd_store *s) { return (pg_store *)s; }

/* libpq's message as one line. */
static const char *one_line(char *buf, size_t size, const char *msg)
{
    snprintf(buf, size, "%s", msg && *msg ? msg : "unknown error");
    for (char *p = buf; *p; p++)
        if (*p == '\n')
            *p = p[1] ? ' ' : '\0';
    return buf;
}

static void pg_drop(pg_store *p)
{
    PQfinish(p->conn);
    p->conn = NULL;
}

static rd_error_code pg_broken(pg_store *p, const char *what, rd_error *err)
{
    char line[400];
    rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "store: PostgreSQL %s: %s", what,
                 one_line(line, sizeof line, p->conn ? PQerrorMessage(p->conn) : NULL));
    pg_drop(p);
    return RD_ERR_UNAVAILABLE;
}

/* Sends what is buffered and reads until the result is complete, by the
 * deadline (rd_now_ms). */
static rd_error_code pg_pump(pg_store *p, double deadline, rd_error *err)
{
    for (;;) {
        int f = PQflush(p->conn);
        if (f < 0)
            return pg_broken(p, "sending", err);
        if (f == 0 && !PQisBusy(p->conn))
            return RD_OK;
        double left = deadline - rd_now_ms();
        if (left <= 0) {
            pg_drop(p);
            return rd_error_set(err, RD_ERR_UNAVAILABLE, 0, 0, "store: PostgreSQL did not answer within %d ms",
                                p->base.opt.timeout_ms);
        }
        struct pollfd pfd = {PQsocket(p->conn), (short)(POLLIN | (f ? POLLOUT : 0)), 0};
        int r = poll(&pfd, 1, (int)left + 1);
        if (r < 0 && errno != EINTR)
            return pg_broken(p, "waiting", err);
        if (r > 0 && (pfd.revents & (POLLIN | POLLERR | POLLHUP)) && !PQconsumeInput(p->conn))
            return pg_broken(p, "reading", err);
    }
}

static int result_ok(const PGresult *r)
{
    ExecStatusType st = PQresultStatus(r);
    return st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK;
}

/* A failed statement's code: connection and server trouble is RD_ERR_UNAVAILABLE
 * (503), a bad value RD_ERR_INVALID, a lost conflict RD_ERR_BUSY, a full
 * disk RD_ERR_NOSPACE, a corrupt page or index RD_ERR_DAMAGED. */
static rd_error_code pg_code(const char *state)
{
    if (!state)
        return RD_ERR_UNAVAILABLE;
    if (strncmp(state, "22", 2) == 0 || strncmp(state, "23", 2) == 0)
        return RD_ERR_INVALID;
    if (strcmp(state, "40001") == 0 || strcmp(state, "40P01") == 0 || strcmp(state, "55P03") == 0)
        return RD_ERR_BUSY;
    if (strcmp(state, "54000") == 0)
        return RD_ERR_LIMIT;
    if (strcmp(state, "53100") == 0)
        return RD_ERR_NOSPACE;
    if (strcmp(state, "XX001") == 0 || strcmp(state, "XX002") == 0)
        return RD_ERR_DAMAGED;
    return RD_ERR_UNAVAILABLE;
}

static rd_error_code pg_failed(pg_store *p, PGresult *r, rd_error *err)
{
    char line[400];
    const char *msg = PQresultErrorField(r, PG_DIAG_MESSAGE_PRIMARY);
    rd_error_code c = pg_code(PQresultErrorField(r, PG_DIAG_SQLSTATE));
    rd_store_saw(&p->base, c);
    rd_error_set(err, c, 0, 0, "store: PostgreSQL: %s%s",
                 c == RD_ERR_DAMAGED   ? "the database is damaged: "
                 : c == RD_ERR_NOSPACE ? "no space left: "
                                       : "",
                 one_line(line, sizeof line, msg ? msg : PQresultErrorMessage(r)));
    PQclear(r);
    if (PQstatus(p->conn) != CONNECTION_OK)
        pg_drop(p);
    return c;
}

/* Bound values: text as text, integers and doubles as decimal text, bytes
 * as binary. */
typedef struct {
    int n;
    const char *vals[16];
    int lens[16], fmts[16];
    char nums[16][32];
} pg_params;

static void pp_text(pg_params *pp, const char *t)
{
    pp->vals[pp->n] = t;
    pp->lens[pp->n] = 0;
    pp->fmts[pp->n++] = 0;
}

static void pp_int(pg_params *pp, int64_t v)
{
    snprintf(pp->nums[pp->n], sizeof pp->nums[0], "%lld", (long long)v);
    pp_text(pp, pp->nums[pp->n]);
}

/* 17 significant digits: the server reads back the very double (NULL
 * binds NULL). */
static void pp_double(pg_params *pp, const double *v)
{
    if (!v) {
        pp_text(pp, NULL);
        return;
    }
    snprintf(pp->nums[pp->n], sizeof pp->nums[0], "%.17g", *v);
    pp_text(pp, pp->nums[pp->n]);
}

static void pp_bytes(pg_params *pp, const void *d, size_t len)
{
    pp->vals[pp->n] = d ? d : "";
    pp->lens[pp->n] = (int)len; /* the limits are below PG_FIELD_MAX */
    pp->fmts[pp->n++] = 1;
}

/* Runs one statement (pp NULL: a script of several, with no values) and
 * returns its result (the first error of a script), or NULL with err set.
 * binary: results in binary (for bytes). */
static PGresult *pg_run(pg_store *p, const char *sql, const pg_params *pp, int binary, rd_error *err)
{
    int sent = pp ? PQsendQueryParams(p->conn, sql, pp->n, NULL, pp->vals, pp->lens, pp->fmts, binary)
                  : PQsendQuery(p->conn, sql);
    if (!sent) {
        pg_broken(p, "sending", err);
        return NULL;
    }
    double deadline = rd_now_ms() + p->base.opt.timeout_ms + 1000;
    PGresult *keep = NULL;
    for (;;) {
        if (pg_pump(p, deadline, err)) {
            PQclear(keep);
            return NULL;
        }
        PGresult *r = PQgetResult(p->conn);
        if (!r)
            break;
        if (!keep || result_ok(keep)) {
            PQclear(keep);
            keep = r;
        } else {
            PQclear(r);
        }
    }
    if (!keep) {
        pg_broken(p, "answering", err);
        return NULL;
    }
    if (!result_ok(keep)) {
        pg_failed(p, keep, err);
        return NULL;
    }
    return keep;
}

/* A statement whose rows are not needed: *rows (may be NULL) it changed. */
static rd_error_code pg_cmd(pg_store *p, const char *sql, const pg_params *pp, int *rows, rd_error *err)
{
    PGresult *r = pg_run(p, sql, pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (rows)
        *rows = atoi(PQcmdTuples(r));
    PQclear(r);
    return RD_OK;
}

/* extra_float_digits = 3: doubles come back as the exact value (the
 * shortest text that reads back as it from PostgreSQL 12 on, 17 digits
 * before), whatever the server's default or the spec's options say. */
static rd_error_code pg_session(pg_store *p, rd_error *err)
{
    PQsetnonblocking(p->conn, 1);
    p->backend = PQbackendPID(p->conn);
    return pg_cmd(p, "SET extra_float_digits = 3; LISTEN " CHANNEL, NULL, NULL, err);
}

static void quiet(void *arg, const char *message)
{
    (void)arg;
    (void)message; /* "relation already exists, skipping" and such */
}

/* A new connection. The caller's spec comes last so that it may override
 * the timeouts. */
static rd_error_code pg_connect(pg_store *p, rd_error *err)
{
    int t = p->base.opt.timeout_ms;
    char connect_s[16], options[160];
    snprintf(connect_s, sizeof connect_s, "%d", t < 2000 ? 2 : (t + 999) / 1000);
    snprintf(options, sizeof options,
             "-c statement_timeout=%d -c lock_timeout=%d -c idle_in_transaction_session_timeout=%d", t, t, 4 * t);
    const char *keys[] = {"connect_timeout", "options", "application_name", "client_encoding", "dbname", NULL};
    const char *vals[] = {connect_s, options, "rayd", "UTF8", p->conninfo, NULL};
    if (p->conn)
        pg_drop(p);
    p->conn = PQconnectdbParams(keys, vals, 1);
    if (!p->conn)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a PostgreSQL connection");
    if (PQstatus(p->conn) != CONNECTION_OK)
        return pg_broken(p, "cannot connect", err);
    PQsetNoticeProcessor(p->conn, quiet, NULL);
    return pg_session(p, err);
}

/* Moves libpq's notifications from other server processes to events. */
static void pg_collect(pg_store *p)
{
    PGnotify *nt;
    while ((nt = PQnotifies(p->conn))) {
        if (nt->be_pid != p->backend) {
            if (p->count == EVENTS_KEPT) {
                p->first = (p->first + 1) % EVENTS_KEPT;
                p->count--;
            }
            rd_store_event_parse(nt->extra, &p->events[(p->first + p->count++) % EVENTS_KEPT]);
        }
        PQfreemem(nt);
    }
}

/* Connected and idle: reads what the server sent meanwhile (a shutdown's
 * goodbye, notifications), reconnecting when the connection is gone. */
static rd_error_code pg_ready(pg_store *p, rd_error *err)
{
    if (p->conn && PQstatus(p->conn) == CONNECTION_OK && PQconsumeInput(p->conn) &&
        PQstatus(p->conn) == CONNECTION_OK && PQtransactionStatus(p->conn) == PQTRANS_IDLE) {
        pg_collect(p);
        return RD_OK;
    }
    return pg_connect(p, err);
}

static rd_error_code pg_begin(pg_store *p, rd_error *err)
{
    rd_error_code c = pg_ready(p, err);
    return c ? c : pg_cmd(p, "BEGIN", NULL, NULL, err);
}

/* Commits when c is RD_OK, else rolls back; returns c or the commit's
 * error. */
static rd_error_code pg_end(pg_store *p, rd_error_code c, rd_error *err)
{
    if (!p->conn)
        return c;
    if (c == RD_OK) {
        c = pg_cmd(p, "COMMIT", NULL, NULL, err);
        if (!c)
            rd_store_committed(&p->base);
        return c;
    }
    rd_error ignored;
    if (PQtransactionStatus(p->conn) != PQTRANS_IDLE)
        pg_cmd(p, "ROLLBACK", NULL, NULL, &ignored);
    return c;
}

static rd_error_code pg_notify(pg_store *p, rd_store_event_kind kind, const char *id, rd_error *err)
{
    char payload[RD_STORE_ID_MAX + 4];
    pg_params pp = {0};
    rd_store_event_payload(payload, sizeof payload, kind, id);
    pp_text(&pp, payload);
    return pg_cmd(p, "SELECT pg_notify('" CHANNEL "', $1::text)", &pp, NULL, err);
}

/* A value of a result in either format. */
static int64_t pg_int(const PGresult *r, int row, int col)
{
    if (PQgetisnull(r, row, col))
        return 0;
    const unsigned char *v = (const unsigned char *)PQgetvalue(r, row, col);
    if (PQfformat(r, col) == 0)
        return strtoll((const char *)v, NULL, 10);
    uint64_t x = 0;
    int n = PQgetlength(r, row, col);
    for (int i = 0; i < n; i++)
        x = x << 8 | v[i];
    return n == 4 ? (int64_t)(int32_t)x : n == 2 ? (int64_t)(int16_t)x : (int64_t)x;
}

static const char *pg_text(const PGresult *r, int row, int col)
{
    return PQgetisnull(r, row, col) ? "" : PQgetvalue(r, row, col);
}

static const char *pg_text_or_null(const PGresult *r, int row, int col)
{
    return PQgetisnull(r, row, col) ? NULL : PQgetvalue(r, row, col);
}

/* A double of a text result; NAN for NULL. */
static double pg_double(const PGresult *r, int row, int col)
{
    return PQgetisnull(r, row, col) ? NAN : strtod(PQgetvalue(r, row, col), NULL);
}

/* Statements on one job id: the params hold it as $1. */
static pg_params id_params(const char *id)
{
    pg_params pp = {0};
    pp_text(&pp, id);
    return pp;
}

static rd_error_code pg_status(pg_store *p, const char *id, rd_store_status *out, rd_error *err)
{
    pg_params pp = id_params(id);
    PGresult *r = pg_run(p, "SELECT status FROM jobs WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    int found = PQntuples(r) > 0;
    if (found)
        *out = (rd_store_status)rd_store_status_parse(pg_text(r, 0, 0));
    PQclear(r);
    return found ? RD_OK : rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
}

static rd_error_code pg_not_runnable(pg_store *p, const char *id, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = pg_status(p, id, &st, err);
    if (c)
        return c;
    return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
}

/* A round trip, then a committed write (deleted in the same transaction):
 * a store that cannot be written is not ready. */
static rd_error_code pg_ping(rd_store *s, rd_error *err)
{
    pg_store *p = pg(s);
    rd_error_code c = pg_ready(p, err);
    if (!c)
        c = pg_cmd(p, "SELECT 1", NULL, NULL, err);
    if (c)
        return c;
    c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p, "INSERT INTO write_probe (pad) VALUES (decode(repeat('00', 65536), 'hex'))", NULL, NULL, err);
    if (!c)
        c = pg_cmd(p, "DELETE FROM write_probe", NULL, NULL, err);
    return pg_end(p, c, err);
}

static rd_error_code pg_insert_tiles(pg_store *p, const char *id, int tiles, rd_error *err)
{
    pg_params pp = id_params(id);
    pp_int(&pp, tiles);
    return pg_cmd(p, "INSERT INTO tiles (job_id, tile) SELECT $1, g FROM generate_series(0, $2::int - 1) AS g", &pp,
                  NULL, err);
}

static rd_error_code pg_create(rd_store *s, const rd_store_job_spec *j, rd_error *err)
{
    pg_store *p = pg(s);
    rd_store_status old;
    rd_error look;
    rd_error_code c = pg_begin(p, err);
    if (c)
        return c;
    c = pg_status(p, j->id, &old, &look);
    if (c == RD_OK) {
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s exists already", j->id);
    } else if (c == RD_ERR_NOT_FOUND) {
        pg_params pp = id_params(j->id);
        pp_bytes(&pp, j->scene, j->scene_len);
        pp_text(&pp, j->format);
        pp_text(&pp, j->query ? j->query : "");
        pp_int(&pp, j->hdr != 0);
        pp_int(&pp, j->width);
        pp_int(&pp, j->height);
        pp_int(&pp, j->memory_bytes);
        pp_int(&pp, j->submitted_ms);
        pp_int(&pp, j->tiles);
        pp_int(&pp, j->passes);
        pp_int(&pp, j->gated != 0);
        pp_text(&pp, j->schedule);
        c = pg_cmd(p,
                   "INSERT INTO jobs (id, status, scene, format, query, hdr, width, height, memory_bytes, "
                   "submitted_ms, tiles_total, passes, gated, schedule) "
                   "VALUES ($1, 'queued', $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13)",
                   &pp, NULL, err);
    } else {
        *err = look;
    }
    if (!c && j->tiles)
        c = pg_insert_tiles(p, j->id, j->tiles, err);
    if (!c)
        c = pg_notify(p, RD_STORE_EV_SUBMITTED, j->id, err);
    return pg_end(p, c, err);
}

static void pg_info_row(const PGresult *r, rd_store_job_info *o)
{
    memset(o, 0, sizeof *o);
    snprintf(o->id, sizeof o->id, "%s", pg_text(r, 0, 0));
    o->status = (rd_store_status)rd_store_status_parse(pg_text(r, 0, 1));
    snprintf(o->format, sizeof o->format, "%s", pg_text(r, 0, 2));
    o->hdr = (int)pg_int(r, 0, 3);
    o->width = (int)pg_int(r, 0, 4);
    o->height = (int)pg_int(r, 0, 5);
    o->memory_bytes = pg_int(r, 0, 6);
    o->submitted_ms = pg_int(r, 0, 7);
    o->started_ms = pg_int(r, 0, 8);
    o->finished_ms = pg_int(r, 0, 9);
    if (!PQgetisnull(r, 0, 10)) {
        o->error.code = rd_store_code_parse(pg_text(r, 0, 10));
        o->error.line = (int)pg_int(r, 0, 11);
        o->error.column = (int)pg_int(r, 0, 12);
        snprintf(o->error.message, sizeof o->error.message, "%s", pg_text(r, 0, 13));
    }
    o->tiles_total = (int)pg_int(r, 0, 15);
    o->tiles_done = (int)pg_int(r, 0, 16);
    o->pass = (int)pg_int(r, 0, 17);
    o->passes = (int)pg_int(r, 0, 18);
    o->png_bytes = (size_t)pg_int(r, 0, 19);
    o->exr_bytes = (size_t)pg_int(r, 0, 20);
    o->gated = (int)pg_int(r, 0, 21);
    o->open_pass = (int)pg_int(r, 0, 22);
}

/* The one row sql gives for job id ($1), in text or binary; RD_ERR_NOT_FOUND
 * when there is no such job. *r is the caller's to PQclear. */
static rd_error_code pg_job_row(pg_store *p, const char *id, const char *sql, int binary, PGresult **r, rd_error *err)
{
    pg_params pp = id_params(id);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    *r = pg_run(p, sql, &pp, binary, err);
    if (!*r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(*r) == 0) {
        PQclear(*r);
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    }
    return RD_OK;
}

static rd_error_code pg_get(rd_store *s, const char *id, rd_store_job_info *out, rd_error *err)
{
    pg_store *p = pg(s);
    PGresult *r;
    rd_error_code c =
        pg_job_row(p, id,
                   "SELECT id, status, format, hdr, width, height, memory_bytes, submitted_ms, started_ms, "
                   "finished_ms, error_code, error_line, error_column, error_message, stats, tiles_total, "
                   "tiles_done, pass, passes, "
                   "(SELECT octet_length(data) FROM results WHERE job_id = jobs.id AND kind = 'png'), "
                   "(SELECT octet_length(data) FROM results WHERE job_id = jobs.id AND kind = 'exr'), "
                   "gated, open_pass, schedule FROM jobs WHERE id = $1",
                   0, &r, err);
    if (c)
        return c;
    rd_store_job_info o;
    pg_info_row(r, &o);
    if ((!PQgetisnull(r, 0, 14) && !(o.stats = rd_store_dup(pg_text(r, 0, 14), strlen(pg_text(r, 0, 14))))) ||
        (!PQgetisnull(r, 0, 23) && !(o.schedule = rd_store_dup(pg_text(r, 0, 23), strlen(pg_text(r, 0, 23))))))
        c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's texts");
    PQclear(r);
    if (!c)
        *out = o;
    else
        rd_store_job_info_free(&o);
    return c;
}

static rd_error_code pg_input(rd_store *s, const char *id, rd_store_job_input *out, rd_error *err)
{
    pg_store *p = pg(s);
    PGresult *r;
    rd_error_code c = pg_job_row(p, id,
                                 "SELECT scene, format, query, hdr, width, height, memory_bytes, submitted_ms "
                                 "FROM jobs WHERE id = $1",
                                 1, &r, err);
    if (c)
        return c;
    rd_store_job_input in;
    memset(&in, 0, sizeof in);
    in.scene_len = (size_t)PQgetlength(r, 0, 0);
    in.scene = rd_store_dup(PQgetvalue(r, 0, 0), in.scene_len);
    snprintf(in.format, sizeof in.format, "%.*s", PQgetlength(r, 0, 1), PQgetvalue(r, 0, 1));
    in.query = rd_store_dup(PQgetvalue(r, 0, 2), (size_t)PQgetlength(r, 0, 2));
    in.hdr = (int)pg_int(r, 0, 3);
    in.width = (int)pg_int(r, 0, 4);
    in.height = (int)pg_int(r, 0, 5);
    in.memory_bytes = pg_int(r, 0, 6);
    in.submitted_ms = pg_int(r, 0, 7);
    PQclear(r);
    if (!in.scene || !in.query) {
        rd_store_job_input_free(&in);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job's scene");
    }
    *out = in;
    return RD_OK;
}

static rd_error_code pg_update_runnable(pg_store *p, const char *sql, const pg_params *pp, rd_error *err)
{
    int n = 0;
    const char *id = pp->vals[0];
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p, sql, pp, &n, err);
    if (!c && n == 0)
        c = pg_not_runnable(p, id, err);
    return pg_end(p, c, err);
}

static rd_error_code pg_start(rd_store *s, const char *id, rd_error *err)
{
    pg_params pp = id_params(id);
    return pg_update_runnable(pg(s),
                              "UPDATE jobs SET status = 'running', started_ms = coalesce(started_ms, " NOW ") "
                              "WHERE id = $1 AND status IN ('queued', 'running')",
                              &pp, err);
}

static rd_error_code pg_stats(rd_store *s, const char *id, const char *stats, rd_error *err)
{
    pg_params pp = id_params(id);
    pp_text(&pp, stats);
    return pg_update_runnable(pg(s), "UPDATE jobs SET stats = $2 WHERE id = $1 AND status IN ('queued', 'running')",
                              &pp, err);
}

static rd_error_code pg_images(pg_store *p, const char *id, const rd_store_result *r, rd_error *err)
{
    const char *sql = "INSERT INTO results (job_id, kind, data) VALUES ($1, $2, $3)";
    pg_params pp = id_params(id);
    pp_text(&pp, "png");
    pp_bytes(&pp, r->png, r->png_len);
    rd_error_code c = pg_cmd(p, sql, &pp, NULL, err);
    if (!c && r->exr) {
        pp = id_params(id);
        pp_text(&pp, "exr");
        pp_bytes(&pp, r->exr, r->exr_len);
        c = pg_cmd(p, sql, &pp, NULL, err);
    }
    return c;
}

/* The tiles' locks before the job's (the order every transaction keeps). */
static rd_error_code pg_lock_tiles(pg_store *p, const char *id, rd_error *err)
{
    pg_params pp = id_params(id);
    return pg_cmd(p, "SELECT count(*) FROM (SELECT 1 FROM tiles WHERE job_id = $1 FOR UPDATE) AS locked", &pp, NULL,
                  err);
}

static rd_error_code pg_mark_ended(pg_store *p, const char *id, rd_store_status to, const rd_error *why,
                                   const rd_store_result *r, int *n, rd_error *err)
{
    pg_params pp = id_params(id);
    pp_text(&pp, rd_store_status_name(to));
    pp_text(&pp, r ? r->stats : NULL);
    pp_text(&pp, why ? rd_error_name(why->code) : NULL);
    if (why) {
        pp_int(&pp, why->line);
        pp_int(&pp, why->column);
    } else {
        pp_text(&pp, NULL);
        pp_text(&pp, NULL);
    }
    pp_text(&pp, why ? why->message : NULL);
    return pg_cmd(p,
                  "UPDATE jobs SET status = $2, finished_ms = " NOW ", stats = coalesce($3, stats), error_code = $4, "
                  "error_line = $5::int, error_column = $6::int, error_message = $7 "
                  "WHERE id = $1 AND status IN ('queued', 'running')",
                  &pp, n, err);
}

static rd_error_code pg_end_job(rd_store *s, const char *id, rd_store_status to, const rd_error *why,
                                const rd_store_result *r, int *changed, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    rd_store_status st;
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_lock_tiles(p, id, err);
    if (!c)
        c = pg_mark_ended(p, id, to, why, r, &n, err);
    if (!c && n == 0)
        c = pg_status(p, id, &st, err);
    else if (!c)
        c = pg_cmd(p, "DELETE FROM tiles WHERE job_id = $1", &pp, NULL, err);
    if (!c && n && to == RD_STORE_DONE)
        c = pg_images(p, id, r, err);
    if (!c && n)
        c = pg_notify(p, RD_STORE_EV_ENDED, id, err);
    *changed = n;
    return pg_end(p, c, err);
}

static rd_error_code pg_delete(rd_store *s, const char *id, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p, "DELETE FROM tiles WHERE job_id = $1", &pp, NULL, err);
    if (!c)
        c = pg_cmd(p, "DELETE FROM results WHERE job_id = $1", &pp, NULL, err);
    if (!c)
        c = pg_cmd(p, "DELETE FROM jobs WHERE id = $1", &pp, &n, err);
    if (!c && n == 0)
        c = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    return pg_end(p, c, err);
}

static rd_error_code pg_image(rd_store *s, const char *id, rd_store_image_kind kind, unsigned char **data, size_t *len,
                              rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    pp_text(&pp, kind == RD_STORE_PNG ? "png" : "exr");
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, "SELECT data FROM results WHERE job_id = $1 AND kind = $2", &pp, 1, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(r) == 0) {
        PQclear(r);
        rd_store_status st;
        c = pg_status(p, id, &st, err);
        return c ? c
                 : rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s (%s) has no %s", id, rd_store_status_name(st),
                                kind == RD_STORE_PNG ? "PNG" : "EXR");
    }
    size_t n = (size_t)PQgetlength(r, 0, 0);
    unsigned char *d = rd_store_dup(PQgetvalue(r, 0, 0), n);
    PQclear(r);
    if (!d)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for an image");
    *data = d;
    *len = n;
    return RD_OK;
}

static rd_error_code pg_list(rd_store *s, unsigned mask, size_t max, rd_store_job_brief **out, size_t *n, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    for (int i = 0; i < RD_STORE_STATUS_COUNT; i++)
        pp_text(&pp, mask & RD_STORE_MASK(i) ? rd_store_status_name((rd_store_status)i) : NULL);
    pp_int(&pp, (int64_t)(max > INT64_MAX ? INT64_MAX : max));
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p,
                         "SELECT id, status, submitted_ms FROM jobs WHERE status IN ($1, $2, $3, $4, $5) "
                         "ORDER BY submitted_ms, id LIMIT $6",
                         &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    size_t k = (size_t)PQntuples(r);
    rd_store_job_brief *list = k ? malloc(k * sizeof *list) : NULL;
    if (k && !list) {
        PQclear(r);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a job list");
    }
    for (size_t i = 0; i < k; i++) {
        snprintf(list[i].id, sizeof list[i].id, "%s", pg_text(r, (int)i, 0));
        list[i].status = (rd_store_status)rd_store_status_parse(pg_text(r, (int)i, 1));
        list[i].submitted_ms = pg_int(r, (int)i, 2);
    }
    PQclear(r);
    *out = list;
    *n = k;
    return RD_OK;
}

static rd_error_code pg_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    int n = 0;
    pp_int(&pp, ttl_ms);
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p,
                   "DELETE FROM results WHERE job_id IN (SELECT id FROM jobs "
                   "WHERE status IN ('done', 'failed', 'cancelled') AND finished_ms < " NOW " - $1::bigint)",
                   &pp, NULL, err);
    if (!c)
        c = pg_cmd(p,
                   "DELETE FROM jobs WHERE status IN ('done', 'failed', 'cancelled') "
                   "AND finished_ms < " NOW " - $1::bigint",
                   &pp, &n, err);
    *deleted = (size_t)n;
    return pg_end(p, c, err);
}

static rd_error_code pg_tiles_init(rd_store *s, const char *id, int tiles, int passes, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    pp_int(&pp, tiles);
    pp_int(&pp, passes);
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p,
                   "UPDATE jobs SET tiles_total = $2::int, passes = $3::int, tiles_done = 0, pass = 0, open_pass = 1 "
                   "WHERE id = $1 AND status IN ('queued', 'running') AND tiles_total = 0",
                   &pp, &n, err);
    if (!c && n == 0) {
        rd_store_status st;
        c = pg_status(p, id, &st, err);
        if (!c && (st == RD_STORE_QUEUED || st == RD_STORE_RUNNING))
            c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: job %s has its tiles already", id);
        else if (!c)
            c = rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "store: job %s is %s", id, rd_store_status_name(st));
    }
    if (!c)
        c = pg_insert_tiles(p, id, tiles, err);
    if (!c)
        c = pg_notify(p, RD_STORE_EV_TILES, id, err);
    return pg_end(p, c, err);
}

/* One statement, so no transaction of its own: the oldest runnable job's
 * claimable tiles, locked with SKIP LOCKED (a tile another claim holds is
 * passed over, and one it has just claimed fails the re-check of the
 * lease), then those of the first job taken and the job marked running.
 * A gated job's pass that is not open has no claimable tiles. The job row
 * a claim reads may be older than a concurrent tile_done or pass_open; but
 * a pass once open stays open, so a stale row can make a claim miss a pass
 * just opened (the next claim takes it), never take one that is not. */
static const char claim_sql[] =
    "WITH picked AS ("
    " SELECT t.job_id, t.tile, j.submitted_ms FROM tiles t JOIN jobs j ON j.id = t.job_id"
    " WHERE j.status IN ('queued', 'running') AND j.pass < j.passes AND t.passes_done = j.pass"
    " AND (j.gated = 0 OR j.pass < j.open_pass)"
    " AND ($4::text IS NULL OR j.id = $4::text) AND ($5::bigint <= 0 OR j.memory_bytes <= $5::bigint)"
    " AND (t.owner IS NULL OR t.lease_until < " NOW ")"
    " ORDER BY j.submitted_ms, j.id, t.tile LIMIT $2::int FOR UPDATE OF t SKIP LOCKED),"
    " first AS (SELECT job_id FROM picked ORDER BY submitted_ms, job_id LIMIT 1),"
    " started AS (UPDATE jobs SET status = 'running', started_ms = " NOW
    " WHERE id = (SELECT job_id FROM first) AND status = 'queued')"
    " UPDATE tiles t SET owner = $1, lease_until = " NOW " + $3::bigint FROM picked p"
    " WHERE p.job_id = (SELECT job_id FROM first) AND t.job_id = p.job_id AND t.tile = p.tile"
    " RETURNING t.job_id, t.tile, t.passes_done";

static int tile_cmp(const void *a, const void *b)
{
    const rd_store_tile *x = a, *y = b;
    return (x->index > y->index) - (x->index < y->index);
}

static rd_error_code pg_claim(rd_store *s, const char *daemon, int max, int lease_ms, const rd_store_claim_filter *f,
                              rd_store_tile *out, int *n, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    pp_text(&pp, daemon);
    pp_int(&pp, max);
    pp_int(&pp, lease_ms);
    pp_text(&pp, f->job_id);
    pp_int(&pp, f->max_memory_bytes);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, claim_sql, &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    int k = PQntuples(r) < max ? PQntuples(r) : max;
    for (int i = 0; i < k; i++) {
        snprintf(out[i].job_id, sizeof out[i].job_id, "%s", pg_text(r, i, 0));
        out[i].index = (int)pg_int(r, i, 1);
        out[i].pass = (int)pg_int(r, i, 2);
    }
    PQclear(r);
    qsort(out, (size_t)k, sizeof *out, tile_cmp);
    *n = k;
    return RD_OK;
}

static rd_error_code pg_leases(rd_store *s, const char *daemon, int lease_ms, int *count, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    pp_text(&pp, daemon);
    rd_error_code c = pg_begin(p, err);
    if (!c && lease_ms < 0) {
        c = pg_cmd(p, "UPDATE tiles SET owner = NULL, lease_until = NULL WHERE owner = $1", &pp, count, err);
        if (!c && *count)
            c = pg_notify(p, RD_STORE_EV_TILES, "", err);
    } else if (!c) {
        pp_int(&pp, lease_ms);
        c = pg_cmd(p, "UPDATE tiles SET lease_until = " NOW " + $2::bigint WHERE owner = $1", &pp, count, err);
    }
    return pg_end(p, c, err);
}

static rd_error_code pg_tile_refused(pg_store *p, const char *daemon, const rd_store_tile *t, rd_error *err)
{
    rd_store_status st;
    rd_error_code c = pg_status(p, t->job_id, &st, err);
    return c ? c : rd_store_refusal(st, daemon, t, err);
}

/* A gated job's next pass is not claimable yet: its TILES event is sent
 * by pass_open, so that a waiting daemon is not woken for nothing. */
static rd_error_code pg_advance(pg_store *p, const rd_store_tile *t, int last, int total, int gated, rd_error *err)
{
    pg_params pp = id_params(t->job_id);
    pp_int(&pp, t->pass + 1);
    pp_int(&pp, last ? total : 0);
    rd_error_code c = pg_cmd(p, "UPDATE jobs SET pass = $2::int, tiles_done = $3::int WHERE id = $1", &pp, NULL, err);
    return c || last || gated ? c : pg_notify(p, RD_STORE_EV_TILES, t->job_id, err);
}

static rd_error_code pg_count_tile(pg_store *p, const rd_store_tile *t, rd_store_tile_outcome *outcome, rd_error *err)
{
    pg_params pp = id_params(t->job_id);
    pp_int(&pp, t->pass);
    PGresult *r = pg_run(p,
                         "UPDATE jobs SET tiles_done = tiles_done + 1 WHERE id = $1 AND pass = $2::int "
                         "AND status IN ('queued', 'running') RETURNING tiles_done, tiles_total, passes, gated",
                         &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    int rows = PQntuples(r);
    int done = rows ? (int)pg_int(r, 0, 0) : 0, total = rows ? (int)pg_int(r, 0, 1) : 0;
    int passes = rows ? (int)pg_int(r, 0, 2) : 0, gated = rows ? (int)pg_int(r, 0, 3) : 0;
    PQclear(r);
    if (!rows)
        return pg_not_runnable(p, t->job_id, err);
    *outcome = RD_STORE_TILE_MORE;
    if (done < total)
        return RD_OK;
    int last = t->pass + 1 >= passes;
    *outcome = last ? RD_STORE_TILE_JOB_DONE : RD_STORE_TILE_PASS_DONE;
    return pg_advance(p, t, last, total, gated, err);
}

static rd_error_code pg_tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const void *data, size_t len,
                                  rd_store_tile_outcome *outcome, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(t->job_id);
    pp_int(&pp, t->index);
    pp_int(&pp, t->pass);
    pp_bytes(&pp, data, len);
    pp_text(&pp, daemon);
    rd_store_tile_outcome o = RD_STORE_TILE_MORE;
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p,
                   "UPDATE tiles SET passes_done = passes_done + 1, owner = NULL, lease_until = NULL, data = $4 "
                   "WHERE job_id = $1 AND tile = $2::int AND passes_done = $3::int AND owner = $5",
                   &pp, &n, err);
    if (!c)
        c = n ? pg_count_tile(p, t, &o, err) : pg_tile_refused(p, daemon, t, err);
    c = pg_end(p, c, err);
    if (!c)
        *outcome = o;
    return c;
}

/* Inside the transaction (not pg_job_row, which would find it busy and
 * reconnect). */
static rd_error_code pg_pass_refused(pg_store *p, const char *id, int pass, rd_error *err)
{
    pg_params pp = id_params(id);
    PGresult *r = pg_run(p, "SELECT status, gated, pass, passes, open_pass FROM jobs WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(r) == 0) {
        PQclear(r);
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no job %s", id);
    }
    rd_store_status st = (rd_store_status)rd_store_status_parse(pg_text(r, 0, 0));
    int gated = (int)pg_int(r, 0, 1), done = (int)pg_int(r, 0, 2), passes = (int)pg_int(r, 0, 3);
    int opened = (int)pg_int(r, 0, 4);
    PQclear(r);
    return rd_store_pass_refusal(id, pass, st, gated, done, passes, opened, err);
}

/* The WHERE is the whole rule (gated, running, pass - 1 complete, pass not
 * yet open). Of two openers at once, the second waits for the first's row
 * lock and, at read committed, evaluates the WHERE again on the row the
 * first committed: open_pass has moved on and it changes nothing. Only the
 * job's row is locked, and nothing after it, so the tiles-then-job order
 * holds. */
static rd_error_code pg_pass_open(rd_store *s, const char *id, int pass, const char *schedule, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    pp_int(&pp, pass);
    pp_text(&pp, schedule);
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p,
                   "UPDATE jobs SET open_pass = $2::int + 1, schedule = coalesce($3, schedule) "
                   "WHERE id = $1 AND gated = 1 AND status IN ('queued', 'running') "
                   "AND pass = $2::int AND open_pass = $2::int AND pass < passes",
                   &pp, &n, err);
    if (!c && n == 0)
        c = pg_pass_refused(p, id, pass, err);
    if (!c)
        c = pg_notify(p, RD_STORE_EV_TILES, id, err);
    return pg_end(p, c, err);
}

static rd_error_code pg_tiles_get(rd_store *s, const char *id, int index, rd_store_tile_data **out, size_t *n,
                                  rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    if (index >= 0)
        pp_int(&pp, index);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p,
                         index < 0 ? "SELECT tile, passes_done, data FROM tiles WHERE job_id = $1 AND passes_done > 0 "
                                     "ORDER BY tile"
                                   : "SELECT tile, passes_done, data FROM tiles WHERE job_id = $1 AND tile = $2::int",
                         &pp, 1, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    size_t k = (size_t)PQntuples(r);
    rd_store_tile_data *list = k ? calloc(k, sizeof *list) : NULL;
    for (size_t i = 0; list && i < k; i++) {
        list[i].index = (int)pg_int(r, (int)i, 0);
        list[i].passes = (int)pg_int(r, (int)i, 1);
        list[i].len = (size_t)PQgetlength(r, (int)i, 2);
        if (!PQgetisnull(r, (int)i, 2) && !(list[i].data = rd_store_dup(PQgetvalue(r, (int)i, 2), list[i].len)))
            c = RD_ERR_NOMEM;
    }
    PQclear(r);
    if ((k && !list) || c) {
        rd_store_tiles_free(list, k);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for tiles");
    }
    rd_store_status st;
    if (k == 0 && (c = pg_status(p, id, &st, err)))
        return c;
    *out = list;
    *n = k;
    return RD_OK;
}

/* The oldest event kept, if any. */
static void pg_next_event(pg_store *p, rd_store_event *ev)
{
    if (p->count) {
        *ev = p->events[p->first];
        p->first = (p->first + 1) % EVENTS_KEPT;
        p->count--;
    }
}

/* Holds the mutex only to read, and waits on the socket in slices, so that
 * a reconnection by another call on the handle is noticed. */
static rd_error_code pg_wait(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err)
{
    pg_store *p = pg(s);
    double deadline = rd_now_ms() + timeout_ms;
    for (;;) {
        pthread_mutex_lock(&s->lock);
        rd_error_code c = pg_ready(p, err);
        int fd = c ? -1 : PQsocket(p->conn);
        if (!c)
            pg_next_event(p, ev);
        pthread_mutex_unlock(&s->lock);
        double left = deadline - rd_now_ms();
        if (c || ev->kind != RD_STORE_EV_NONE || left <= 0) {
            if (c && left > 0) {
                struct timespec ts = {(time_t)(left / 1000), (long)((long long)left % 1000) * 1000000L};
                nanosleep(&ts, NULL);
            }
            return c;
        }
        struct pollfd pfd = {fd, POLLIN, 0};
        poll(&pfd, 1, left > 100 ? 100 : (int)left + 1);
    }
}

/* Grades and batches. A put takes the batch's row lock (its count) before
 * it inserts the grade, and expiry takes the old batches' row locks first
 * too, so neither waits for the other in a circle. */

/* *found: whether sql (a SELECT on $1) has a row. */
static rd_error_code pg_exists(pg_store *p, const char *sql, const char *id, int *found, rd_error *err)
{
    pg_params pp = id_params(id);
    PGresult *r = pg_run(p, sql, &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    *found = PQntuples(r) > 0;
    PQclear(r);
    return RD_OK;
}

static rd_error_code pg_batch_refused(pg_store *p, const char *id, const char *assignment, rd_error *err)
{
    pg_params pp = id_params(id);
    PGresult *r = pg_run(p, "SELECT status, assignment, done, total FROM batches WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    rd_error_code c;
    if (PQntuples(r) == 0)
        c = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    else
        c = rd_store_batch_refusal(id, assignment, (rd_store_batch_status)rd_store_batch_status_parse(pg_text(r, 0, 0)),
                                   pg_text(r, 0, 1), (int)pg_int(r, 0, 2), (int)pg_int(r, 0, 3), err);
    PQclear(r);
    return c;
}

/* The WHERE is the whole rule. Of two puts at once, the second waits for
 * the first's row lock and, at read committed, evaluates the WHERE again
 * on the row the first committed: it counts on from there, and once the
 * batch is done it changes nothing. */
static rd_error_code pg_count_grade(pg_store *p, const rd_store_grade *g, rd_error *err)
{
    pg_params pp = id_params(g->batch_id);
    pp_text(&pp, g->assignment);
    int n = 0;
    rd_error_code c = pg_cmd(p,
                             "UPDATE batches SET done = done + 1, "
                             "status = CASE WHEN done + 1 >= total THEN 'done' ELSE status END "
                             "WHERE id = $1 AND status = 'running' AND assignment = $2 AND done < total",
                             &pp, &n, err);
    if (!c && n == 0)
        c = pg_batch_refused(p, g->batch_id, g->assignment, err);
    return c;
}

static rd_error_code pg_insert_grade(pg_store *p, const rd_store_grade *g, rd_error *err)
{
    int graded = !g->error;
    pg_params pp = id_params(g->id);
    pp_text(&pp, g->batch_id);
    pp_text(&pp, g->assignment);
    pp_text(&pp, g->student);
    pp_int(&pp, g->pass);
    pp_double(&pp, graded ? &g->failed_fraction : NULL);
    pp_double(&pp, graded ? &g->max_abs : NULL);
    pp_double(&pp, graded ? &g->psnr_db : NULL);
    pp_double(&pp, graded ? &g->ssim : NULL);
    pp_text(&pp, g->verdict);
    pp_text(&pp, g->reference_key);
    pp_int(&pp, g->graded_ms);
    pp_text(&pp, g->error);
    return pg_cmd(p,
                  "INSERT INTO grades (" RD_STORE_GRADE_COLUMNS ") VALUES ($1, $2, $3, $4, $5::int, "
                  "$6::double precision, $7::double precision, $8::double precision, $9::double precision, "
                  "$10, $11, $12::bigint, $13)",
                  &pp, NULL, err);
}

static rd_error_code pg_grade_put(rd_store *s, const rd_store_grade *g, const unsigned char *diff, size_t len,
                                  rd_error *err)
{
    pg_store *p = pg(s);
    int found = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_exists(p, "SELECT 1 FROM grades WHERE id = $1", g->id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s exists already", g->id);
    if (!c && g->batch_id)
        c = pg_count_grade(p, g, err);
    if (!c)
        c = pg_insert_grade(p, g, err);
    if (!c && diff) {
        pg_params pp = id_params(g->id);
        pp_bytes(&pp, diff, len);
        c = pg_cmd(p, "INSERT INTO grade_images (grade_id, kind, data) VALUES ($1, 'diff', $2)", &pp, NULL, err);
    }
    return pg_end(p, c, err);
}

/* Row i of RD_STORE_GRADE_COLUMNS, in text. */
static rd_error_code pg_grade_row(const PGresult *r, int i, rd_store_grade *g, rd_error *err)
{
    memset(g, 0, sizeof *g);
    g->pass = (int)pg_int(r, i, 4);
    g->failed_fraction = pg_double(r, i, 5);
    g->max_abs = pg_double(r, i, 6);
    g->psnr_db = pg_double(r, i, 7);
    g->ssim = pg_double(r, i, 8);
    g->graded_ms = pg_int(r, i, 11);
    const char *texts[RD_STORE_GRADE_TEXTS] = {
        pg_text_or_null(r, i, 0), pg_text_or_null(r, i, 1),  pg_text_or_null(r, i, 2), pg_text_or_null(r, i, 3),
        pg_text_or_null(r, i, 9), pg_text_or_null(r, i, 10), pg_text_or_null(r, i, 12)};
    return rd_store_grade_texts(g, texts, err);
}

static rd_error_code pg_grade_get(rd_store *s, const char *id, rd_store_grade *out, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, "SELECT " RD_STORE_GRADE_COLUMNS " FROM grades WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    rd_store_grade g;
    if (PQntuples(r) == 0)
        c = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no grade %s", id);
    else if (!(c = pg_grade_row(r, 0, &g, err)))
        *out = g;
    PQclear(r);
    return c;
}

static rd_error_code pg_grade_image(rd_store *s, const char *id, rd_store_grade_image_kind kind, unsigned char **data,
                                    size_t *len, rd_error *err)
{
    pg_store *p = pg(s);
    const char *name = rd_store_grade_image_name(kind);
    pg_params pp = id_params(id);
    pp_text(&pp, name);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, "SELECT data FROM grade_images WHERE grade_id = $1 AND kind = $2", &pp, 1, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(r) == 0) {
        PQclear(r);
        int found = 0;
        if ((c = pg_exists(p, "SELECT 1 FROM grades WHERE id = $1", id, &found, err)))
            return c;
        if (!found)
            return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no grade %s", id);
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: grade %s has no %s image", id, name);
    }
    size_t n = (size_t)PQgetlength(r, 0, 0);
    unsigned char *d = rd_store_dup(PQgetvalue(r, 0, 0), n);
    PQclear(r);
    if (!d)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for an image");
    *data = d;
    *len = n;
    return RD_OK;
}

/* Only the filter's given conditions are written in, numbered as they
 * come (PostgreSQL wants every parameter used); the values are bound. */
static rd_error_code pg_grades_list(rd_store *s, const rd_store_grade_filter *f, rd_store_grade **out, size_t *n,
                                    rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    char sql[400];
    int at = snprintf(sql, sizeof sql, "SELECT " RD_STORE_GRADE_COLUMNS " FROM grades WHERE graded_ms >= $1::bigint");
    pp_int(&pp, f->since_ms);
    const char *cols[3] = {"assignment", "student", "batch_id"};
    const char *vals[3] = {f->assignment, f->student, f->batch_id};
    for (int i = 0; i < 3; i++)
        if (vals[i]) {
            pp_text(&pp, vals[i]);
            at += snprintf(sql + at, sizeof sql - (size_t)at, " AND %s = $%d", cols[i], pp.n);
        }
    pp_int(&pp, (int64_t)(f->max > INT64_MAX ? INT64_MAX : f->max));
    snprintf(sql + at, sizeof sql - (size_t)at, " ORDER BY graded_ms, id LIMIT $%d::bigint", pp.n);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, sql, &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    size_t k = (size_t)PQntuples(r), done = 0;
    rd_store_grade *list = k ? calloc(k, sizeof *list) : NULL;
    if (k && !list)
        c = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a grade list");
    for (; !c && done < k; done++)
        c = pg_grade_row(r, (int)done, &list[done], err);
    PQclear(r);
    if (c) {
        rd_store_grades_free(list, done);
        return c;
    }
    *out = list;
    *n = k;
    return RD_OK;
}

/* The cut is read once, so that every statement deletes by the same time.
 * The old batches are locked first: a put of a grade to one of them has
 * committed before, or waits until after, and so the batches found with no
 * grade left (by the DELETE's own, later, snapshot) cannot be given one
 * before they go, and the cascade deletes no grade. */
static rd_error_code pg_grades_expire(rd_store *s, int64_t ttl_ms, size_t *deleted, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = {0};
    int n = 0;
    pp_int(&pp, ttl_ms);
    rd_error_code c = pg_begin(p, err);
    PGresult *r = c ? NULL : pg_run(p, "SELECT " NOW " - $1::bigint", &pp, 0, err);
    if (!c && !r)
        c = err ? err->code : RD_ERR_IO;
    if (!c) {
        pp = (pg_params){0};
        pp_int(&pp, pg_int(r, 0, 0));
        PQclear(r);
        c = pg_cmd(p,
                   "SELECT count(*) FROM (SELECT 1 FROM batches WHERE created_ms < $1::bigint ORDER BY id FOR UPDATE) "
                   "AS locked",
                   &pp, NULL, err);
    }
    if (!c)
        c = pg_cmd(p, "DELETE FROM grade_images WHERE grade_id IN (SELECT id FROM grades WHERE graded_ms < $1::bigint)",
                   &pp, NULL, err);
    if (!c)
        c = pg_cmd(p, "DELETE FROM grades WHERE graded_ms < $1::bigint", &pp, &n, err);
    if (!c)
        c = pg_cmd(p,
                   "DELETE FROM batches WHERE created_ms < $1::bigint "
                   "AND NOT EXISTS (SELECT 1 FROM grades WHERE batch_id = batches.id)",
                   &pp, NULL, err);
    *deleted = (size_t)n;
    return pg_end(p, c, err);
}

static rd_error_code pg_batch_create(rd_store *s, const char *id, const char *assignment, int total, const char *daemon,
                                     const char *students, rd_error *err)
{
    pg_store *p = pg(s);
    int found = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_exists(p, "SELECT 1 FROM batches WHERE id = $1", id, &found, err);
    if (!c && found)
        c = rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: batch %s exists already", id);
    if (!c) {
        pg_params pp = id_params(id);
        pp_text(&pp, assignment);
        pp_int(&pp, total);
        pp_text(&pp, daemon);
        pp_text(&pp, students);
        c = pg_cmd(p,
                   "INSERT INTO batches (id, assignment, total, done, status, created_ms, daemon, students) "
                   "VALUES ($1, $2, $3::int, 0, 'running', " NOW ", $4, $5)",
                   &pp, NULL, err);
    }
    return pg_end(p, c, err);
}

#define BATCH_COLUMNS "id, assignment, total, done, status, created_ms"

/* The batch of row i of a result of BATCH_COLUMNS. */
static rd_store_batch pg_batch_of(const PGresult *r, int i)
{
    rd_store_batch b;
    memset(&b, 0, sizeof b);
    snprintf(b.id, sizeof b.id, "%s", pg_text(r, i, 0));
    snprintf(b.assignment, sizeof b.assignment, "%s", pg_text(r, i, 1));
    b.total = (int)pg_int(r, i, 2);
    b.done = (int)pg_int(r, i, 3);
    b.status = (rd_store_batch_status)rd_store_batch_status_parse(pg_text(r, i, 4));
    b.created_ms = pg_int(r, i, 5);
    return b;
}

/* Inside a transaction or not (pg_run, not pg_ready). */
static rd_error_code pg_batch_row(pg_store *p, const char *id, rd_store_batch *out, rd_error *err)
{
    pg_params pp = id_params(id);
    PGresult *r = pg_run(p, "SELECT " BATCH_COLUMNS " FROM batches WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(r) == 0) {
        PQclear(r);
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    }
    *out = pg_batch_of(r, 0);
    PQclear(r);
    return RD_OK;
}

static rd_error_code pg_batches_running(rd_store *s, const char *daemon, size_t max, rd_store_batch **out, size_t *n,
                                        rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(daemon);
    pp_int(&pp, (int64_t)(max > INT64_MAX ? INT64_MAX : max));
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p,
                         "SELECT " BATCH_COLUMNS " FROM batches WHERE daemon = $1 AND status = 'running' "
                         "ORDER BY created_ms, id LIMIT $2",
                         &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    size_t k = (size_t)PQntuples(r);
    rd_store_batch *list = k ? malloc(k * sizeof *list) : NULL;
    if (k && !list) {
        PQclear(r);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a batch list");
    }
    for (size_t i = 0; i < k; i++)
        list[i] = pg_batch_of(r, (int)i);
    PQclear(r);
    *out = list;
    *n = k;
    return RD_OK;
}

static rd_error_code pg_batch_students(rd_store *s, const char *id, char **students, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    rd_error_code c = pg_ready(p, err);
    if (c)
        return c;
    PGresult *r = pg_run(p, "SELECT students FROM batches WHERE id = $1", &pp, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    if (PQntuples(r) == 0) {
        PQclear(r);
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "store: no batch %s", id);
    }
    const char *t = pg_text(r, 0, 0);
    char *copy = rd_store_dup(t, strlen(t));
    PQclear(r);
    if (!copy)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: out of memory reading a batch's students");
    *students = copy;
    return RD_OK;
}

static rd_error_code pg_batch_get(rd_store *s, const char *id, rd_store_batch *out, rd_error *err)
{
    pg_store *p = pg(s);
    rd_error_code c = pg_ready(p, err);
    return c ? c : pg_batch_row(p, id, out, err);
}

static rd_error_code pg_batch_cancel(rd_store *s, const char *id, int *changed, rd_error *err)
{
    pg_store *p = pg(s);
    pg_params pp = id_params(id);
    rd_store_batch b;
    int n = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p, "UPDATE batches SET status = 'cancelled' WHERE id = $1 AND status = 'running'", &pp, &n, err);
    if (!c && n == 0)
        c = pg_batch_row(p, id, &b, err);
    *changed = n;
    return pg_end(p, c, err);
}

static void pg_close(rd_store *s)
{
    pg_store *p = pg(s);
    if (p->conn)
        PQfinish(p->conn);
    free(p->conninfo);
    free(p);
}

static const rd_store_ops pg_ops = {
    .name = "postgresql",
    .close = pg_close,
    .ping = pg_ping,
    .job_create = pg_create,
    .job_get = pg_get,
    .job_input = pg_input,
    .job_start = pg_start,
    .job_stats = pg_stats,
    .job_end = pg_end_job,
    .job_delete = pg_delete,
    .job_image = pg_image,
    .jobs_list = pg_list,
    .jobs_expire = pg_expire,
    .tiles_init = pg_tiles_init,
    .claim = pg_claim,
    .leases = pg_leases,
    .tile_done = pg_tile_done,
    .pass_open = pg_pass_open,
    .tiles_get = pg_tiles_get,
    .wait = pg_wait,
    .grade_put = pg_grade_put,
    .grade_get = pg_grade_get,
    .grade_image = pg_grade_image,
    .grades_list = pg_grades_list,
    .grades_expire = pg_grades_expire,
    .batch_create = pg_batch_create,
    .batch_get = pg_batch_get,
    .batches_running = pg_batches_running,
    .batch_students = pg_batch_students,
    .batch_cancel = pg_batch_cancel,
};

/* Migrations, under an advisory lock so that daemons starting together
 * apply each once. */

static rd_error_code pg_version(pg_store *p, int *v, rd_error *err)
{
    PGresult *r = pg_run(p, "SELECT coalesce(max(version), 0) FROM schema_version", NULL, 0, err);
    if (!r)
        return err ? err->code : RD_ERR_IO;
    *v = (int)pg_int(r, 0, 0);
    PQclear(r);
    return RD_OK;
}

static rd_error_code pg_apply(pg_store *p, const rd_store_migration *m, rd_error *err)
{
    char *sql = rd_store_migration_text(m->sql, "BYTEA");
    if (!sql)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for migration %s", m->name);
    rd_error_code c = pg_cmd(p, sql, NULL, NULL, err);
    free(sql);
    if (c)
        return c;
    pg_params pp = {0};
    pp_int(&pp, m->version);
    pp_text(&pp, m->name);
    return pg_cmd(p, "INSERT INTO schema_version (version, name, applied_ms) VALUES ($1::int, $2, " NOW ")", &pp, NULL,
                  err);
}

static rd_error_code pg_migrate(pg_store *p, rd_error *err)
{
    int v = 0;
    rd_error_code c = pg_begin(p, err);
    if (!c)
        c = pg_cmd(p, "SELECT pg_advisory_xact_lock(7265617964)", NULL, NULL, err);
    if (!c)
        c = pg_cmd(p,
                   "CREATE TABLE IF NOT EXISTS schema_version (version INTEGER PRIMARY KEY, name TEXT NOT NULL, "
                   "applied_ms BIGINT NOT NULL)",
                   NULL, NULL, err);
    if (!c)
        c = pg_version(p, &v, err);
    if (!c && v > rd_store_migration_count)
        c = rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0,
                         "store: its schema is version %d, newer than this rayd's %d: run a newer rayd", v,
                         rd_store_migration_count);
    for (int i = v; !c && i < rd_store_migration_count; i++)
        c = pg_apply(p, &rd_store_migrations[i], err);
    return pg_end(p, c, err);
}

static void cap_limits(rd_store_limits *l)
{
    size_t *sizes[] = {&l->scene_bytes, &l->text_bytes, &l->image_bytes, &l->tile_bytes};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        if (*sizes[i] > PG_FIELD_MAX - 1)
            *sizes[i] = PG_FIELD_MAX - 1;
}

rd_store *rd_store_pg_open(const char *conninfo, const rd_store_options *opt, rd_error *err)
{
    pg_store *p = calloc(1, sizeof *p);
    if (!p || !(p->conninfo = rd_store_dup(conninfo, strlen(conninfo)))) {
        free(p);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory");
        return NULL;
    }
    p->base.ops = &pg_ops;
    p->base.opt = *opt;
    cap_limits(&p->base.opt.limits);
    rd_error_code c = pg_connect(p, err);
    if (!c)
        c = pg_migrate(p, err);
    if (c) {
        pg_close(&p->base);
        return NULL;
    }
    return &p->base;
}
