#include <ctype.h>
#include <getopt.h>
#include <limits.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "assignment.h"
#include "cli.h"
#include "log.h"
#include "server.h"
#include "version.h"

/* What the command line sets: the server's options and the command's own. */
typedef struct {
    rd_server_options o;
    char host[256];
    double drain_ms;
    const char *port_file, *log_file;
} serve_args;

typedef enum { K_INT, K_UNSIGNED, K_SIZE, K_DOUBLE, K_STRING, K_LISTEN, K_LOG } flag_kind;

/* One flag of rayd serve: where its value goes, its range, and its help.
 * Its environment variable is RAYD_ and the name in capitals. The help's
 * default is printed from the defaults unless the row says it in words. */
typedef struct {
    const char *name, *arg, *help, *dflt;
    flag_kind kind;
    size_t offset;
    unsigned long long lo, hi;
    double scale; /* K_DOUBLE: the value times this (seconds to ms) */
} serve_flag;

#define A(f) offsetof(serve_args, f)
static const serve_flag flags[] = {
    {"listen", "HOST:PORT",
     "address to listen on: 127.0.0.1:8080, [::1]:8080, localhost:8080, :8080 (every address); "
     "port 0 picks one",
     NULL, K_LISTEN, 0, 0, 65535, 0},
    {"port-file", "FILE", "write the port listened on to FILE once ready", "none", K_STRING, A(port_file), 0, 0, 0},
    {"threads", "N", "render threads", "the number of cores", K_INT, A(o.jobs.workers), 1, 1024, 0},
    {"http-threads", "N", "HTTP threads, at least 2", NULL, K_INT, A(o.http_threads), 2, 256, 0},
    {"queue", "N", "jobs queued or running at most; more get 503", NULL, K_SIZE, A(o.jobs.queue_length), 1, 1000000, 0},
    {"max-body-bytes", "N", "request body limit, answered 413", NULL, K_SIZE, A(o.max_body_bytes), 1, 1ull << 34, 0},
    {"job-timeout-ms", "N", "a render running longer fails (0 = none)", NULL, K_DOUBLE, A(o.jobs.job_timeout_ms), 0,
     1ull << 40, 1},
    {"max-connections", "N", "open connections at most", NULL, K_UNSIGNED, A(o.max_connections), 1, 1000000, 0},
    {"max-per-ip", "N", "open connections (with --trust-proxy: requests) per client address", NULL, K_UNSIGNED,
     A(o.max_per_ip), 1, 1000000, 0},
    {"connection-timeout", "N", "seconds an idle connection is kept", NULL, K_UNSIGNED, A(o.connection_timeout_s), 1,
     86400, 0},
    {"header-timeout-ms", "N", "a request's headers must arrive within N ms of its start", NULL, K_DOUBLE,
     A(o.header_timeout_ms), 1, 1ull << 30, 1},
    {"body-timeout-ms", "N", "its body within N ms of its headers", NULL, K_DOUBLE, A(o.body_timeout_ms), 1, 1ull << 30,
     1},
    {"max-query-args", "N", "query arguments at most; more get 431", NULL, K_UNSIGNED, A(o.max_query_args), 1, 10000,
     0},
    {"memory-budget", "N",
     "bytes for running jobs, results and grading caches; a job starts only when it fits, one that never could "
     "gets 413",
     "half the RAM", K_SIZE, A(o.jobs.memory_budget), 1u << 20, 1ull << 50, 0},
    {"grade-cache-bytes", "N", "grading references and kept grade images", NULL, K_SIZE, A(o.grade_cache_bytes), 0,
     1ull << 40, 0},
    {"max-jobs-kept", "N", "finished jobs whose status stays readable", NULL, K_SIZE, A(o.jobs.kept_max), 1, 10000000,
     0},
    {"result-memory", "N", "bytes of finished images kept for /v1/jobs", NULL, K_SIZE, A(o.jobs.result_memory), 0,
     1ull << 40, 0},
    {"result-ttl", "N", "seconds a finished job stays readable", NULL, K_DOUBLE, A(o.jobs.result_ttl_ms), 0, 1ull << 30,
     1e3},
    {"drain-ms", "N", "on SIGTERM, how long running renders may finish", NULL, K_DOUBLE, A(drain_ms), 0, 1ull << 30, 1},
    {"data-dir", "DIR", "the job store: POST /v1/jobs is answered once committed here (SQLite, created if missing)",
     NULL, K_STRING, A(o.data_dir), 0, 0, 0},
    {"store", "URL",
     "keep jobs in PostgreSQL instead (postgresql://... or a libpq conninfo): every daemon on one database shares "
     "the queue and renders big jobs together",
     "SQLite in --data-dir", K_STRING, A(o.store), 0, 0, 0},
    {"lease-ms", "N", "a stored job's tile is given to another daemon N ms after its daemon stops renewing", NULL,
     K_INT, A(o.lease_ms), 100, 86400000, 0},
    {"daemon-id", "ID", "this daemon's name in the store's leases, unique among daemons sharing a store",
     "HOSTNAME:PORT", K_STRING, A(o.daemon_id), 0, 0, 0},
    {"instructor-tokens", "FILE",
     "instructors' bearer tokens, one a line: they open grade records, exports and batches (off: 404); SIGHUP "
     "reads the file again",
     "off", K_STRING, A(o.instructor_tokens), 0, 0, 0},
    {"roster", "FILE",
     "the class's roster, CSV with a header naming student (and name, email): the tables list who has not "
     "submitted, and the gradebook has a row for each; read again for every table",
     "none", K_STRING, A(o.roster), 0, 0, 0},
    {"grade-ttl", "N", "seconds grade records are kept", NULL, K_DOUBLE, A(o.grade_ttl_ms), 1, 1ull << 34, 1e3},
    {"max-batch-images", "N", "images in one grading batch", NULL, K_SIZE, A(o.max_batch_images), 1, 100000, 0},
    {"max-batch-bytes", "N", "a grading batch's form or archive; each image at most --max-body-bytes", NULL, K_SIZE,
     A(o.max_batch_bytes), 1, 1ull << 36, 0},
    {"max-batch-expanded", "N", "bytes a batch's archive may decompress to", NULL, K_SIZE, A(o.max_batch_expanded), 1,
     1ull << 38, 0},
    {"store-tile", "PX", "tile edge of stored jobs: the grain daemons share a job in", NULL, K_INT, A(o.store_tile), 8,
     256, 0},
    {"png-level", "N", "zlib level 0..9 of answers", NULL, K_INT, A(o.jobs.png.level), 0, 9, 0},
    {"scenes", "DIR", "bundled scenes, and where scenes' files resolve", NULL, K_STRING, A(o.scenes_dir), 0, 0, 0},
    {"assignments", "DIR", "graded assignments", NULL, K_STRING, A(o.assignments_dir), 0, 0, 0},
    {"cache-dir", "DIR", "keep grading references on disk too (created if missing)", "memory only", K_STRING,
     A(o.cache_dir), 0, 0, 0},
    {"bwrap", "PATH", "bubblewrap, the code grader's sandbox (POST /v1/grade/code is 503 when it cannot start)", NULL,
     K_STRING, A(o.bwrap), 0, 0, 0},
    {"course", "DIR", "the course's headers, skeletons and adapter for grading code", NULL, K_STRING, A(o.course_dir),
     0, 0, 0},
    {"code-eval", "PATH", "the code grader's evaluator (rayd-eval)", NULL, K_STRING, A(o.code_eval), 0, 0, 0},
    {"max-code-bytes", "N", "an uploaded source file for POST /v1/grade/code", NULL, K_SIZE, A(o.max_code_bytes), 1,
     1u << 24, 0},
    {"max-code-jobs", "N", "code grades running at once, each a sandbox on a render thread; more get 503", NULL, K_INT,
     A(o.max_code_jobs), 1, 1024, 0},
    {"max-code-jobs-per-client", "N",
     "of those, one client's at once (its address, or the client a --trust-proxy names); more get 429", NULL, K_INT,
     A(o.max_code_jobs_per_client), 1, 1024, 0},
    {"code-compile-seconds", "N", "the compiler's time for one code grade", NULL, K_DOUBLE, A(o.code_compile_ms), 1,
     3600, 1e3},
    {"code-run-seconds", "N", "the student's function's time for one code grade, all calls", NULL, K_DOUBLE,
     A(o.code_run_ms), 1, 3600, 1e3},
    {"sandbox-uid", "N", "the sandbox's uid and gid when rayd runs as root", NULL, K_UNSIGNED, A(o.sandbox_uid), 1,
     4294967294u, 0},
    {"log-format", "text|json", "log lines on stderr (start-up, requests, warnings, stop)", "text", K_LOG, 0, 0, 0, 0},
    {"log-file", "FILE", "append the log to FILE instead of stderr; SIGHUP reopens it", "stderr", K_STRING, A(log_file),
     0, 0, 0},
    {"trust-proxy", "ADDRS", "comma-separated proxy addresses whose X-Forwarded-For names the client", "none", K_STRING,
     A(o.trust_proxy), 0, 0, 0},
    {"cors-origin", "ORIGIN", "allow browsers on ORIGIN (or *) to call the API (CORS)", "none", K_STRING,
     A(o.cors_origin), 0, 0, 0},
};
#undef A
enum { NFLAGS = sizeof flags / sizeof flags[0] };

/* An installed rayd's store when --data-dir is not given: the service's
 * state folder (systemd's StateDirectory= sets STATE_DIRECTORY, a
 * colon-separated list whose first is this unit's), else the user's
 * ($XDG_STATE_HOME/rayd, which the XDG base directory rules take only when
 * absolute, else ~/.local/state/rayd). Grade records are the students':
 * they must not land in whatever folder the daemon happened to start in.
 * build/rayd keeps var/ of the folder it runs in (make run: the tree's).
 * A static buffer: read once, at start. */
static const char *default_data_dir(void)
{
    static char dir[PATH_MAX];
    if (!rd_installed())
        return "var";
    const char *state = getenv("STATE_DIRECTORY"), *xdg = getenv("XDG_STATE_HOME"), *home = getenv("HOME");
    int n = -1;
    if (state && state[0] == '/')
        n = snprintf(dir, sizeof dir, "%.*s", (int)strcspn(state, ":"), state);
    else if (xdg && xdg[0] == '/')
        n = snprintf(dir, sizeof dir, "%s/rayd", xdg);
    else if (home && home[0] == '/')
        n = snprintf(dir, sizeof dir, "%s/.local/state/rayd", home);
    return n > 0 && (size_t)n < sizeof dir ? dir : "var";
}

static serve_args defaults(void)
{
    serve_args a;
    memset(&a, 0, sizeof a);
    a.o = rd_server_options_default();
    a.o.data_dir = default_data_dir();
    snprintf(a.host, sizeof a.host, "%s", a.o.listen_host);
    a.drain_ms = 10000;
    return a;
}

/* RAYD_ and the flag's name in capitals, '-' as '_'. */
static void env_name(const char *flag, char *buf, size_t size)
{
    size_t n = (size_t)snprintf(buf, size, "RAYD_");
    for (; *flag && n + 1 < size; flag++)
        buf[n++] = *flag == '-' ? '_' : (char)toupper((unsigned char)*flag);
    buf[n] = 0;
}

/* The default of a flag as its value would be written. */
static void default_text(const serve_flag *f, const serve_args *a, char *buf, size_t size)
{
    const char *p = (const char *)a + f->offset;
    switch (f->kind) {
    case K_INT: snprintf(buf, size, "%d", *(const int *)p); break;
    case K_UNSIGNED: snprintf(buf, size, "%u", *(const unsigned *)p); break;
    case K_SIZE: snprintf(buf, size, "%zu", *(const size_t *)p); break;
    case K_DOUBLE: snprintf(buf, size, "%.0f", *(const double *)p / f->scale); break;
    case K_STRING: snprintf(buf, size, "%s", *(const char *const *)p ? *(const char *const *)p : "none"); break;
    case K_LISTEN: snprintf(buf, size, "%s:%u", a->host, (unsigned)a->o.port); break;
    case K_LOG: buf[0] = 0; break;
    }
}

/* "  HEAD   TEXT", TEXT wrapped at 100 columns under itself. */
static void print_wrapped(const char *head, const char *text)
{
    enum { INDENT = 26, WIDTH = 100 };
    printf("  %-23s%s", head, strlen(head) > 23 ? "\n                          " : " ");
    int col = INDENT;
    while (*text) {
        size_t word = strcspn(text, " ");
        if (col > INDENT && col + 1 + (int)word > WIDTH) {
            printf("\n%*s", INDENT, "");
            col = INDENT;
        } else if (col > INDENT) {
            putchar(' ');
            col++;
        }
        printf("%.*s", (int)word, text);
        col += (int)word;
        text += word;
        text += strspn(text, " ");
    }
    putchar('\n');
}

static void print_help(void)
{
    serve_args a = defaults();
    fputs("usage: rayd serve [options]\n\n"
          "Runs the HTTP render service (see docs/http-api.md): POST a cfg or JSON scene\n"
          "to /v1/render for a PNG, or to /v1/jobs for a job to poll. SIGTERM or SIGINT\n"
          "stops it gracefully: no new work, running renders finish (up to --drain-ms),\n"
          "the rest are cancelled, every client gets an answer, exit 0. SIGHUP reopens\n"
          "the log file and reads the instructor tokens and the assignments again.\n\n"
          "Every option can also be given as an environment variable, named after it\n"
          "(--threads: RAYD_THREADS); an option on the command line wins. --opt=VALUE\n"
          "and --opt VALUE are the same.\n\n",
          stdout);
    for (size_t i = 0; i < NFLAGS; i++) {
        const serve_flag *f = &flags[i];
        char head[64], dflt[600], env[64], line[1200];
        snprintf(head, sizeof head, "--%s %s", f->name, f->arg);
        /* The store's default in words: the man page is made from this
         * text, and the path of whoever ran help2man is no one's default. */
        if (f->offset == offsetof(serve_args, o.data_dir) && rd_installed())
            snprintf(dflt, sizeof dflt, "%s",
                     "$STATE_DIRECTORY under systemd, else $XDG_STATE_HOME/rayd, else ~/.local/state/rayd");
        else if (f->dflt)
            snprintf(dflt, sizeof dflt, "%s", f->dflt);
        else
            default_text(f, &a, dflt, sizeof dflt);
        env_name(f->name, env, sizeof env);
        snprintf(line, sizeof line, "%s (default %s; %s)", f->help, dflt, env);
        print_wrapped(head, line);
    }
    print_wrapped("--limit-... N", "scene size limits, as for 'rayd render' (see 'rayd limits'); RAYD_LIMIT_...");
}

static int bad_value(const serve_flag *f, const char *v, const char *from)
{
    if (f->kind == K_LISTEN)
        fprintf(stderr,
                "rayd serve: %s: expected HOST:PORT, [IPV6]:PORT or :PORT with a port in 0..65535 and a host "
                "that resolves, got '%s'\n",
                from, v);
    else if (f->kind == K_LOG)
        fprintf(stderr, "rayd serve: %s takes text or json, got '%s'\n", from, v);
    else
        fprintf(stderr, "rayd serve: %s: expected an integer in %llu..%llu, got '%s'\n", from, f->lo, f->hi, v);
    return RD_EXIT_USAGE;
}

/* HOST:PORT, [V6]:PORT or :PORT into a->host and a->o.port, checked by
 * resolving it as the server will. */
static int set_listen(const char *v, serve_args *a)
{
    const char *colon = strrchr(v, ':');
    long port = 0;
    if (!colon || rd_cli_int(colon + 1, 0, 65535, &port))
        return 1;
    const char *h = v;
    size_t n = (size_t)(colon - v);
    if (n >= 2 && h[0] == '[' && h[n - 1] == ']') {
        h++;
        n -= 2;
    } else if (memchr(h, ':', n)) {
        return 1; /* an IPv6 address needs its brackets */
    }
    if (n >= sizeof a->host)
        return 1;
    memcpy(a->host, h, n);
    a->host[n] = 0;
    a->o.port = (uint16_t)port;
    rd_listen_addr addr;
    rd_error err = {0};
    return rd_listen_resolve(a->host, a->o.port, &addr, &err) != RD_OK;
}

/* Stores v for f into a; 0, or the exit status after a message naming
 * where the value came from. */
static int set_flag(const serve_flag *f, const char *v, serve_args *a, const char *from)
{
    char *p = (char *)a + f->offset;
    long lo = (long)f->lo, hi = f->hi > (unsigned long long)LONG_MAX ? LONG_MAX : (long)f->hi, x = 0;
    switch (f->kind) {
    case K_STRING: *(const char **)p = v; return 0;
    case K_LOG:
        if (strcmp(v, "json") != 0 && strcmp(v, "text") != 0)
            return bad_value(f, v, from);
        a->o.log_json = strcmp(v, "json") == 0;
        return 0;
    case K_LISTEN: return set_listen(v, a) ? bad_value(f, v, from) : 0;
    default: break;
    }
    if (rd_cli_int(v, lo, hi, &x))
        return bad_value(f, v, from);
    switch (f->kind) {
    case K_INT: *(int *)p = (int)x; break;
    case K_UNSIGNED: *(unsigned *)p = (unsigned)x; break;
    case K_SIZE: *(size_t *)p = (size_t)x; break;
    default: *(double *)p = (double)x * f->scale; break;
    }
    return 0;
}

/* The environment first, so that the command line wins. */
static int take_env(serve_args *a)
{
    for (size_t i = 0; i < NFLAGS; i++) {
        char env[64];
        env_name(flags[i].name, env, sizeof env);
        const char *v = getenv(env);
        int rc = v ? set_flag(&flags[i], v, a, env) : 0;
        if (rc)
            return rc;
    }
    return rd_cli_limits_from_env(&a->o.limits, "rayd serve");
}

enum { HELP_PRINTED = -1 };

static int take_argv(int argc, char **argv, serve_args *a)
{
    struct option opts[NFLAGS + 2];
    for (size_t i = 0; i < NFLAGS; i++)
        opts[i] = (struct option){flags[i].name, required_argument, NULL, (int)i + 256};
    opts[NFLAGS] = (struct option){"help", no_argument, NULL, 'h'};
    opts[NFLAGS + 1] = (struct option){0, 0, 0, 0};
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        if (c == 'h') {
            print_help();
            return HELP_PRINTED;
        }
        if (c == '?' || c == ':') {
            fprintf(stderr, "rayd serve: %s '%s' (try 'rayd serve --help')\n",
                    c == ':' ? "this option needs a value:" : "unknown option", argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
        const serve_flag *f = &flags[c - 256];
        char from[64];
        snprintf(from, sizeof from, "--%s", f->name);
        int rc = set_flag(f, optarg, a, from);
        if (rc)
            return rc;
    }
    if (optind < argc) {
        fprintf(stderr, "rayd serve: unexpected argument '%s' (try 'rayd serve --help')\n", argv[optind]);
        return RD_EXIT_USAGE;
    }
    return 0;
}

/* 0 with *a filled, HELP_PRINTED, or the exit status of a usage error. */
static int parse_args(int argc, char **argv, serve_args *a)
{
    *a = defaults();
    int rc = take_env(a);
    if (!rc)
        rc = rd_cli_take_limits(&argc, argv, &a->o.limits, "rayd serve", NULL);
    return rc ? rc : take_argv(argc, argv, a);
}

static int write_port_file(const char *path, unsigned port)
{
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    int ok = f && fprintf(f, "%u\n", port) >= 0;
    if (f && fclose(f) != 0)
        ok = 0;
    return ok && rename(tmp, path) == 0;
}

/* Logs what the assignments folder holds: at start and on SIGHUP. */
static void log_assignments(rd_log *log, const char *dir, const char *when)
{
    rd_assignment *list = NULL;
    size_t n = 0;
    rd_error err = {0};
    if (rd_assignment_list(dir, &list, &n, &err)) {
        rd_log_msg(log, "warning", "%s assignments in %s: %s", when, dir, err.message);
        return;
    }
    char names[1024] = "";
    size_t good = 0;
    for (size_t i = 0; i < n; i++) {
        if (list[i].error[0]) {
            rd_log_msg(log, "warning", "%s assignment %s cannot be graded: %s", when, list[i].name, list[i].error);
            continue;
        }
        snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", good++ ? "," : "", list[i].name);
    }
    free(list);
    cJSON *fields = cJSON_CreateObject();
    cJSON_AddNumberToObject(fields, "assignments", (double)good);
    cJSON_AddStringToObject(fields, "dir", dir);
    cJSON_AddStringToObject(fields, "names", names);
    rd_log_event(log, "info", when, fields);
}

static void log_listening(rd_log *log, const serve_args *a, const rd_server *srv)
{
    const rd_server_options *o = &a->o;
    unsigned port = rd_server_port(srv);
    int v6 = strchr(a->host, ':') != NULL;
    char url[320], msg[1200], store[600];
    snprintf(url, sizeof url, "http://%s%s%s:%u/", v6 ? "[" : "", a->host[0] ? a->host : "0.0.0.0", v6 ? "]" : "",
             port);
    /* A PostgreSQL URL may hold a password: the log names the engine only. */
    if (o->store && *o->store)
        snprintf(store, sizeof store, "postgresql");
    else
        snprintf(store, sizeof store, "sqlite in %.500s", o->data_dir);
    snprintf(msg, sizeof msg,
             "rayd %s listening on %s (%d render threads, queue %zu, memory budget %zu MiB, jobs stored in %s as %s)",
             rd_version(), url, o->jobs.workers, o->jobs.queue_length, o->jobs.memory_budget >> 20, store,
             rd_server_daemon_id(srv));
    cJSON *fields = cJSON_CreateObject();
    cJSON_AddStringToObject(fields, "version", rd_version());
    cJSON_AddStringToObject(fields, "url", url);
    cJSON_AddNumberToObject(fields, "port", port);
    cJSON_AddNumberToObject(fields, "threads", o->jobs.workers);
    cJSON_AddStringToObject(fields, "scenes", o->scenes_dir);
    cJSON_AddStringToObject(fields, "assignments", o->assignments_dir);
    cJSON_AddStringToObject(fields, "store", store);
    cJSON_AddStringToObject(fields, "daemon_id", rd_server_daemon_id(srv));
    if (!rd_log_is_json(log)) {
        cJSON_Delete(fields);
        fields = NULL;
    }
    rd_log_event(log, "info", msg, fields);
}

/* Until SIGTERM or SIGINT; SIGHUP reopens the log and re-reads the tokens and the
 * assignments. Returns the stopping signal. */
static int wait_for_stop(rd_log *log, const sigset_t *set, const char *assignments, rd_server *srv, const char *tokens)
{
    for (;;) {
        int sig = 0;
        sigwait(set, &sig);
        if (sig != SIGHUP)
            return sig;
        rd_error err = {0};
        if (rd_log_reopen(log, &err))
            rd_log_msg(log, "error", "SIGHUP: %s", err.message);
        rd_log_msg(log, "info", "SIGHUP: log reopened");
        /* Before the assignments' line, which the log's readers (and the
         * tests) take as the end of the reload. */
        int n = rd_server_reload_tokens(srv, &err);
        if (n >= 0)
            rd_log_msg(log, "info", "SIGHUP: instructor tokens read again from %s: %d token%s", tokens, n,
                       n == 1 ? "" : "s");
        else if (n == -2)
            rd_log_msg(log, "error", "SIGHUP: %s; the tokens read before stay", err.message);
        log_assignments(log, assignments, "SIGHUP: reloaded");
    }
}

static int serve(serve_args *args, rd_log *log)
{
    rd_server_options o = args->o;
    o.listen_host = args->host;
    o.log = log;
    rd_error err = {0};
    rd_server *srv = rd_server_start(&o, &err);
    if (!srv) {
        rd_log_msg(log, "error", "%s", err.message);
        return RD_EXIT_IO;
    }
    unsigned port = rd_server_port(srv);
    log_listening(log, args, srv);
    log_assignments(log, o.assignments_dir, "loaded");
    if (args->port_file && !write_port_file(args->port_file, port)) {
        rd_log_msg(log, "error", "cannot write %s", args->port_file);
        rd_server_stop(srv, 0);
        return RD_EXIT_IO;
    }
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGHUP);
    int sig = wait_for_stop(log, &set, o.assignments_dir, srv, o.instructor_tokens);
    rd_log_msg(log, "info", "%s: draining (up to %.0f ms), then stopping", sig == SIGINT ? "SIGINT" : "SIGTERM",
               args->drain_ms);
    rd_server_stop(srv, args->drain_ms);
    rd_log_msg(log, "info", "stopped");
    return RD_EXIT_OK;
}

int rd_cmd_serve(int argc, char **argv)
{
    serve_args args;
    int prc = parse_args(argc, argv, &args);
    if (prc)
        return prc == HELP_PRINTED ? RD_EXIT_OK : prc;
    /* Block the stop signals in every thread; this one waits for them. */
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &set, NULL);
    signal(SIGPIPE, SIG_IGN);
    rd_error err = {0};
    rd_log *log = rd_log_open(args.log_file, args.o.log_json, &err);
    if (!log) {
        fprintf(stderr, "rayd serve: %s\n", err.message);
        return RD_EXIT_IO;
    }
    int rc = serve(&args, log);
    rd_log_free(log);
    return rc;
}
