/* rayd serve: the HTTP daemon (libmicrohttpd) in front of the job queue.
 * Contract: http-api.md. */
#ifndef RD_SERVER_H
#define RD_SERVER_H

#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>

#include "farm.h"
#include "job_queue.h"
#include "scene_limits.h"

typedef struct {
    const char *listen_host; /* "127.0.0.1", "::1", "localhost"; "": every address */
    uint16_t port;           /* 0: any free port */
    int http_threads;        /* libmicrohttpd's thread pool, >= 2 */
    rd_jq_options jobs;
    rd_scene_limits limits;
    size_t max_body_bytes;
    unsigned max_connections;
    unsigned max_per_ip;
    unsigned connection_timeout_s;
    double header_timeout_ms;    /* from accept (or the previous answer) to a request's last header */
    double body_timeout_ms;      /* from the last header to the body's last byte */
    unsigned max_query_args;     /* more get 431 */
    size_t grade_cache_bytes;    /* grading references and kept grade images */
    const char *scenes_dir;      /* bundled scenes and the folder uploaded scenes' files resolve in */
    const char *assignments_dir; /* graded assignments */
    const char *cache_dir;       /* grading references on disk; NULL: memory only */
    int log_json;
    struct rd_log *log;      /* the daemon's log (log.h); NULL: text on stderr */
    const char *trust_proxy; /* comma-separated proxy addresses whose X-Forwarded-For is believed */
    const char *cors_origin; /* Access-Control-Allow-Origin; NULL: no CORS headers */
    /* The job store of POST /v1/jobs (farm.h): SQLite in data_dir, or the
     * PostgreSQL database store names. */
    const char *data_dir;
    const char *store;     /* NULL: SQLite in data_dir */
    const char *daemon_id; /* NULL: HOSTNAME:PORT */
    int lease_ms;
    int store_tile;
    /* Grading a class (docs/grading.md). */
    const char *instructor_tokens; /* the tokens' file; NULL: the instructors' routes are off (404) */
    const char *roster;            /* the class's roster (api/grading/roster.h); NULL: none */
    double grade_ttl_ms;           /* grade records are kept this long */
    size_t max_batch_images;       /* images of one batch */
    size_t max_batch_bytes;        /* a batch's form (or archive) */
    size_t max_batch_expanded;     /* what an archive decompresses to */
    /* Grading code (docs/grading.md, "Grading code"). */
    const char *bwrap;            /* bubblewrap */
    const char *course_dir;       /* the course's headers and adapter */
    const char *code_eval;        /* rayd-eval */
    size_t max_code_bytes;        /* an uploaded file */
    int max_code_jobs;            /* code grades at once; more get 503 */
    int max_code_jobs_per_client; /* of them, one client's at once; more get 429 */
    double code_compile_ms;       /* the compiler's time */
    double code_run_ms;           /* the calls' time */
    unsigned sandbox_uid;         /* the sandbox's uid and gid when rayd runs as root */
} rd_server_options;

/* A resolved listening address. */
typedef struct {
    struct sockaddr_storage addr;
    socklen_t len;
} rd_listen_addr;

/* host (a name or an address; "" for every address) and port through
 * getaddrinfo, the first answer; RD_ERR_INVALID with a message when it
 * does not resolve. */
rd_error_code rd_listen_resolve(const char *host, uint16_t port, rd_listen_addr *out, rd_error *err);

typedef struct rd_server rd_server;

/* The defaults of `rayd serve --help`: memory budget half the RAM, render
 * threads one per core. */
rd_server_options rd_server_options_default(void);

rd_server *rd_server_start(const rd_server_options *opt, rd_error *err);

/* The port it listens on (useful with port 0). */
uint16_t rd_server_port(const rd_server *s);

/* Its name in the job store's leases (--daemon-id, or HOSTNAME:PORT). */
const char *rd_server_daemon_id(const rd_server *s);

/* Reads --instructor-tokens again (SIGHUP): the file's tokens replace
 * those in use, for the next request. Returns how many it holds; -1 when
 * the server has no --instructor-tokens (the instructors' routes stay off);
 * -2 with err set when the file cannot be read or is bad, the tokens in use
 * then staying. */
int rd_server_reload_tokens(rd_server *s, rd_error *err);

/* Graceful stop: refuse new work (503), let running jobs finish for up to
 * drain_ms, cancel the rest, answer every waiting client, stop. */
void rd_server_stop(rd_server *s, double drain_ms);

#endif
