/* The store in PostgreSQL, for several daemons sharing one queue. Writers
 * run side by side, so the dialect locks the rows a transaction decides on
 * (FOR UPDATE) and claims pass each other's tiles (SKIP LOCKED); the clock
 * is the server's; creations, completed (or opened) passes and ends send
 * NOTIFY rayd_jobs inside their transaction, delivered at commit.
 *
 * Never hang, never crash when the server is away: the connection is
 * non-blocking and every statement has a deadline here (beyond the server's
 * statement_timeout); connecting is bounded by connect_timeout; a
 * connection found broken, or past a deadline, is closed, and the next call
 * outside a transaction connects anew.
 *
 * Values go with explicit types (so the SQL needs no casts) and results
 * come back in binary (so doubles are the very bits, whatever the server's
 * extra_float_digits). */
#include <errno.h>
#include <libpq-fe.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "rayd/clock.h"
#include "store_internal.h"

#define CHANNEL "rayd_jobs"

/* PostgreSQL takes at most 1 GB in one field. */
#define PG_FIELD_MAX ((size_t)1 << 30)

/* Notifications kept for rd_store_wait: libpq's own queue grows without
 * bound on a handle that never waits, so they are moved here, the oldest
 * dropped when it is full. */
#define EVENTS_KEPT 64

/* The types values are sent as (the server's pg_type OIDs, fixed). */
enum { OID_BYTEA = 17, OID_INT8 = 20, OID_TEXT = 25, OID_FLOAT8 = 701 };

/* The most values one statement binds: a grade's insert has 19. */
#define VALUES_MAX 24

typedef struct {
    rd_store base;
    PGconn *conn; /* NULL when not connected */
    char *conninfo;
    int backend; /* the server process of conn: its own NOTIFYs are not events */
    int in_tx;   /* between begin and commit or rollback: no reconnecting */
    rd_store_event events[EVENTS_KEPT];
    int first, count;
} pg_store;

/* A statement runs at its first step, with its values as text (numbers in
 * decimal) or binary (bytes). */
struct rd_store_stmt {
    pg_store *p;
    char *sql;
    int n, too_many; /* values bound: the highest position; one past VALUES_MAX */
    const char *vals[VALUES_MAX];
    int lens[VALUES_MAX], fmts[VALUES_MAX];
    Oid types[VALUES_MAX];
    char nums[VALUES_MAX][32];
    PGresult *res;
    int row;
};

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

/* The one mapping of PostgreSQL's failures to the store's codes: a
 * statement's SQLSTATE, or NULL for the connection's trouble (down, broken,
 * past the deadline), which is unreachable: RD_ERR_UNAVAILABLE (503). A bad value is
 * RD_ERR_INVALID, a lost conflict RD_ERR_BUSY, a full disk RD_ERR_NOSPACE,
 * a corrupt page or index RD_ERR_DAMAGED. */
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

static void pg_drop(pg_store *p)
{
    PQfinish(p->conn);
    p->conn = NULL;
}

/* The connection is unusable: closed, so that the next call reconnects. */
static rd_error_code pg_broken(pg_store *p, const char *what, rd_error *err)
{
    char line[400];
    rd_error_code c = rd_error_set(err, pg_code(NULL), 0, 0, "store: PostgreSQL %s: %s", what,
                                   one_line(line, sizeof line, p->conn ? PQerrorMessage(p->conn) : NULL));
    pg_drop(p);
    return c;
}

static rd_error_code pg_failed(pg_store *p, PGresult *r, rd_error *err)
{
    char line[400];
    const char *msg = PQresultErrorField(r, PG_DIAG_MESSAGE_PRIMARY);
    rd_error_code c = pg_code(PQresultErrorField(r, PG_DIAG_SQLSTATE));
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
        if (deadline - rd_now_ms() <= 0) {
            pg_drop(p);
            return rd_error_set(err, pg_code(NULL), 0, 0, "store: PostgreSQL did not answer within %d ms",
                                p->base.opt.timeout_ms);
        }
        struct pollfd pfd = {PQsocket(p->conn), (short)(POLLIN | (f ? POLLOUT : 0)), 0};
        int r = poll(&pfd, 1, (int)(deadline - rd_now_ms()) + 1);
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

/* Runs one statement with st's values (st NULL: a script of several, with
 * none); *out (may be NULL) its result, the caller's to PQclear. A script
 * fails with its first error. */
static rd_error_code pg_run(pg_store *p, const char *sql, const rd_store_stmt *st, PGresult **out, rd_error *err)
{
    if (!p->conn)
        return pg_broken(p, "connection lost in a transaction", err);
    int sent = st ? PQsendQueryParams(p->conn, sql, st->n, st->types, st->vals, st->lens, st->fmts, 1)
                  : PQsendQuery(p->conn, sql);
    if (!sent)
        return pg_broken(p, "sending", err);
    double deadline = rd_now_ms() + p->base.opt.timeout_ms + 1000;
    PGresult *keep = NULL, *r;
    rd_error_code c;
    while (!(c = pg_pump(p, deadline, err)) && (r = PQgetResult(p->conn))) {
        if (!keep || result_ok(keep)) {
            PQclear(keep);
            keep = r;
        } else {
            PQclear(r);
        }
    }
    if (c || !keep) {
        PQclear(keep);
        return c ? c : pg_broken(p, "answering", err);
    }
    if (!result_ok(keep))
        return pg_failed(p, keep, err);
    if (out)
        *out = keep;
    else
        PQclear(keep);
    return RD_OK;
}

/* Events. Their payload: "s:ID" submitted, "t:ID" tiles, "e:ID" ended. */

static const char event_letters[] = {
    [RD_STORE_EV_SUBMITTED] = 's', [RD_STORE_EV_TILES] = 't', [RD_STORE_EV_ENDED] = 'e'};

static void event_parse(const char *payload, rd_store_event *ev)
{
    memset(ev, 0, sizeof *ev);
    ev->kind = RD_STORE_EV_CHANGED;
    for (int k = RD_STORE_EV_SUBMITTED; k <= RD_STORE_EV_ENDED; k++)
        if (payload[0] == event_letters[k] && payload[1] == ':') {
            ev->kind = (rd_store_event_kind)k;
            snprintf(ev->job_id, sizeof ev->job_id, "%s", payload + 2);
        }
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
            event_parse(nt->extra, &p->events[(p->first + p->count++) % EVENTS_KEPT]);
        }
        PQfreemem(nt);
    }
}

/* Connecting. */

static void quiet(void *arg, const char *message)
{
    (void)arg;
    (void)message; /* "relation already exists, skipping" and such */
}

/* A new connection, listening. The caller's spec comes last so that it may
 * override the timeouts. */
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
    PQsetnonblocking(p->conn, 1);
    p->backend = PQbackendPID(p->conn);
    return pg_run(p, "LISTEN " CHANNEL, NULL, NULL, err);
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

/* The driver. */

static rd_error_code pg_script(rd_store *s, const char *sql, const char *what, rd_error *err)
{
    (void)what; /* the server's message names the statement */
    return pg_run(pg(s), sql, NULL, NULL, err);
}

static rd_error_code pg_begin(rd_store *s, rd_error *err)
{
    pg_store *p = pg(s);
    rd_error_code c = pg_ready(p, err);
    if (!c)
        c = pg_run(p, "BEGIN", NULL, NULL, err);
    p->in_tx = !c;
    return c;
}

static rd_error_code pg_commit(rd_store *s, rd_error *err)
{
    pg(s)->in_tx = 0;
    return pg_run(pg(s), "COMMIT", NULL, NULL, err);
}

static void pg_rollback(rd_store *s)
{
    pg_store *p = pg(s);
    rd_error ignored;
    p->in_tx = 0;
    if (p->conn && PQtransactionStatus(p->conn) != PQTRANS_IDLE)
        pg_run(p, "ROLLBACK", NULL, NULL, &ignored);
}

static rd_error_code pg_prepare(rd_store *s, const char *sql, rd_store_stmt **out, rd_error *err)
{
    rd_store_stmt *st = calloc(1, sizeof *st);
    if (!st || !(st->sql = rd_store_dup(sql, strlen(sql)))) {
        free(st);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a statement");
    }
    st->p = pg(s);
    st->row = -1;
    *out = st;
    return RD_OK;
}

/* Position i's slot, or -1 past VALUES_MAX (which step tells). */
static int pg_slot(rd_store_stmt *st, int i)
{
    if (i < 1 || i > VALUES_MAX) {
        st->too_many = 1;
        return -1;
    }
    st->n = i > st->n ? i : st->n;
    return i - 1;
}

static void pg_bind(rd_store_stmt *st, int i, const char *val, int len, int binary, Oid type)
{
    int k = pg_slot(st, i);
    if (k < 0)
        return;
    st->vals[k] = val;
    st->lens[k] = len;
    st->fmts[k] = binary;
    st->types[k] = type;
}

/* Numbers go as decimal text. */
static void pg_bind_int(rd_store_stmt *st, int i, int64_t v)
{
    int k = pg_slot(st, i);
    if (k >= 0) {
        snprintf(st->nums[k], sizeof st->nums[k], "%lld", (long long)v);
        pg_bind(st, i, st->nums[k], 0, 0, OID_INT8);
    }
}

/* 17 significant digits: the server reads back the very double. */
static void pg_bind_double(rd_store_stmt *st, int i, double v)
{
    int k = pg_slot(st, i);
    if (k >= 0) {
        snprintf(st->nums[k], sizeof st->nums[k], "%.17g", v);
        pg_bind(st, i, st->nums[k], 0, 0, OID_FLOAT8);
    }
}

static void pg_bind_text(rd_store_stmt *st, int i, const char *t) { pg_bind(st, i, t, 0, 0, OID_TEXT); }

/* The limits are below PG_FIELD_MAX, so len fits an int. */
static void pg_bind_blob(rd_store_stmt *st, int i, const void *data, size_t len)
{
    pg_bind(st, i, data ? data : "", (int)len, 1, OID_BYTEA);
}

/* Of no type: the server takes its place's (a column's). */
static void pg_bind_null(rd_store_stmt *st, int i) { pg_bind(st, i, NULL, 0, 0, 0); }

/* Outside a transaction a statement first reads what the server sent and
 * reconnects if it must; inside one it runs on the transaction's
 * connection or fails. */
static rd_error_code pg_execute(rd_store_stmt *st, rd_error *err)
{
    pg_store *p = st->p;
    if (st->too_many)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "store: a statement of more than %d values", VALUES_MAX);
    rd_error_code c = p->in_tx ? RD_OK : pg_ready(p, err);
    return c ? c : pg_run(p, st->sql, st, &st->res, err);
}

static int pg_step(rd_store_stmt *st, rd_error *err)
{
    rd_error_code c = st->res ? RD_OK : pg_execute(st, err);
    if (c)
        return -(int)c;
    return ++st->row < PQntuples(st->res);
}

static int pg_changes(rd_store_stmt *st) { return atoi(PQcmdTuples(st->res)); }

static int pg_is_null(rd_store_stmt *st, int col) { return PQgetisnull(st->res, st->row, col); }

/* A big-endian integer of 1, 2, 4 or 8 bytes. */
static int64_t pg_col_int(rd_store_stmt *st, int col)
{
    const unsigned char *v = (const unsigned char *)PQgetvalue(st->res, st->row, col);
    int n = PQgetisnull(st->res, st->row, col) ? 0 : PQgetlength(st->res, st->row, col);
    uint64_t x = 0;
    for (int i = 0; i < n; i++)
        x = x << 8 | v[i];
    return n == 4 ? (int64_t)(int32_t)x : n == 2 ? (int64_t)(int16_t)x : (int64_t)x;
}

/* The schema's reals are all DOUBLE PRECISION: 8 bytes, big-endian. */
static double pg_col_double(rd_store_stmt *st, int col)
{
    uint64_t bits = (uint64_t)pg_col_int(st, col);
    double d;
    if (PQftype(st->res, col) != OID_FLOAT8)
        return (double)(int64_t)bits;
    memcpy(&d, &bits, sizeof d);
    return d;
}

/* A text's binary form is its bytes, and libpq ends every value with a NUL. */
static const char *pg_col_text(rd_store_stmt *st, int col)
{
    return PQgetisnull(st->res, st->row, col) ? NULL : PQgetvalue(st->res, st->row, col);
}

static const void *pg_col_blob(rd_store_stmt *st, int col, size_t *len)
{
    *len = (size_t)PQgetlength(st->res, st->row, col);
    return PQgetvalue(st->res, st->row, col);
}

static void pg_finalize(rd_store_stmt *st)
{
    if (!st)
        return;
    PQclear(st->res);
    free(st->sql);
    free(st);
}

static rd_error_code pg_notify(rd_store *s, rd_store_event_kind kind, const char *id, rd_error *err)
{
    char payload[RD_STORE_ID_MAX + 4];
    snprintf(payload, sizeof payload, "%c:%s", event_letters[kind], id);
    rd_store_stmt st = {.p = pg(s)};
    pg_bind_text(&st, 1, payload);
    return pg_run(pg(s), "SELECT pg_notify('" CHANNEL "', $1)", &st, NULL, err);
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

static void pg_close(rd_store *s)
{
    pg_store *p = pg(s);
    if (p->conn)
        PQfinish(p->conn);
    free(p->conninfo);
    free(p);
}

static const rd_store_driver pg_driver = {
    .name = "postgresql",
    .sql = {.now = "(extract(epoch FROM statement_timestamp()) * 1000)::bigint",
            .lock = " FOR UPDATE",
            .skip_locked = " FOR UPDATE SKIP LOCKED",
            .blob = "BYTEA",
            .migration_lock = "SELECT pg_advisory_xact_lock(7265617964)",
            .dollar = 1},
    .close = pg_close,
    .script = pg_script,
    .begin = pg_begin,
    .commit = pg_commit,
    .rollback = pg_rollback,
    .prepare = pg_prepare,
    .bind_int = pg_bind_int,
    .bind_double = pg_bind_double,
    .bind_text = pg_bind_text,
    .bind_blob = pg_bind_blob,
    .bind_null = pg_bind_null,
    .step = pg_step,
    .changes = pg_changes,
    .is_null = pg_is_null,
    .col_int = pg_col_int,
    .col_double = pg_col_double,
    .col_text = pg_col_text,
    .col_blob = pg_col_blob,
    .finalize = pg_finalize,
    .notify = pg_notify,
    .wait = pg_wait,
};

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
    p->base.drv = &pg_driver;
    p->base.opt = *opt;
    cap_limits(&p->base.opt.limits);
    rd_error_code c = pg_connect(p, err);
    if (!c)
        c = rd_store_migrate(&p->base, err);
    if (c) {
        pg_close(&p->base);
        return NULL;
    }
    return &p->base;
}
