/* The store in SQLite: one file, rayd.sqlite3, in WAL mode (readers do not
 * wait for the writer) with a busy timeout. Every write is one BEGIN
 * IMMEDIATE transaction: it takes the file's write lock first, so two
 * handles (threads or processes) never interleave a claim, and a busy store
 * is known before anything is done. That single writer is why this dialect
 * needs no row locks. The store's clock is this machine's: @NOW@ is
 * rayd_now(), read once when a statement is prepared, as PostgreSQL reads
 * its own once a statement. */
#include <errno.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "rayd/clock.h"
#include "store_internal.h"

typedef struct {
    rd_store base;
    sqlite3 *db;
    long long data_version; /* PRAGMA data_version when last looked at (wait) */
    int64_t now_ms;         /* rayd_now() of the statement prepared last */
} sq_store;

struct rd_store_stmt {
    sq_store *q;
    sqlite3_stmt *st;
    int rc; /* the first failed bind's, told by step */
};

static sq_store *sq(rd_store *s) { return (sq_store *)s; }

/* The one mapping of SQLite's result codes to the store's. */
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
    return rd_error_set(err, c, 0, 0, "store: %s: %s%s", what,
                        c == RD_ERR_DAMAGED   ? "the database is damaged: "
                        : c == RD_ERR_NOSPACE ? "no space left: "
                                              : "",
                        q->db ? sqlite3_errmsg(q->db) : sqlite3_errstr(rc));
}

static rd_error_code sq_exec(sq_store *q, const char *sql, const char *what, rd_error *err)
{
    int rc = sqlite3_exec(q->db, sql, NULL, NULL, NULL);
    return rc == SQLITE_OK ? RD_OK : sq_fail(q, rc, what, err);
}

static rd_error_code sq_script(rd_store *s, const char *sql, const char *what, rd_error *err)
{
    return sq_exec(sq(s), sql, what, err);
}

static rd_error_code sq_begin(rd_store *s, rd_error *err)
{
    return sq_exec(sq(s), "BEGIN IMMEDIATE", "beginning a transaction", err);
}

/* Unless SQLite has rolled back already. */
static void sq_rollback(rd_store *s)
{
    if (!sqlite3_get_autocommit(sq(s)->db))
        sqlite3_exec(sq(s)->db, "ROLLBACK", NULL, NULL, NULL);
}

static rd_error_code sq_commit(rd_store *s, rd_error *err)
{
    rd_error_code c = sq_exec(sq(s), "COMMIT", "committing", err);
    if (c)
        sq_rollback(s);
    return c;
}

static void sq_now(sqlite3_context *cx, int argc, sqlite3_value **argv)
{
    (void)argc;
    (void)argv;
    sqlite3_result_int64(cx, ((sq_store *)sqlite3_user_data(cx))->now_ms);
}

static rd_error_code sq_prepare(rd_store *s, const char *sql, rd_store_stmt **out, rd_error *err)
{
    sq_store *q = sq(s);
    rd_store_stmt *st = calloc(1, sizeof *st);
    if (!st)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "store: no memory for a statement");
    st->q = q;
    q->now_ms = rd_wall_ms();
    int rc = sqlite3_prepare_v2(q->db, sql, -1, &st->st, NULL);
    if (rc != SQLITE_OK) {
        free(st);
        return sq_fail(q, rc, "preparing a statement", err);
    }
    *out = st;
    return RD_OK;
}

static void sq_bind_int(rd_store_stmt *st, int i, int64_t v)
{
    if (!st->rc)
        st->rc = sqlite3_bind_int64(st->st, i, v);
}

static void sq_bind_double(rd_store_stmt *st, int i, double v)
{
    if (!st->rc)
        st->rc = sqlite3_bind_double(st->st, i, v);
}

static void sq_bind_text(rd_store_stmt *st, int i, const char *t)
{
    if (!st->rc)
        st->rc = t ? sqlite3_bind_text(st->st, i, t, -1, SQLITE_STATIC) : sqlite3_bind_null(st->st, i);
}

/* Zero bytes are an empty blob, not NULL. */
static void sq_bind_blob(rd_store_stmt *st, int i, const void *data, size_t len)
{
    if (!st->rc)
        st->rc = len ? sqlite3_bind_blob64(st->st, i, data, len, SQLITE_STATIC) : sqlite3_bind_zeroblob(st->st, i, 0);
}

static void sq_bind_null(rd_store_stmt *st, int i)
{
    if (!st->rc)
        st->rc = sqlite3_bind_null(st->st, i);
}

static int sq_step(rd_store_stmt *st, rd_error *err)
{
    if (st->rc)
        return -(int)sq_fail(st->q, st->rc, "preparing a statement", err);
    int rc = sqlite3_step(st->st);
    if (rc == SQLITE_ROW)
        return 1;
    if (rc == SQLITE_DONE)
        return 0;
    return -(int)sq_fail(st->q, rc, sqlite3_stmt_readonly(st->st) ? "reading" : "writing", err);
}

static int sq_changes(rd_store_stmt *st) { return sqlite3_changes(st->q->db); }

static int sq_is_null(rd_store_stmt *st, int col) { return sqlite3_column_type(st->st, col) == SQLITE_NULL; }

static int64_t sq_col_int(rd_store_stmt *st, int col) { return sqlite3_column_int64(st->st, col); }

static double sq_col_double(rd_store_stmt *st, int col) { return sqlite3_column_double(st->st, col); }

static const char *sq_col_text(rd_store_stmt *st, int col) { return (const char *)sqlite3_column_text(st->st, col); }

static const void *sq_col_blob(rd_store_stmt *st, int col, size_t *len)
{
    const void *data = sqlite3_column_blob(st->st, col);
    *len = (size_t)sqlite3_column_bytes(st->st, col);
    return data;
}

static void sq_finalize(rd_store_stmt *st)
{
    if (st)
        sqlite3_finalize(st->st);
    free(st);
}

/* The first column of a one-row PRAGMA, as text into buf (may be NULL)
 * and as a number into *v (may be NULL). */
static rd_error_code sq_pragma(sq_store *q, const char *sql, char *buf, size_t size, long long *v, rd_error *err)
{
    sqlite3_stmt *st;
    int rc = sqlite3_prepare_v2(q->db, sql, -1, &st, NULL);
    if (rc == SQLITE_OK && (rc = sqlite3_step(st)) == SQLITE_ROW) {
        if (buf)
            snprintf(buf, size, "%s", sqlite3_column_text(st, 0) ? (const char *)sqlite3_column_text(st, 0) : "");
        if (v)
            *v = sqlite3_column_int64(st, 0);
    }
    sqlite3_finalize(st);
    return rc == SQLITE_ROW || rc == SQLITE_DONE ? RD_OK : sq_fail(q, rc, sql, err);
}

/* One process, one file: nothing to listen to, so it looks at
 * data_version, which moves with every other connection's commit. */
static rd_error_code sq_wait(rd_store *s, int timeout_ms, rd_store_event *ev, rd_error *err)
{
    sq_store *q = sq(s);
    for (int waited = 0;; waited += 10) {
        long long v = 0;
        pthread_mutex_lock(&s->lock);
        rd_error_code c = sq_pragma(q, "PRAGMA data_version", NULL, 0, &v, err);
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

static void sq_close(rd_store *s)
{
    sqlite3_close(sq(s)->db);
    free(s);
}

static const rd_store_driver sq_driver = {
    .name = "sqlite",
    .sql = {.now = "rayd_now()", .blob = "BLOB"},
    .close = sq_close,
    .script = sq_script,
    .begin = sq_begin,
    .commit = sq_commit,
    .rollback = sq_rollback,
    .prepare = sq_prepare,
    .bind_int = sq_bind_int,
    .bind_double = sq_bind_double,
    .bind_text = sq_bind_text,
    .bind_blob = sq_bind_blob,
    .bind_null = sq_bind_null,
    .step = sq_step,
    .changes = sq_changes,
    .is_null = sq_is_null,
    .col_int = sq_col_int,
    .col_double = sq_col_double,
    .col_text = sq_col_text,
    .col_blob = sq_col_blob,
    .finalize = sq_finalize,
    .wait = sq_wait,
};

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
    rd_error_code c = sq_pragma(q, "PRAGMA journal_mode = WAL", mode, sizeof mode, NULL, err);
    if (c)
        return c;
    if (strcmp(mode, "wal") != 0)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "store: %s cannot be in WAL mode (journal mode %s)",
                            sqlite3_db_filename(q->db, "main"), mode[0] ? mode : "unknown");
    c = sq_exec(q, sync_full ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL", "setting up", err);
    if (!c)
        c = sq_exec(q, "PRAGMA foreign_keys = ON", "setting up", err);
    if (!c && sqlite3_create_function_v2(q->db, "rayd_now", 0, SQLITE_UTF8 | SQLITE_DETERMINISTIC | SQLITE_DIRECTONLY,
                                         q, sq_now, NULL, NULL, NULL) != SQLITE_OK)
        c = sq_fail(q, sqlite3_errcode(q->db), "setting up", err);
    return c;
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
    int r = sqlite3_prepare_v2(q->db, "PRAGMA quick_check(1)", -1, &st, NULL);
    rd_error_code c = r == SQLITE_OK ? RD_OK : sq_fail(q, r, "preparing a statement", err);
    r = c ? 0 : sqlite3_step(st);
    const char *says = r == SQLITE_ROW ? (const char *)sqlite3_column_text(st, 0) : NULL;
    if (r == SQLITE_ROW && strcmp(says ? says : "", "ok") != 0)
        c = rd_error_set(err, RD_ERR_DAMAGED, 0, 0, "store: %s is damaged (PRAGMA quick_check: %.300s)",
                         sqlite3_db_filename(q->db, "main"), says ? says : "");
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
    q->base.drv = &sq_driver;
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
        c = rd_store_migrate(&q->base, err);
    if (!c)
        c = sq_pragma(q, "PRAGMA data_version", NULL, 0, &q->data_version, err);
    if (c) {
        sq_close(&q->base);
        return NULL;
    }
    return &q->base;
}
