#include "metrics.h"

#include <dirent.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "histogram.h"
#include "http_internal.h"
#include "strbuf.h"
#include "version.h"

/* Statuses a route can be counted under, and routes: the route table has
 * about a dozen paths, so the slots never run out; past them requests
 * count as "other". */
enum { CODE_MIN = 100, CODE_MAX = 599, ROUTES_MAX = 32 };

typedef struct {
    const char *route; /* a route table path or "other"; static strings */
    uint64_t codes[CODE_MAX - CODE_MIN + 1];
    rd_hist duration;
} route_stats;

/* One mutex for everything: a request takes it once as it completes, which
 * costs nothing beside libmicrohttpd's own locking, and histograms need
 * their sum and buckets to move together. */
struct rd_metrics {
    pthread_mutex_t mu;
    double cover;
    int nroutes;
    route_stats routes[ROUTES_MAX]; /* [0] is "other" */
    uint64_t classes[6];            /* 1xx..5xx; [0] unused */
    uint64_t grades[3];             /* by rd_verdict */
    uint64_t code_grades[3];        /* POST /v1/grade/code, by rd_verdict */
};

rd_metrics *rd_metrics_new(double cover_seconds)
{
    rd_metrics *m = calloc(1, sizeof *m);
    if (!m)
        return NULL;
    pthread_mutex_init(&m->mu, NULL);
    m->cover = cover_seconds;
    m->routes[0].route = "other";
    rd_hist_init(&m->routes[0].duration, cover_seconds);
    m->nroutes = 1;
    return m;
}

void rd_metrics_free(rd_metrics *m)
{
    if (!m)
        return;
    pthread_mutex_destroy(&m->mu);
    free(m);
}

/* The slot of route, made on its first request. Under m->mu. */
static route_stats *slot(rd_metrics *m, const char *route)
{
    for (int i = 0; i < m->nroutes; i++)
        if (strcmp(m->routes[i].route, route) == 0)
            return &m->routes[i];
    if (m->nroutes == ROUTES_MAX)
        return &m->routes[0];
    route_stats *s = &m->routes[m->nroutes++];
    s->route = route;
    rd_hist_init(&s->duration, m->cover);
    return s;
}

static void count_status(rd_metrics *m, route_stats *s, unsigned status)
{
    m->classes[status / 100]++;
    s->codes[status - CODE_MIN]++;
}

void rd_metrics_request_done(rd_server *srv, const rd_req *r, double ms)
{
    if (r->status < CODE_MIN || r->status > CODE_MAX)
        return;
    rd_metrics *m = srv->metrics;
    pthread_mutex_lock(&m->mu);
    route_stats *s = slot(m, r->route ? r->route->path : "other");
    count_status(m, s, r->status);
    rd_hist_observe(&s->duration, ms / 1e3);
    pthread_mutex_unlock(&m->mu);
}

void rd_metrics_refused(rd_server *srv)
{
    rd_metrics *m = srv->metrics;
    pthread_mutex_lock(&m->mu);
    count_status(m, &m->routes[0], 431);
    pthread_mutex_unlock(&m->mu);
}

void rd_metrics_grade(rd_server *srv, rd_verdict v)
{
    rd_metrics *m = srv->metrics;
    pthread_mutex_lock(&m->mu);
    m->grades[v]++;
    pthread_mutex_unlock(&m->mu);
}

void rd_metrics_code_grade(rd_server *srv, rd_verdict v)
{
    rd_metrics *m = srv->metrics;
    pthread_mutex_lock(&m->mu);
    m->code_grades[v]++;
    pthread_mutex_unlock(&m->mu);
}

/* ---- the text format ------------------------------------------------- */

#define PUT(...) rd_strbuf_printf(out, __VA_ARGS__)

static void family(rd_strbuf *out, const char *name, const char *type, const char *help)
{
    PUT("# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

/* A label value as the format wants it, into buf: backslash, quote and
 * newline escaped. Cut short (at a whole character) rather than overrun. */
static const char *escaped(char *buf, size_t size, const char *v)
{
    size_t n = 0;
    for (; *v && n + 3 < size; v++) {
        if (*v == '\\' || *v == '"' || *v == '\n')
            buf[n++] = '\\';
        buf[n++] = *v == '\n' ? 'n' : *v;
    }
    buf[n] = 0;
    return buf;
}

/* One histogram's samples. labels: "" or the series' labels, escaped
 * (route="/healthz"). %.15g writes every bound exactly (0.005, 30, 7680). */
static void histogram(rd_strbuf *out, const char *name, const char *labels, const rd_hist *h)
{
    const char *sep = *labels ? "," : "", *open = *labels ? "{" : "", *close = *labels ? "}" : "";
    uint64_t cum = 0;
    for (int b = 0; b < h->n; b++) {
        cum += h->count[b];
        PUT("%s_bucket{%s%sle=\"%.15g\"} %llu\n", name, labels, sep, h->le[b], (unsigned long long)cum);
    }
    PUT("%s_bucket{%s%sle=\"+Inf\"} %llu\n", name, labels, sep, (unsigned long long)h->total);
    PUT("%s_sum%s%s%s %.6f\n", name, open, labels, close, h->sum);
    PUT("%s_count%s%s%s %llu\n", name, open, labels, close, (unsigned long long)h->total);
}

static void gauge(rd_strbuf *out, const char *name, const char *help, size_t v)
{
    family(out, name, "gauge", help);
    PUT("%s %zu\n", name, v);
}

static void counter(rd_strbuf *out, const char *name, const char *help, uint64_t v)
{
    family(out, name, "counter", help);
    PUT("%s %llu\n", name, (unsigned long long)v);
}

static void queue_metrics(rd_strbuf *out, const rd_jq_metrics *m)
{
    gauge(out, "rayd_queue_depth", "This daemon's in-memory render jobs waiting for a render thread.", m->queued);
    gauge(out, "rayd_jobs_running",
          "Render jobs being rendered here: in-memory, and stored jobs whose tiles render here.", m->running);
    family(out, "rayd_jobs_total", "counter", "Render jobs ended, by outcome.");
    PUT("rayd_jobs_total{outcome=\"done\"} %llu\n", (unsigned long long)m->done);
    PUT("rayd_jobs_total{outcome=\"failed\"} %llu\n", (unsigned long long)m->failed);
    PUT("rayd_jobs_total{outcome=\"cancelled\"} %llu\n", (unsigned long long)m->cancelled);
    family(out, "rayd_render_seconds", "histogram", "Time from a job's start to its image.");
    histogram(out, "rayd_render_seconds", "", &m->render_seconds);
    family(out, "rayd_queue_wait_seconds", "histogram",
           "Time a job waited from its submission until a render thread started it.");
    histogram(out, "rayd_queue_wait_seconds", "", &m->queue_wait_seconds);
    counter(out, "rayd_rays_traced_total", "Camera, shadow and secondary rays traced.", m->rays);
    gauge(out, "rayd_result_bytes", "PNG (and EXR) bytes kept for finished jobs.", m->result_bytes);
    gauge(out, "rayd_jobs_kept", "Jobs whose status can still be read.", m->jobs_kept);
    gauge(out, "rayd_memory_budget_bytes", "The --memory-budget (0: none).", m->memory_budget);
    gauge(out, "rayd_memory_reserved_bytes", "Estimated bytes held by queued and running jobs.", m->memory_reserved);
    gauge(out, "rayd_grade_cache_bytes", "Grading references and kept grade images.", m->external_bytes);
    gauge(out, "rayd_jobs_waiting_memory", "Prepared jobs waiting for the memory budget.", m->waiting_memory);
}

static void farm_metrics(rd_strbuf *out, const rd_farm_metrics *m)
{
    counter(out, "rayd_farm_tiles_total", "Tiles of stored jobs this daemon rendered and stored.", m->tiles);
    counter(out, "rayd_farm_tiles_lost_total",
            "Tiles rendered here whose lease had passed to another daemon, or whose job had ended.", m->tiles_lost);
    counter(out, "rayd_farm_passes_total", "Passes of stored jobs this daemon ended.", m->passes);
    counter(out, "rayd_farm_scenes_read_total",
            "Stored jobs' scenes read back from the store to render here (a job submitted here is read once, as it "
            "is submitted).",
            m->read_back);
    counter(out, "rayd_store_jobs_submitted_total", "Jobs committed to the store through this daemon.", m->submitted);
    counter(out, "rayd_store_errors_total", "Store calls that found it unreachable.", m->store_errors);
    gauge(out, "rayd_farm_memory_bytes", "Estimated bytes of the stored jobs this daemon holds to render.", m->memory);
    gauge(out, "rayd_store_up", "1 when the job store answered the last call, 0 when it did not.", (size_t)m->store_up);
    if (m->store_known) {
        gauge(out, "rayd_store_queue_depth", "Stored jobs queued in the job store, for every daemon on it.",
              m->store_queued);
        gauge(out, "rayd_store_jobs_running", "Stored jobs running on any daemon of the job store.", m->store_running);
    }
}

static void http_metrics(rd_strbuf *out, const rd_metrics *m)
{
    family(out, "rayd_http_responses_total", "counter", "HTTP answers by status class.");
    for (int c = 1; c <= 5; c++)
        PUT("rayd_http_responses_total{code=\"%dxx\"} %llu\n", c, (unsigned long long)m->classes[c]);
    family(out, "rayd_http_requests_total", "counter",
           "HTTP answers by status and route (the route table's path; other: none matched).");
    char route[256], labels[300];
    for (int i = 0; i < m->nroutes; i++)
        for (int c = CODE_MIN; c <= CODE_MAX; c++)
            if (m->routes[i].codes[c - CODE_MIN])
                PUT("rayd_http_requests_total{code=\"%d\",route=\"%s\"} %llu\n", c,
                    escaped(route, sizeof route, m->routes[i].route),
                    (unsigned long long)m->routes[i].codes[c - CODE_MIN]);
    family(out, "rayd_http_request_duration_seconds", "histogram",
           "Time from a request's headers to its completion, by route.");
    for (int i = 0; i < m->nroutes; i++) {
        if (!m->routes[i].duration.total)
            continue;
        snprintf(labels, sizeof labels, "route=\"%s\"", escaped(route, sizeof route, m->routes[i].route));
        histogram(out, "rayd_http_request_duration_seconds", labels, &m->routes[i].duration);
    }
}

static void grade_metrics(rd_strbuf *out, const rd_metrics *m, const rd_grading_metrics *gm)
{
    static const char *const verdicts[] = {"pass", "fail", "error"};
    family(out, "rayd_grades_total", "counter", "Grades answered, by verdict (error: the grade could not be made).");
    for (int v = 0; v < 3; v++)
        PUT("rayd_grades_total{verdict=\"%s\"} %llu\n", verdicts[v], (unsigned long long)m->grades[v]);
    family(out, "rayd_code_grades_total", "counter",
           "Students' calcReflectedLight graded, by verdict (error: the grade could not be made).");
    for (int v = 0; v < 3; v++)
        PUT("rayd_code_grades_total{verdict=\"%s\"} %llu\n", verdicts[v], (unsigned long long)m->code_grades[v]);
    family(out, "rayd_grade_reference_cache_total", "counter",
           "Grading references looked up: found cached (hit) or rendered (miss).");
    PUT("rayd_grade_reference_cache_total{result=\"hit\"} %llu\n", gm->reference_hits);
    PUT("rayd_grade_reference_cache_total{result=\"miss\"} %llu\n", gm->reference_misses);
}

/* ---- the process, as Prometheus' client libraries report it ---------- */

typedef struct {
    double cpu_seconds, start_seconds;
    unsigned long long vsize, rss_bytes;
} proc_stat;

/* /proc/stat's btime: the boot time, seconds since the epoch; 0 unknown. */
static double boot_time(void)
{
    FILE *f = fopen("/proc/stat", "r");
    char line[256];
    double bt = 0;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "btime %lf", &bt) == 1)
            break;
    if (f)
        fclose(f);
    return bt;
}

/* /proc/self/stat (proc(5)): utime, stime, starttime in clock ticks since
 * boot, vsize in bytes, rss in pages. The name in parentheses may hold
 * spaces, so fields are counted from its closing parenthesis. 0 on
 * success. */
static int read_proc_stat(proc_stat *p)
{
    char buf[1024];
    FILE *f = fopen("/proc/self/stat", "r");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f)
        fclose(f);
    buf[n] = 0;
    const char *rp = strrchr(buf, ')');
    unsigned long long ut, st, start, vsize;
    long long rss;
    long tck = sysconf(_SC_CLK_TCK), page = sysconf(_SC_PAGESIZE);
    if (!rp || tck <= 0 || page <= 0 ||
        sscanf(rp + 1, " %*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu %*d %*d %*d %*d %*d %*d %llu %llu %lld",
               &ut, &st, &start, &vsize, &rss) != 5)
        return 1;
    p->cpu_seconds = (double)(ut + st) / (double)tck;
    p->start_seconds = boot_time() + (double)start / (double)tck;
    p->vsize = vsize;
    p->rss_bytes = rss > 0 ? (unsigned long long)rss * (unsigned long long)page : 0;
    return 0;
}

/* Entries of /proc/self/fd, the one reading it included, as the Go and
 * Python clients count them; -1 when it cannot be read. */
static long open_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    if (!d)
        return -1;
    long n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static void process_metrics(rd_strbuf *out)
{
    proc_stat p;
    if (read_proc_stat(&p) == 0) {
        family(out, "process_cpu_seconds_total", "counter", "Total user and system CPU time spent in seconds.");
        PUT("process_cpu_seconds_total %.2f\n", p.cpu_seconds);
        family(out, "process_resident_memory_bytes", "gauge", "Resident memory size in bytes.");
        PUT("process_resident_memory_bytes %llu\n", p.rss_bytes);
        family(out, "process_virtual_memory_bytes", "gauge", "Virtual memory size in bytes.");
        PUT("process_virtual_memory_bytes %llu\n", p.vsize);
        family(out, "process_start_time_seconds", "gauge", "Start time of the process since unix epoch in seconds.");
        PUT("process_start_time_seconds %.2f\n", p.start_seconds);
    }
    long fds = open_fds();
    if (fds >= 0) {
        family(out, "process_open_fds", "gauge", "Number of open file descriptors.");
        PUT("process_open_fds %ld\n", fds);
    }
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) == 0) {
        family(out, "process_max_fds", "gauge", "Maximum number of open file descriptors.");
        PUT("process_max_fds %llu\n", (unsigned long long)rl.rlim_cur);
    }
}

#undef PUT

enum MHD_Result rd_route_metrics(rd_req *r, const char *rest)
{
    (void)rest;
    rd_server *srv = r->srv;
    rd_jq_metrics jm;
    rd_jq_metrics_get(srv->jobs, &jm);
    rd_farm_metrics fm = {0};
    rd_farm *farm = rd_server_farm(srv);
    if (farm)
        rd_farm_metrics_get(farm, &fm);
    rd_grading_metrics gm = {0};
    rd_grading *grading = rd_server_grading(srv);
    if (grading)
        rd_grading_metrics_get(grading, &gm);
    /* A job ends in the queue (synchronous) or in the store (POST /v1/jobs). */
    jm.done += fm.done;
    jm.failed += fm.failed;
    jm.cancelled += fm.cancelled;
    jm.rays += fm.rays;
    jm.running += (size_t)fm.active;
    /* The farm's jobs count against the budget as memory outside the queue. */
    jm.external_bytes -= fm.memory < jm.external_bytes ? fm.memory : jm.external_bytes;
    /* A copy, so that requests completing meanwhile wait for a memcpy, not
     * for the formatting. */
    rd_metrics *copy = malloc(sizeof *copy);
    if (!copy)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    pthread_mutex_lock(&srv->metrics->mu);
    memcpy(copy, srv->metrics, sizeof *copy);
    pthread_mutex_unlock(&srv->metrics->mu);
    rd_strbuf out = {0};
    queue_metrics(&out, &jm);
    farm_metrics(&out, &fm);
    counter(&out, "rayd_http_deadline_closed_total", "Connections closed by the header or body deadline.",
            atomic_load(&srv->deadline_closed));
    counter(&out, "rayd_http_refused_total", "Requests answered 431 before parsing (--max-query-args).",
            atomic_load(&srv->raw_refused));
    http_metrics(&out, copy);
    grade_metrics(&out, copy, &gm);
    free(copy);
    process_metrics(&out);
    char version[256];
    family(&out, "rayd_build_info", "gauge", "The running build: its version as a label, value 1.");
    rd_strbuf_printf(&out, "rayd_build_info{version=\"%s\"} 1\n", escaped(version, sizeof version, rd_version()));
    size_t n;
    char *text = rd_strbuf_take(&out, &n);
    if (!text)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    return rd_reply(r, 200, "text/plain; version=0.0.4", text, n, 1);
}
