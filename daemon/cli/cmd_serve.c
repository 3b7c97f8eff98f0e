#include <limits.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "server.h"

/* What the command line sets: the server's options and the command's own. */
typedef struct {
    rd_server_options o;
    char host[64];
    double drain_ms;
    const char *port_file;
} serve_args;

typedef enum { K_INT, K_UNSIGNED, K_SIZE, K_DOUBLE, K_STRING, K_LISTEN, K_LOG } flag_kind;

/* One flag of rayd serve: where its value goes, its range, and its help.
 * The help's default is printed from rd_server_options_default unless the
 * row says it in words (dflt). */
typedef struct {
    const char *name, *arg, *help, *dflt;
    flag_kind kind;
    size_t offset;
    unsigned long long lo, hi;
    double scale; /* K_DOUBLE: the value times this (seconds to ms) */
} serve_flag;

#define A(f) offsetof(serve_args, f)
static const serve_flag flags[] = {
    {"--listen", "HOST:PORT", "address to listen on (port 0 picks one)", NULL, K_LISTEN, 0, 0, 65535, 0},
    {"--port-file", "FILE", "write the port listened on to FILE once ready", "none", K_STRING, A(port_file), 0, 0, 0},
    {"--threads", "N", "render threads", "the number of cores", K_INT, A(o.jobs.workers), 1, 1024, 0},
    {"--http-threads", "N", "HTTP threads, at least 2", NULL, K_INT, A(o.http_threads), 2, 256, 0},
    {"--queue", "N", "jobs queued or running at most; more get 503", NULL, K_SIZE, A(o.jobs.queue_length), 1, 1000000,
     0},
    {"--max-body-bytes", "N", "request body limit, answered 413", NULL, K_SIZE, A(o.max_body_bytes), 1, 1ull << 34, 0},
    {"--job-timeout-ms", "N", "a render running longer fails (0 = none)", NULL, K_DOUBLE, A(o.jobs.job_timeout_ms), 0,
     1ull << 40, 1},
    {"--max-connections", "N", "open connections at most", NULL, K_UNSIGNED, A(o.max_connections), 1, 1000000, 0},
    {"--max-per-ip", "N", "open connections per client address", NULL, K_UNSIGNED, A(o.max_per_ip), 1, 1000000, 0},
    {"--connection-timeout", "N", "seconds an idle connection is kept", NULL, K_UNSIGNED, A(o.connection_timeout_s), 1,
     86400, 0},
    {"--header-timeout-ms", "N", "a request's headers must arrive within N ms of its start", NULL, K_DOUBLE,
     A(o.header_timeout_ms), 1, 1ull << 30, 1},
    {"--body-timeout-ms", "N", "its body within N ms of its headers", NULL, K_DOUBLE, A(o.body_timeout_ms), 1,
     1ull << 30, 1},
    {"--max-query-args", "N", "query arguments at most; more get 431", NULL, K_UNSIGNED, A(o.max_query_args), 1, 10000,
     0},
    {"--memory-budget", "N",
     "bytes for running jobs, results and grading caches; a job starts only when it fits, one that never could "
     "gets 413",
     "half the RAM", K_SIZE, A(o.jobs.memory_budget), 1u << 20, 1ull << 50, 0},
    {"--grade-cache-bytes", "N", "grading references and kept grade images", NULL, K_SIZE, A(o.grade_cache_bytes), 0,
     1ull << 40, 0},
    {"--max-jobs-kept", "N", "finished jobs whose status stays readable", NULL, K_SIZE, A(o.jobs.kept_max), 1, 10000000,
     0},
    {"--result-memory", "N", "bytes of finished PNGs kept for /v1/jobs", NULL, K_SIZE, A(o.jobs.result_memory), 0,
     1ull << 40, 0},
    {"--result-ttl", "N", "seconds a finished job stays readable", NULL, K_DOUBLE, A(o.jobs.result_ttl_ms), 0,
     1ull << 30, 1e3},
    {"--drain-ms", "N", "on SIGTERM, how long running renders may finish", NULL, K_DOUBLE, A(drain_ms), 0, 1ull << 30,
     1},
    {"--png-level", "N", "zlib level 0..9 of answers", NULL, K_INT, A(o.jobs.png.level), 0, 9, 0},
    {"--scenes", "DIR", "bundled scenes, and where scenes' files resolve", NULL, K_STRING, A(o.scenes_dir), 0, 0, 0},
    {"--assignments", "DIR", "graded assignments", NULL, K_STRING, A(o.assignments_dir), 0, 0, 0},
    {"--cache-dir", "DIR", "keep grading references on disk too", "memory only", K_STRING, A(o.cache_dir), 0, 0, 0},
    {"--log-format", "text|json", "one line per request on stderr", "text", K_LOG, 0, 0, 0, 0},
};
#undef A

static serve_args defaults(void)
{
    serve_args a;
    memset(&a, 0, sizeof a);
    a.o = rd_server_options_default();
    snprintf(a.host, sizeof a.host, "%s", a.o.listen_host);
    a.o.listen_host = a.host;
    a.drain_ms = 10000;
    return a;
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
    printf("  %-23s ", head);
    int col = INDENT;
    while (*text) {
        size_t word = strcspn(text, " ");
        if (col > INDENT && col + (int)word > WIDTH) {
            printf("\n%*s", INDENT, "");
            col = INDENT;
        }
        printf("%.*s", (int)word, text);
        col += (int)word;
        text += word;
        if (*text == ' ') {
            text++;
            if (*text && col + 1 + (int)strcspn(text, " ") <= WIDTH) {
                putchar(' ');
                col++;
            } else if (*text) {
                printf("\n%*s", INDENT, "");
                col = INDENT;
            }
        }
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
          "the rest are cancelled, every client gets an answer, exit 0.\n\n",
          stdout);
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) {
        const serve_flag *f = &flags[i];
        char head[48], dflt[96];
        snprintf(head, sizeof head, "%s %s", f->name, f->arg);
        if (f->dflt)
            snprintf(dflt, sizeof dflt, "%s", f->dflt);
        else
            default_text(f, &a, dflt, sizeof dflt);
        char line[400];
        snprintf(line, sizeof line, "%s (default %s)", f->help, dflt);
        print_wrapped(head, line);
    }
    fputs("  --limit-...  N          scene size limits, as for 'rayd render' (see 'rayd limits')\n", stdout);
}

static int bad_value(const serve_flag *f, const char *v)
{
    if (f->kind == K_LISTEN)
        fprintf(stderr, "rayd serve: --listen expects HOST:PORT with a port in 0..65535, got '%s'\n", v);
    else if (f->kind == K_LOG)
        fprintf(stderr, "rayd serve: --log-format takes text or json, got '%s'\n", v);
    else
        fprintf(stderr, "rayd serve: %s: expected an integer in %llu..%llu, got '%s'\n", f->name, f->lo, f->hi, v);
    return RD_EXIT_USAGE;
}

/* Stores v for f into a; 0, or the exit status after a message. */
static int set_flag(const serve_flag *f, const char *v, serve_args *a)
{
    char *p = (char *)a + f->offset;
    long lo = (long)f->lo, hi = f->hi > (unsigned long long)LONG_MAX ? LONG_MAX : (long)f->hi, x = 0;
    if (f->kind == K_STRING) {
        *(const char **)p = v;
        return 0;
    }
    if (f->kind == K_LOG) {
        if (strcmp(v, "json") != 0 && strcmp(v, "text") != 0)
            return bad_value(f, v);
        a->o.log_json = strcmp(v, "json") == 0;
        return 0;
    }
    if (f->kind == K_LISTEN) {
        const char *colon = strrchr(v, ':');
        if (!colon || (size_t)(colon - v) >= sizeof a->host || rd_cli_int(colon + 1, lo, hi, &x))
            return bad_value(f, v);
        memcpy(a->host, v, (size_t)(colon - v));
        a->host[colon - v] = 0;
        a->o.port = (uint16_t)x;
        return 0;
    }
    if (rd_cli_int(v, lo, hi, &x))
        return bad_value(f, v);
    switch (f->kind) {
    case K_INT: *(int *)p = (int)x; break;
    case K_UNSIGNED: *(unsigned *)p = (unsigned)x; break;
    case K_SIZE: *(size_t *)p = (size_t)x; break;
    default: *(double *)p = (double)x * f->scale; break;
    }
    return 0;
}

static const serve_flag *find_flag(const char *name)
{
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++)
        if (strcmp(flags[i].name, name) == 0)
            return &flags[i];
    return NULL;
}

enum { HELP_PRINTED = -1 };

/* 0 with *a filled, HELP_PRINTED, or the exit status of a usage error. */
static int parse_args(int argc, char **argv, serve_args *a)
{
    *a = defaults();
    int lrc = rd_cli_take_limits(&argc, argv, &a->o.limits, "rayd serve", NULL);
    if (lrc)
        return lrc;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            print_help();
            return HELP_PRINTED;
        }
        const serve_flag *f = find_flag(argv[i]);
        if (!f) {
            fprintf(stderr, "rayd serve: unknown option '%s' (try 'rayd serve --help')\n", argv[i]);
            return RD_EXIT_USAGE;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "rayd serve: %s needs a value (try 'rayd serve --help')\n", argv[i]);
            return RD_EXIT_USAGE;
        }
        int rc = set_flag(f, argv[++i], a);
        if (rc)
            return rc;
    }
    return 0;
}

int rd_cmd_serve(int argc, char **argv)
{
    serve_args args;
    int prc = parse_args(argc, argv, &args);
    if (prc)
        return prc == HELP_PRINTED ? RD_EXIT_OK : prc;
    rd_server_options o = args.o;
    o.listen_host = args.host;
    const char *host = args.host, *port_file = args.port_file;
    double drain_ms = args.drain_ms;

    /* Block the stop signals in every thread; this one waits for them. */
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    pthread_sigmask(SIG_BLOCK, &set, NULL);
    signal(SIGPIPE, SIG_IGN);

    rd_error err = {0};
    rd_server *srv = rd_server_start(&o, &err);
    if (!srv) {
        fprintf(stderr, "rayd serve: %s\n", err.message);
        return RD_EXIT_IO;
    }
    unsigned port = rd_server_port(srv);
    fprintf(stderr, "rayd serve: listening on http://%s:%u/ (%d render threads, queue %zu, memory budget %zu MiB)\n",
            host, port, o.jobs.workers, o.jobs.queue_length, o.jobs.memory_budget >> 20);
    if (port_file) {
        char tmp[4096];
        snprintf(tmp, sizeof tmp, "%s.tmp", port_file);
        FILE *f = fopen(tmp, "w");
        if (!f || fprintf(f, "%u\n", port) < 0 || fclose(f) != 0 || rename(tmp, port_file) != 0) {
            fprintf(stderr, "rayd serve: cannot write %s\n", port_file);
            rd_server_stop(srv, 0);
            return RD_EXIT_IO;
        }
    }
    int sig = 0;
    sigwait(&set, &sig);
    fprintf(stderr, "rayd serve: %s: draining (up to %.0f ms), then stopping\n", sig == SIGINT ? "SIGINT" : "SIGTERM",
            drain_ms);
    rd_server_stop(srv, drain_ms);
    fprintf(stderr, "rayd serve: stopped\n");
    return RD_EXIT_OK;
}
