/* Driving a real `rayd serve` from a Criterion test: start it on a port it
 * picks, talk HTTP with libcurl, read its log, stop it by pid. See
 * tests/integration/test_daemon.c for the conventions every daemon suite follows. */
#ifndef RD_TEST_DAEMON_HARNESS_H
#define RD_TEST_DAEMON_HARNESS_H

#include <curl/curl.h>
#include <pthread.h>
#include <stddef.h>
#include <sys/types.h>

typedef struct {
    pid_t pid; /* > 0 while running and not reaped */
    int port;
    char dir[256];
    char port_file[300];
    char log_file[300];
    long long max_body; /* --max-body-bytes it was started with */
} server;

#define MAX_SERVERS 4

extern server g_servers[MAX_SERVERS];

extern int g_nservers;

#define start_server(...) start_server_v((const char *const[]){__VA_ARGS__, NULL})

#define start_server_default() start_server_v(NULL)

typedef struct {
    CURLcode rc;
    long code;
    char *body;
    size_t len;
    char hdr[16384]; /* the last response's header block */
    size_t hlen;
    double seconds;
    curl_off_t uploaded;
    long connects;
    char errbuf[CURL_ERROR_SIZE];
} resp;

typedef struct {
    const char *method; /* GET when NULL */
    const char *path;   /* with the query */
    const char *ctype;  /* Content-Type; NULL: none at all */
    const void *body;
    size_t len;
    long timeout_ms;    /* 0: 120 s */
    CURL *easy;         /* reuse this handle (keep-alive); NULL: a new one */
    const char *accept; /* Accept header; NULL: curl's default */
} req_opts;

/* A request on its own thread (a sync render to interrupt). */
typedef struct {
    int port;
    req_opts o;
    resp r;
    pthread_t th;
    int done;
} bg_req;

/* Slow and small work: seconds on an idle machine, and long enough that a
 * test stalled for seconds between seeing it run and cancelling it (as
 * happens here straight after a build) still finds it running. Every test
 * cancels it or lets a time limit end it. */
#define SLOW_QUERY "?width=320&height=240&samples=256"

#define SMALL_QUERY "?width=8&height=8"

double now_s(void);

void sleep_ms(long ms);

const char *rayd_path(void);

/* The whole file (malloc'ed, NUL-terminated), or NULL. */
char *slurp(const char *path, size_t *len_out);

void die_with_log(server *s, const char *why);

/* Starts `RAYD serve --listen 127.0.0.1:0 --port-file F --scenes scenes`
 * with the extra flags (NULL-terminated) and waits for its port. */
server *start_server_v(const char *const *extra);

/* SIGTERM, then wait up to timeout_s for the exit. Returns the wait status,
 * or -1 (after SIGKILL) when it did not exit in time. *secs: how long. */
int stop_server(server *s, double timeout_s, double *secs);

void assert_clean_exit(server *s, double timeout_s);

/* Removes the newest server's files (stopping it first if it still runs)
 * and gives its slot back: a test may start many servers in turn. */
void forget_last_server(void);

void setup(void);

void teardown(void);

size_t on_body(char *p, size_t sz, size_t n, void *user);

size_t on_header(char *p, size_t sz, size_t n, void *user);

void resp_free(resp *r);

/* A response header's value (trimmed), or NULL. */
const char *header(const resp *r, const char *name, char *out, size_t outsz);

void http(int port, const req_opts *o, resp *r);

void GET(int port, const char *path, resp *r);

void POST(int port, const char *path, const char *ctype, const void *body, size_t len, resp *r);

void DELETE(int port, const char *path, resp *r);

/* The value after "key": (the first occurrence), or NULL. */
const char *json_at(const char *json, const char *key);

int json_str(const char *json, const char *key, char *out, size_t outsz);

int json_num(const char *json, const char *key, double *out);

int is_png(const resp *r);

unsigned be32(const unsigned char *p);

void assert_png(const resp *r, unsigned w, unsigned h);

/* An error answer: status, application/json, {"error":{"code","message"...}}. */
void assert_error(const resp *r, long status, const char *code);

/* The value of the sample named exactly `name` (with labels), or -1. */
double metric(const char *text, const char *name);

double get_metric(int port, const char *name);

/* Polls /metrics until name >= want; the last value seen. */
double wait_metric_ge(int port, const char *name, double want, double timeout_s);

/* GET /v1/jobs/{id}: status and progress. */
void job_state(int port, const char *id, char *status, size_t ssz, double *progress, resp *keep);

/* Polls the job until its status is one of `want` ("done", "cancelled"
 * ...); returns 1 when reached. */
int wait_job_status(int port, const char *id, const char *want, double timeout_s, char *last, size_t lsz);

char *scene_text(const char *path, size_t *len);

/* The request log: waits until a line containing all of a, b (b may be
 * NULL) appears; returns that line (malloc'ed) or NULL. */
char *wait_log_line(server *s, const char *a, const char *b, double timeout_s);

void *bg_main(void *arg);

void bg_start(bg_req *b, int port, const char *path, const char *body, size_t len, long timeout_ms);

/* Joins the request, waiting at most timeout_s for it. 1 when it ended. */
int bg_join(bg_req *b, double timeout_s);

long vm_rss_kb(pid_t pid);

/* Runs argv to completion (at most timeout_s); its exit status or -1. */
int run_cmd(const char *const *argv, double timeout_s);
void submit_job(int port, const char *query, const char *ctype, const char *body, size_t len, char *id, size_t idsz);

#endif
