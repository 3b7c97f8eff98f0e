#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "server.h"

static const char serve_help[] =
    "usage: rayd serve [options]\n"
    "\n"
    "Runs the HTTP render service (see docs/http-api.md): POST a cfg or JSON scene\n"
    "to /v1/render for a PNG, or to /v1/jobs for a job to poll. SIGTERM or SIGINT\n"
    "stops it gracefully: no new work, running renders finish (up to --drain-ms),\n"
    "the rest are cancelled, every client gets an answer, exit 0.\n"
    "\n"
    "  --listen HOST:PORT      address to listen on (default 127.0.0.1:8080; port 0 picks one)\n"
    "  --port-file FILE        write the port listened on to FILE once ready\n"
    "  --threads N             render threads (default: the number of cores)\n"
    "  --http-threads N        HTTP threads, at least 2 (default 2)\n"
    "  --queue N               jobs queued or running at most; more get 503 (default 64)\n"
    "  --max-body-bytes N      request body limit, answered 413 (default 16777216)\n"
    "  --job-timeout-ms N      a render running longer fails (default 120000; 0 = none)\n"
    "  --max-connections N     open connections at most (default 1024)\n"
    "  --max-per-ip N          open connections per client address (default 512)\n"
    "  --connection-timeout N  seconds an idle connection is kept (default 30)\n"
    "  --header-timeout-ms N   a request's headers must arrive within N ms of its start (default 10000)\n"
    "  --body-timeout-ms N     its body within N ms of its headers (default 60000)\n"
    "  --max-query-args N      query arguments at most; more get 431 (default 64)\n"
    "  --memory-budget N       bytes for running jobs, results and grading caches; a job starts only\n"
    "                          when it fits, one that never could gets 413 (default: half the RAM)\n"
    "  --grade-cache-bytes N   grading references and kept grade images (default 268435456)\n"
    "  --max-jobs-kept N       finished jobs whose status stays readable (default 4096)\n"
    "  --result-memory N       bytes of finished PNGs kept for /v1/jobs (default 268435456)\n"
    "  --result-ttl N          seconds a finished job stays readable (default 600)\n"
    "  --drain-ms N            on SIGTERM, how long running renders may finish (default 10000)\n"
    "  --png-level N           zlib level 0..9 of answers (default 1)\n"
    "  --scenes DIR            bundled scenes, and where scenes' files resolve (default scenes)\n"
    "  --assignments DIR       graded assignments (default scenes/assignments)\n"
    "  --cache-dir DIR         keep grading references on disk too (default: memory only)\n"
    "  --log-format text|json  one line per request on stderr (default text)\n"
    "  --max-...  N            scene size limits, as for 'rayd render' (see 'rayd limits')\n";

static int parse_size(const char *flag, const char *v, unsigned long long lo, unsigned long long hi,
                      unsigned long long *out)
{
    char *end;
    errno = 0;
    unsigned long long x = v && *v && *v != '-' ? strtoull(v, &end, 10) : 0;
    if (!v || !*v || *v == '-' || *end || errno || x < lo || x > hi) {
        fprintf(stderr, "rayd serve: %s: expected an integer in %llu..%llu, got '%s'\n", flag, lo, hi, v ? v : "");
        return 1;
    }
    *out = x;
    return 0;
}

int rd_cmd_serve(int argc, char **argv)
{
    rd_server_options o = rd_server_options_default();
    char host[64] = "127.0.0.1";
    o.listen_host = host;
    double drain_ms = 10000;
    const char *port_file = NULL;

    int lrc = rd_cli_take_limits(&argc, argv, &o.limits, "rayd serve");
    if (lrc)
        return lrc;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        unsigned long long x;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(serve_help, stdout);
            return RD_EXIT_OK;
        }
        if (!v) {
            fprintf(stderr, "rayd serve: %s needs a value (try 'rayd serve --help')\n", a);
            return RD_EXIT_USAGE;
        }
        i++;
        if (strcmp(a, "--listen") == 0) {
            const char *colon = strrchr(v, ':');
            if (!colon || (size_t)(colon - v) >= sizeof host || parse_size("--listen port", colon + 1, 0, 65535, &x))
                return fprintf(stderr, "rayd serve: --listen expects HOST:PORT, got '%s'\n", v), RD_EXIT_USAGE;
            memcpy(host, v, (size_t)(colon - v));
            host[colon - v] = 0;
            o.port = (uint16_t)x;
        } else if (strcmp(a, "--port-file") == 0) {
            port_file = v;
        } else if (strcmp(a, "--threads") == 0) {
            if (parse_size(a, v, 1, 1024, &x))
                return RD_EXIT_USAGE;
            o.jobs.workers = (int)x;
        } else if (strcmp(a, "--http-threads") == 0) {
            if (parse_size(a, v, 2, 256, &x))
                return RD_EXIT_USAGE;
            o.http_threads = (int)x;
        } else if (strcmp(a, "--queue") == 0) {
            if (parse_size(a, v, 1, 1000000, &x))
                return RD_EXIT_USAGE;
            o.jobs.queue_length = x;
        } else if (strcmp(a, "--max-body-bytes") == 0) {
            if (parse_size(a, v, 1, 1ull << 34, &x))
                return RD_EXIT_USAGE;
            o.max_body_bytes = x;
        } else if (strcmp(a, "--job-timeout-ms") == 0) {
            if (parse_size(a, v, 0, 1ull << 40, &x))
                return RD_EXIT_USAGE;
            o.jobs.job_timeout_ms = (double)x;
        } else if (strcmp(a, "--max-connections") == 0) {
            if (parse_size(a, v, 1, 1000000, &x))
                return RD_EXIT_USAGE;
            o.max_connections = (unsigned)x;
        } else if (strcmp(a, "--max-per-ip") == 0) {
            if (parse_size(a, v, 1, 1000000, &x))
                return RD_EXIT_USAGE;
            o.max_per_ip = (unsigned)x;
        } else if (strcmp(a, "--connection-timeout") == 0) {
            if (parse_size(a, v, 1, 86400, &x))
                return RD_EXIT_USAGE;
            o.connection_timeout_s = (unsigned)x;
        } else if (strcmp(a, "--header-timeout-ms") == 0) {
            if (parse_size(a, v, 1, 1ull << 30, &x))
                return RD_EXIT_USAGE;
            o.header_timeout_ms = (double)x;
        } else if (strcmp(a, "--body-timeout-ms") == 0) {
            if (parse_size(a, v, 1, 1ull << 30, &x))
                return RD_EXIT_USAGE;
            o.body_timeout_ms = (double)x;
        } else if (strcmp(a, "--max-query-args") == 0) {
            if (parse_size(a, v, 1, 10000, &x))
                return RD_EXIT_USAGE;
            o.max_query_args = (unsigned)x;
        } else if (strcmp(a, "--memory-budget") == 0) {
            if (parse_size(a, v, 1u << 20, 1ull << 50, &x))
                return RD_EXIT_USAGE;
            o.jobs.memory_budget = x;
        } else if (strcmp(a, "--grade-cache-bytes") == 0) {
            if (parse_size(a, v, 0, 1ull << 40, &x))
                return RD_EXIT_USAGE;
            o.grade_cache_bytes = x;
        } else if (strcmp(a, "--max-jobs-kept") == 0) {
            if (parse_size(a, v, 1, 10000000, &x))
                return RD_EXIT_USAGE;
            o.jobs.kept_max = x;
        } else if (strcmp(a, "--result-memory") == 0) {
            if (parse_size(a, v, 0, 1ull << 40, &x))
                return RD_EXIT_USAGE;
            o.jobs.result_memory = x;
        } else if (strcmp(a, "--result-ttl") == 0) {
            if (parse_size(a, v, 0, 1ull << 30, &x))
                return RD_EXIT_USAGE;
            o.jobs.result_ttl_ms = (double)x * 1e3;
        } else if (strcmp(a, "--drain-ms") == 0) {
            if (parse_size(a, v, 0, 1ull << 30, &x))
                return RD_EXIT_USAGE;
            drain_ms = (double)x;
        } else if (strcmp(a, "--png-level") == 0) {
            if (parse_size(a, v, 0, 9, &x))
                return RD_EXIT_USAGE;
            o.jobs.png.level = (int)x;
        } else if (strcmp(a, "--scenes") == 0) {
            o.scenes_dir = v;
        } else if (strcmp(a, "--assignments") == 0) {
            o.assignments_dir = v;
        } else if (strcmp(a, "--cache-dir") == 0) {
            o.cache_dir = v;
        } else if (strcmp(a, "--log-format") == 0) {
            if (strcmp(v, "json") == 0)
                o.log_json = 1;
            else if (strcmp(v, "text") != 0)
                return fprintf(stderr, "rayd serve: --log-format takes text or json\n"), RD_EXIT_USAGE;
        } else {
            fprintf(stderr, "rayd serve: unknown option '%s' (try 'rayd serve --help')\n", a);
            return RD_EXIT_USAGE;
        }
    }

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
