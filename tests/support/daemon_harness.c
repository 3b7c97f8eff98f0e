/* The daemon harness (daemon_harness.h). */
#include <criterion/criterion.h>
#include <curl/curl.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "daemon_harness.h"

/* ---- small utilities ------------------------------------------------------ */

double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

void sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
}

const char *rayd_path(void)
{
    const char *p = getenv("RAYD");
    return p && *p ? p : "build/rayd";
}

/* The whole file (malloc'ed, NUL-terminated), or NULL. */
char *slurp(const char *path, size_t *len_out)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 4096, len = 0;
    char *buf = malloc(cap);
    for (;;) {
        if (len + 4096 + 1 > cap) {
            cap *= 2;
            buf = realloc(buf, cap);
        }
        size_t n = fread(buf + len, 1, cap - len - 1, f);
        len += n;
        if (n == 0)
            break;
    }
    fclose(f);
    buf[len] = 0;
    if (len_out)
        *len_out = len;
    return buf;
}

/* ---- the daemon under test ------------------------------------------------ */

server g_servers[MAX_SERVERS];
int g_nservers;

void die_with_log(server *s, const char *why)
{
    char *log = slurp(s->log_file, NULL);
    cr_assert_fail("%s\n--- daemon log (%s) ---\n%s", why, s->log_file, log ? log : "(none)");
}

/* Starts `RAYD serve --listen 127.0.0.1:0 --port-file F --scenes scenes`
 * with the extra flags (NULL-terminated) and waits for its port. */
server *start_server_v(const char *const *extra)
{
    cr_assert_lt(g_nservers, MAX_SERVERS);
    server *s = &g_servers[g_nservers++];
    memset(s, 0, sizeof *s);
    snprintf(s->dir, sizeof s->dir, "/tmp/rayd_td_XXXXXX");
    cr_assert_not_null(mkdtemp(s->dir), "mkdtemp: %s", strerror(errno));
    char dir[256];
    memcpy(dir, s->dir, sizeof dir);
    snprintf(s->port_file, sizeof s->port_file, "%s/port", dir);
    snprintf(s->log_file, sizeof s->log_file, "%s/log", dir);

    const char *argv[64];
    int n = 0;
    argv[n++] = rayd_path();
    argv[n++] = "serve";
    argv[n++] = "--listen";
    argv[n++] = "127.0.0.1:0";
    argv[n++] = "--port-file";
    argv[n++] = s->port_file;
    argv[n++] = "--scenes";
    argv[n++] = "scenes";
    s->max_body = 16LL << 20;
    for (int i = 0; extra && extra[i] && n < 62; i++) {
        if (strcmp(extra[i], "--max-body-bytes") == 0 && extra[i + 1])
            s->max_body = atoll(extra[i + 1]);
        argv[n++] = extra[i];
    }
    argv[n] = NULL;

    pid_t parent = getpid();
    pid_t pid = fork();
    cr_assert_geq(pid, 0, "fork: %s", strerror(errno));
    if (pid == 0) {
        /* Never outlive the test process, even when it is killed. */
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() != parent)
            _exit(127);
        int lf = open(s->log_file, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int nul = open("/dev/null", O_RDWR);
        if (lf < 0 || nul < 0)
            _exit(127);
        dup2(nul, 0);
        dup2(nul, 1);
        dup2(lf, 2);
        /* Each daemon its own job store (a --data-dir flag still wins). */
        char data_dir[300];
        snprintf(data_dir, sizeof data_dir, "%s/var", dir);
        setenv("RAYD_DATA_DIR", data_dir, 1);
        execv(argv[0], (char *const *)argv);
        dprintf(2, "exec %s: %s\n", argv[0], strerror(errno));
        _exit(127);
    }
    s->pid = pid;

    /* The port file appears once it listens (written to F.tmp, renamed). */
    double t0 = now_s();
    for (int i = 0; i < 3000 && now_s() - t0 < 30; i++) {
        FILE *f = fopen(s->port_file, "r");
        if (f) {
            int port = 0;
            int ok = fscanf(f, "%d", &port) == 1;
            fclose(f);
            if (ok && port > 0 && port < 65536) {
                s->port = port;
                return s;
            }
        }
        int st;
        if (waitpid(pid, &st, WNOHANG) == pid) {
            s->pid = 0;
            die_with_log(s, "the daemon exited before writing its port file");
        }
        sleep_ms(10);
    }
    die_with_log(s, "no port file within 30 s");
    return NULL;
}

/* SIGTERM, then wait up to timeout_s for the exit. Returns the wait status,
 * or -1 (after SIGKILL) when it did not exit in time. *secs: how long. */
int stop_server(server *s, double timeout_s, double *secs)
{
    cr_assert_gt(s->pid, 0);
    double t0 = now_s();
    kill(s->pid, SIGTERM);
    int st = 0;
    for (int i = 0; i < 100000 && now_s() - t0 < timeout_s; i++) {
        pid_t w = waitpid(s->pid, &st, WNOHANG);
        if (w == s->pid) {
            s->pid = 0;
            if (secs)
                *secs = now_s() - t0;
            return st;
        }
        sleep_ms(10);
    }
    kill(s->pid, SIGKILL);
    waitpid(s->pid, &st, 0);
    s->pid = 0;
    if (secs)
        *secs = now_s() - t0;
    return -1;
}

void assert_clean_exit(server *s, double timeout_s)
{
    double secs;
    int st = stop_server(s, timeout_s, &secs);
    if (st == -1)
        die_with_log(s, "the daemon did not exit after SIGTERM (killed)");
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
        char why[160];
        snprintf(why, sizeof why, "the daemon did not exit 0 after SIGTERM: %s %d",
                 WIFEXITED(st) ? "exit status" : "killed by signal",
                 WIFEXITED(st)     ? WEXITSTATUS(st)
                 : WIFSIGNALED(st) ? WTERMSIG(st)
                                   : -1);
        die_with_log(s, why);
    }
}

void setup(void)
{
    g_nservers = 0;
    curl_global_init(CURL_GLOBAL_DEFAULT);
}

/* Stops a server still running (SIGTERM, then SIGKILL) and removes its
 * files. */
static void clean_server(server *s)
{
    {
        if (s->pid > 0) {
            int st, reaped = 0;
            kill(s->pid, SIGTERM);
            for (int k = 0; k < 300 && !reaped; k++) {
                reaped = waitpid(s->pid, &st, WNOHANG) == s->pid;
                if (!reaped)
                    sleep_ms(10);
            }
            if (!reaped) {
                kill(s->pid, SIGKILL);
                waitpid(s->pid, &st, 0);
            }
            s->pid = 0;
        }
        unlink(s->port_file);
        char tmp[320];
        snprintf(tmp, sizeof tmp, "%s.tmp", s->port_file);
        unlink(tmp);
        unlink(s->log_file);
        rmdir(s->dir);
    }
}

void forget_last_server(void)
{
    cr_assert_gt(g_nservers, 0);
    clean_server(&g_servers[--g_nservers]);
}

void teardown(void)
{
    for (int i = 0; i < g_nservers; i++)
        clean_server(&g_servers[i]);
    g_nservers = 0;
    curl_global_cleanup();
}

/* ---- HTTP with libcurl ---------------------------------------------------- */

size_t on_body(char *p, size_t sz, size_t n, void *user)
{
    resp *r = user;
    size_t k = sz * n;
    char *nb = realloc(r->body, r->len + k + 1);
    if (!nb)
        return 0;
    r->body = nb;
    memcpy(r->body + r->len, p, k);
    r->len += k;
    r->body[r->len] = 0;
    return k;
}

size_t on_header(char *p, size_t sz, size_t n, void *user)
{
    resp *r = user;
    size_t k = sz * n;
    if (k >= 5 && strncmp(p, "HTTP/", 5) == 0)
        r->hlen = 0; /* a new response (after 100 Continue) */
    if (r->hlen + k < sizeof r->hdr) {
        memcpy(r->hdr + r->hlen, p, k);
        r->hlen += k;
        r->hdr[r->hlen] = 0;
    }
    return k;
}

void resp_free(resp *r)
{
    free(r->body);
    memset(r, 0, sizeof *r);
}

/* A response header's value (trimmed), or NULL. */
const char *header(const resp *r, const char *name, char *out, size_t outsz)
{
    size_t nl = strlen(name);
    const char *p = r->hdr;
    while (p && *p) {
        const char *eol = strchr(p, '\n');
        size_t ll = eol ? (size_t)(eol - p) : strlen(p);
        if (ll > nl && strncasecmp(p, name, nl) == 0 && p[nl] == ':') {
            const char *v = p + nl + 1;
            const char *e = p + ll;
            while (v < e && (*v == ' ' || *v == '\t'))
                v++;
            while (e > v && (e[-1] == '\r' || e[-1] == ' '))
                e--;
            snprintf(out, outsz, "%.*s", (int)(e - v), v);
            return out;
        }
        p = eol ? eol + 1 : NULL;
    }
    return NULL;
}

void http(int port, const req_opts *o, resp *r)
{
    memset(r, 0, sizeof *r);
    CURL *e = o->easy ? o->easy : curl_easy_init();
    cr_assert_not_null(e);
    if (o->easy)
        curl_easy_reset(e); /* keeps the connection cache */
    char url[1024];
    snprintf(url, sizeof url, "http://127.0.0.1:%d%s", port, o->path);
    struct curl_slist *h = NULL;
    char ct[200];
    if (o->ctype) {
        snprintf(ct, sizeof ct, "Content-Type: %s", o->ctype);
        h = curl_slist_append(h, ct);
    } else {
        h = curl_slist_append(h, "Content-Type:");
    }
    h = curl_slist_append(h, "Expect:");
    char accept[200];
    if (o->accept) {
        snprintf(accept, sizeof accept, "Accept: %s", o->accept);
        h = curl_slist_append(h, accept);
    }
    const char *m = o->method ? o->method : "GET";
    curl_easy_setopt(e, CURLOPT_URL, url);
    curl_easy_setopt(e, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(e, CURLOPT_HTTPHEADER, h);
    curl_easy_setopt(e, CURLOPT_WRITEFUNCTION, on_body);
    curl_easy_setopt(e, CURLOPT_WRITEDATA, r);
    curl_easy_setopt(e, CURLOPT_HEADERFUNCTION, on_header);
    curl_easy_setopt(e, CURLOPT_HEADERDATA, r);
    curl_easy_setopt(e, CURLOPT_ERRORBUFFER, r->errbuf);
    curl_easy_setopt(e, CURLOPT_TIMEOUT_MS, o->timeout_ms ? o->timeout_ms : 120000L);
    curl_easy_setopt(e, CURLOPT_FORBID_REUSE, 0L);
    if (strcmp(m, "POST") == 0 || o->body) {
        curl_easy_setopt(e, CURLOPT_POSTFIELDS, o->body ? o->body : "");
        curl_easy_setopt(e, CURLOPT_POSTFIELDSIZE_LARGE, (curl_off_t)o->len);
    }
    if (strcmp(m, "GET") == 0 && !o->body)
        curl_easy_setopt(e, CURLOPT_HTTPGET, 1L);
    else if (strcmp(m, "HEAD") == 0)
        curl_easy_setopt(e, CURLOPT_NOBODY, 1L);
    else if (strcmp(m, "POST") != 0)
        curl_easy_setopt(e, CURLOPT_CUSTOMREQUEST, m);
    double t0 = now_s();
    r->rc = curl_easy_perform(e);
    r->seconds = now_s() - t0;
    curl_easy_getinfo(e, CURLINFO_RESPONSE_CODE, &r->code);
    curl_easy_getinfo(e, CURLINFO_SIZE_UPLOAD_T, &r->uploaded);
    curl_easy_getinfo(e, CURLINFO_NUM_CONNECTS, &r->connects);
    curl_slist_free_all(h);
    if (!o->easy)
        curl_easy_cleanup(e);
}

void GET(int port, const char *path, resp *r)
{
    req_opts o = {.method = "GET", .path = path};
    http(port, &o, r);
}

void POST(int port, const char *path, const char *ctype, const void *body, size_t len, resp *r)
{
    req_opts o = {.method = "POST", .path = path, .ctype = ctype, .body = body, .len = len};
    http(port, &o, r);
}

void DELETE(int port, const char *path, resp *r)
{
    req_opts o = {.method = "DELETE", .path = path};
    http(port, &o, r);
}

/* ---- JSON, PNG and metrics readers ---------------------------------------- */

/* The value after "key": (the first occurrence), or NULL. */
const char *json_at(const char *json, const char *key)
{
    if (!json)
        return NULL;
    char pat[128];
    snprintf(pat, sizeof pat, "\"%s\"", key);
    const char *p = strstr(json, pat);
    if (!p)
        return NULL;
    p += strlen(pat);
    while (*p == ' ' || *p == '\n' || *p == '\t' || *p == '\r')
        p++;
    if (*p != ':')
        return NULL;
    p++;
    while (*p == ' ' || *p == '\n' || *p == '\t' || *p == '\r')
        p++;
    return p;
}

int json_str(const char *json, const char *key, char *out, size_t outsz)
{
    const char *p = json_at(json, key);
    if (!p || *p != '"')
        return 0;
    p++;
    size_t n = 0;
    while (*p && *p != '"' && n + 1 < outsz) {
        if (*p == '\\' && p[1])
            p++;
        out[n++] = *p++;
    }
    out[n] = 0;
    return *p == '"';
}

int json_num(const char *json, const char *key, double *out)
{
    const char *p = json_at(json, key);
    if (!p)
        return 0;
    char *end;
    *out = strtod(p, &end);
    return end != p;
}

int is_png(const resp *r)
{
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    return r->len > 24 && memcmp(r->body, sig, 8) == 0 && memcmp(r->body + 12, "IHDR", 4) == 0;
}

unsigned be32(const unsigned char *p)
{
    return (unsigned)p[0] << 24 | (unsigned)p[1] << 16 | (unsigned)p[2] << 8 | p[3];
}

void assert_png(const resp *r, unsigned w, unsigned h)
{
    char ct[128] = "";
    cr_assert_eq(r->code, 200, "expected 200, got %ld: %.300s", r->code, r->body ? r->body : "");
    cr_assert(header(r, "Content-Type", ct, sizeof ct) && strcmp(ct, "image/png") == 0, "Content-Type: %s",
              header(r, "Content-Type", ct, sizeof ct) ? ct : "(none)");
    cr_assert(is_png(r), "not a PNG (%zu bytes)", r->len);
    const unsigned char *b = (const unsigned char *)r->body;
    cr_assert_eq(be32(b + 16), w, "PNG width %u, expected %u", be32(b + 16), w);
    cr_assert_eq(be32(b + 20), h, "PNG height %u, expected %u", be32(b + 20), h);
}

/* An error answer: status, application/json, {"error":{"code","message"...}}. */
void assert_error(const resp *r, long status, const char *code)
{
    char ct[128] = "", c[64] = "", msg[1024] = "";
    cr_assert_eq(r->rc, CURLE_OK, "curl: %s (%s)", curl_easy_strerror(r->rc), r->errbuf);
    cr_assert_eq(r->code, status, "expected %ld, got %ld: %.400s", status, r->code, r->body ? r->body : "");
    cr_assert(header(r, "Content-Type", ct, sizeof ct) && strncmp(ct, "application/json", 16) == 0,
              "an error answer must be JSON (Content-Type '%s')", header(r, "Content-Type", ct, sizeof ct) ? ct : "");
    cr_assert(r->body && strncmp(r->body, "{\"error\":{", 10) == 0, "not an error object: %.300s",
              r->body ? r->body : "");
    cr_assert(json_str(r->body, "code", c, sizeof c), "no error code: %s", r->body);
    cr_assert(json_str(r->body, "message", msg, sizeof msg) && msg[0], "no error message: %s", r->body);
    if (code)
        cr_assert_str_eq(c, code, "error code: %s", r->body);
}

/* The value of the sample named exactly `name` (with labels), or -1. */
double metric(const char *text, const char *name)
{
    size_t nl = strlen(name);
    for (const char *p = text; p && *p;) {
        if (strncmp(p, name, nl) == 0 && p[nl] == ' ')
            return strtod(p + nl + 1, NULL);
        p = strchr(p, '\n');
        if (p)
            p++;
    }
    return -1;
}

double get_metric(int port, const char *name)
{
    resp r;
    GET(port, "/metrics", &r);
    cr_assert_eq(r.code, 200, "/metrics: %ld (%s)", r.code, curl_easy_strerror(r.rc));
    double v = metric(r.body, name);
    cr_assert_geq(v, 0, "/metrics has no %s:\n%s", name, r.body);
    resp_free(&r);
    return v;
}

/* Polls /metrics until name >= want; the last value seen. */
double wait_metric_ge(int port, const char *name, double want, double timeout_s)
{
    double t0 = now_s(), v = -1;
    for (int i = 0; i < 2000 && now_s() - t0 < timeout_s; i++) {
        v = get_metric(port, name);
        if (v >= want)
            break;
        sleep_ms(20);
    }
    return v;
}

/* GET /v1/jobs/{id}: status and progress. */
void job_state(int port, const char *id, char *status, size_t ssz, double *progress, resp *keep)
{
    char path[128];
    snprintf(path, sizeof path, "/v1/jobs/%s", id);
    resp r;
    GET(port, path, &r);
    cr_assert_eq(r.code, 200, "GET %s: %ld %.300s", path, r.code, r.body ? r.body : "");
    cr_assert(json_str(r.body, "status", status, ssz), "no status: %s", r.body);
    double p = -1;
    cr_assert(json_num(r.body, "progress", &p), "no progress: %s", r.body);
    if (progress)
        *progress = p;
    if (keep)
        *keep = r;
    else
        resp_free(&r);
}

/* Polls the job until its status is one of `want` ("done", "cancelled"
 * ...); returns 1 when reached. */
int wait_job_status(int port, const char *id, const char *want, double timeout_s, char *last, size_t lsz)
{
    double t0 = now_s();
    for (int i = 0; i < 5000 && now_s() - t0 < timeout_s; i++) {
        job_state(port, id, last, lsz, NULL, NULL);
        if (strcmp(last, want) == 0)
            return 1;
        sleep_ms(20);
    }
    return 0;
}

/* POST /v1/jobs: asserts 202 and returns the id. */
void submit_job(int port, const char *query, const char *ctype, const char *body, size_t len, char *id, size_t idsz)
{
    char path[256];
    snprintf(path, sizeof path, "/v1/jobs%s", query);
    resp r;
    POST(port, path, ctype, body, len, &r);
    cr_assert_eq(r.code, 202, "POST %s: %ld %.300s", path, r.code, r.body ? r.body : "");
    cr_assert(json_str(r.body, "id", id, idsz) && id[0], "no id: %s", r.body);
    resp_free(&r);
}

char *scene_text(const char *path, size_t *len)
{
    char *t = slurp(path, len);
    cr_assert_not_null(t, "cannot read %s (run from the repository root)", path);
    return t;
}

/* The request log: waits until a line containing all of a, b (b may be
 * NULL) appears; returns that line (malloc'ed) or NULL. */
char *wait_log_line(server *s, const char *a, const char *b, double timeout_s)
{
    double t0 = now_s();
    for (int i = 0; i < 2000 && now_s() - t0 < timeout_s; i++) {
        char *log = slurp(s->log_file, NULL);
        for (char *line = log ? strtok(log, "\n") : NULL; line; line = strtok(NULL, "\n"))
            if (strstr(line, a) && (!b || strstr(line, b))) {
                char *copy = strdup(line);
                free(log);
                return copy;
            }
        free(log);
        sleep_ms(20);
    }
    return NULL;
}

void *bg_main(void *arg)
{
    bg_req *b = arg;
    http(b->port, &b->o, &b->r);
    __atomic_store_n(&b->done, 1, __ATOMIC_SEQ_CST);
    return NULL;
}

void bg_start(bg_req *b, int port, const char *path, const char *body, size_t len, long timeout_ms)
{
    memset(b, 0, sizeof *b);
    b->port = port;
    b->o.method = "POST";
    b->o.path = path;
    b->o.ctype = "text/plain";
    b->o.body = body;
    b->o.len = len;
    b->o.timeout_ms = timeout_ms;
    cr_assert_eq(pthread_create(&b->th, NULL, bg_main, b), 0);
}

/* Joins the request, waiting at most timeout_s for it. 1 when it ended. */
int bg_join(bg_req *b, double timeout_s)
{
    double t0 = now_s();
    for (int i = 0; i < 100000 && now_s() - t0 < timeout_s; i++) {
        if (__atomic_load_n(&b->done, __ATOMIC_SEQ_CST)) {
            pthread_join(b->th, NULL);
            return 1;
        }
        sleep_ms(10);
    }
    return 0;
}

long vm_rss_kb(pid_t pid)
{
    char path[64];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    char *t = slurp(path, NULL);
    cr_assert_not_null(t, "cannot read %s", path);
    const char *p = strstr(t, "VmRSS:");
    cr_assert_not_null(p, "no VmRSS in %s", path);
    long kb = strtol(p + 6, NULL, 10);
    free(t);
    return kb;
}

/* Runs argv to completion (at most timeout_s); its exit status or -1. */
int run_cmd(const char *const *argv, double timeout_s)
{
    pid_t parent = getpid();
    pid_t pid = fork();
    cr_assert_geq(pid, 0);
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (getppid() != parent)
            _exit(127);
        int nul = open("/dev/null", O_RDWR);
        dup2(nul, 0);
        dup2(nul, 1);
        dup2(nul, 2);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    double t0 = now_s();
    int st;
    for (int i = 0; i < 100000 && now_s() - t0 < timeout_s; i++) {
        if (waitpid(pid, &st, WNOHANG) == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        sleep_ms(10);
    }
    kill(pid, SIGKILL);
    waitpid(pid, &st, 0);
    return -1;
}
