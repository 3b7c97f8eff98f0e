/* store_claims: how many tile claims a job store sustains, through
 * daemon/store's API alone, for the bench's store section (bench/README.md).
 *
 *   store_claims SPEC [--threads N] [--seconds S] [--payload FILE | --payload-bytes B]
 *                [--queue D] [--tiles T] [--lease-ms L]
 *
 * SPEC is what rd_store_open takes: a folder (SQLite) or a PostgreSQL URL
 * or conninfo. The queue holds D jobs of T tiles and one pass (default 2
 * of 510: the 64-pixel tiles of a 1920x1080 frame, the one in progress and
 * the next). N threads, each with a handle of its own as N daemons' render
 * threads would have (connected before the clock starts), loop for S
 * seconds: rd_store_claim of one tile for daemon "claims-I" with a lease of
 * L ms, then rd_store_tile_done of that tile with the payload as its result
 * (the FILE's bytes, say a real tile's; or B bytes of a fixed pattern,
 * default 16). Nothing is rendered: the figure is the store's. The thread
 * whose tile_done completes a job marks it done with a 16-byte stand-in PNG,
 * as a daemon does once it has assembled the image (it does not read the
 * tiles back), which drops that job's tiles, and commits a new job at the
 * end of the queue, so that the queue keeps D jobs. A claim that finds
 * nothing (between two jobs) is counted and tried again after 1 ms. Every
 * job is deleted at the end.
 *
 * Prints one JSON object on stdout: the engine, threads, payload bytes, the
 * queue, the tiles done, the seconds from the start to the last thread's
 * end, tiles per second, the latencies of the claims and of the tile_done
 * calls (p50, p99, ms; a tile_done that completed a job also counts its
 * finish and the next job's commit), tiles per thread, empty claims, errors
 * by code and the first error's message. Exit 0; 1 usage; 2 the store could
 * not be opened or the first jobs not made. */
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "store.h"

#define MAX_THREADS 64

typedef struct {
    double *v;
    size_t n, cap;
} samples;

typedef struct {
    int index;
    const char *spec;
    const rd_store_options *opt;
    const unsigned char *payload;
    size_t payload_len;
    int lease_ms;
    pthread_barrier_t *ready, *go;
    const double *deadline;
    const char *prefix;
    int tiles;
    int64_t submit_base;
    atomic_int *next_job;
    rd_store *s;
    int open_failed;
    char daemon[32];
    long done, empty, errors[RD_ERROR_COUNT];
    double end_ms;
    samples claim_ms, done_ms;
    char first_error[600];
} worker;

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec / 1e6;
}

static void push(samples *s, double x)
{
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 4096;
        double *v = realloc(s->v, cap * sizeof *v);
        if (!v)
            return; /* a latency lost, not the run */
        s->v = v;
        s->cap = cap;
    }
    s->v[s->n++] = x;
}

static void failed(worker *w, const rd_error *err)
{
    w->errors[err->code < RD_ERROR_COUNT ? err->code : RD_ERR_IO]++;
    if (!w->first_error[0])
        snprintf(w->first_error, sizeof w->first_error, "%s: %s", rd_error_name(err->code), err->message);
}

static rd_error_code make_job(rd_store *s, const char *prefix, int k, int tiles, int64_t submit_base, rd_error *err)
{
    char id[RD_STORE_ID_MAX];
    snprintf(id, sizeof id, "%s-%d", prefix, k);
    rd_store_job_spec js = {.id = id,
                            .scene = "bench",
                            .scene_len = 5,
                            .format = "cfg",
                            .width = 1920,
                            .height = 1080,
                            .submitted_ms = submit_base + k,
                            .tiles = tiles,
                            .passes = 1};
    return rd_store_job_create(s, &js, err);
}

static void sleep_1ms(void)
{
    struct timespec ts = {0, 1000000L};
    nanosleep(&ts, NULL);
}

static void *work(void *arg)
{
    worker *w = arg;
    rd_error err = {0};
    w->s = rd_store_open(w->spec, w->opt, &err);
    if (!w->s) {
        w->open_failed = 1;
        failed(w, &err);
    }
    pthread_barrier_wait(w->ready);
    pthread_barrier_wait(w->go);
    if (!w->s)
        return NULL;
    static const unsigned char png[16] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    for (;;) {
        double t0 = now_ms();
        if (t0 >= *w->deadline)
            break;
        rd_store_tile t;
        int n = 0;
        rd_error_code rc = rd_store_claim(w->s, w->daemon, 1, w->lease_ms, &t, &n, &err);
        double t1 = now_ms();
        if (rc) {
            failed(w, &err);
            if (rc == RD_ERR_IO)
                break;
            continue;
        }
        push(&w->claim_ms, t1 - t0);
        if (n == 0) {
            w->empty++;
            sleep_1ms();
            continue;
        }
        rd_store_tile_outcome out = RD_STORE_TILE_MORE;
        rc = rd_store_tile_done(w->s, w->daemon, &t, w->payload, w->payload_len, &out, &err);
        if (!rc && out == RD_STORE_TILE_JOB_DONE) {
            rd_store_result r = {png, sizeof png, NULL, 0, NULL};
            if (rd_store_job_finish(w->s, t.job_id, &r, &err))
                failed(w, &err);
            int k = atomic_fetch_add(w->next_job, 1);
            if (make_job(w->s, w->prefix, k, w->tiles, w->submit_base, &err))
                failed(w, &err);
        }
        double t2 = now_ms();
        if (rc) {
            failed(w, &err);
            if (rc == RD_ERR_IO)
                break;
            continue;
        }
        push(&w->done_ms, t2 - t1);
        w->done++;
    }
    w->end_ms = now_ms();
    return NULL;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Nearest rank, as the bench's measure.percentile. */
static double percentile(samples *all, double p)
{
    if (all->n == 0)
        return -1;
    double k = p / 100.0 * (double)all->n;
    size_t i = (size_t)k;
    if ((double)i < k)
        i++;
    if (i < 1)
        i = 1;
    if (i > all->n)
        i = all->n;
    return all->v[i - 1];
}

static void merge(samples *all, const samples *s)
{
    for (size_t i = 0; i < s->n; i++)
        push(all, s->v[i]);
}

static void usage(void)
{
    fprintf(stderr, "usage: store_claims SPEC [--threads N] [--seconds S] [--payload FILE | --payload-bytes B]\n"
                    "                    [--queue D] [--tiles T] [--lease-ms L]\n");
    exit(1);
}

static long number(const char *text, long lo, long hi, const char *what)
{
    char *end;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi) {
        fprintf(stderr, "store_claims: %s: expected %ld to %ld, got '%s'\n", what, lo, hi, text);
        exit(1);
    }
    return v;
}

static unsigned char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "store_claims: %s: %s\n", path, strerror(errno));
        exit(1);
    }
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    for (;;) {
        if (!buf) {
            fprintf(stderr, "store_claims: out of memory\n");
            exit(1);
        }
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        cap *= 2;
        buf = realloc(buf, cap);
    }
    fclose(f);
    *len = n;
    return buf;
}

int main(int argc, char **argv)
{
    const char *spec = NULL, *payload_path = NULL;
    int threads = 1, queue = 2, tiles = 510, lease_ms = 60000;
    double seconds = 3;
    size_t payload_len = 16;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (spec)
                usage();
            spec = a;
            continue;
        }
        if (i + 1 >= argc)
            usage();
        const char *v = argv[++i];
        if (!strcmp(a, "--threads"))
            threads = (int)number(v, 1, MAX_THREADS, "--threads");
        else if (!strcmp(a, "--seconds"))
            seconds = (double)number(v, 1, 3600, "--seconds");
        else if (!strcmp(a, "--payload"))
            payload_path = v;
        else if (!strcmp(a, "--payload-bytes"))
            payload_len = (size_t)number(v, 1, 16 << 20, "--payload-bytes");
        else if (!strcmp(a, "--queue"))
            queue = (int)number(v, 1, 100000, "--queue");
        else if (!strcmp(a, "--tiles"))
            tiles = (int)number(v, 1, 1 << 20, "--tiles");
        else if (!strcmp(a, "--lease-ms"))
            lease_ms = (int)number(v, 1, 1 << 30, "--lease-ms");
        else
            usage();
    }
    if (!spec)
        usage();
    unsigned char *payload;
    if (payload_path) {
        payload = read_file(payload_path, &payload_len);
    } else {
        payload = malloc(payload_len);
        if (!payload)
            return 2;
        for (size_t i = 0; i < payload_len; i++)
            payload[i] = (unsigned char)(i * 131u % 251u);
    }

    rd_store_options opt = rd_store_options_default();
    rd_error err = {0};
    rd_store *s = rd_store_open(spec, &opt, &err);
    if (!s) {
        fprintf(stderr, "store_claims: %s: %s\n", spec, err.message);
        return 2;
    }
    char prefix[40];
    snprintf(prefix, sizeof prefix, "claims-%ld-%ld", (long)getpid(), (long)time(NULL));
    int64_t submit_base = rd_wall_ms();
    double t_make = now_ms();
    for (int k = 0; k < queue; k++) {
        if (make_job(s, prefix, k, tiles, submit_base, &err)) {
            fprintf(stderr, "store_claims: making job %d of %d: %s\n", k + 1, queue, err.message);
            return 2;
        }
    }
    t_make = (now_ms() - t_make) / queue;
    atomic_int next_job = queue;

    worker w[MAX_THREADS];
    pthread_t th[MAX_THREADS];
    pthread_barrier_t ready, go;
    double deadline = 0;
    pthread_barrier_init(&ready, NULL, (unsigned)threads + 1);
    pthread_barrier_init(&go, NULL, (unsigned)threads + 1);
    memset(w, 0, sizeof w);
    for (int i = 0; i < threads; i++) {
        w[i] = (worker){.index = i,
                        .spec = spec,
                        .opt = &opt,
                        .payload = payload,
                        .payload_len = payload_len,
                        .lease_ms = lease_ms,
                        .ready = &ready,
                        .go = &go,
                        .deadline = &deadline,
                        .prefix = prefix,
                        .tiles = tiles,
                        .submit_base = submit_base,
                        .next_job = &next_job};
        snprintf(w[i].daemon, sizeof w[i].daemon, "claims-%d", i);
        if (pthread_create(&th[i], NULL, work, &w[i])) {
            fprintf(stderr, "store_claims: cannot start thread %d\n", i);
            return 2;
        }
    }
    /* Every handle is connected once all threads reach the first barrier;
     * the clock starts there, and the deadline written before the second
     * is seen by every thread after it. */
    pthread_barrier_wait(&ready);
    double t0 = now_ms();
    deadline = t0 + seconds * 1e3;
    pthread_barrier_wait(&go);
    for (int i = 0; i < threads; i++)
        pthread_join(th[i], NULL);

    double end = t0;
    long done = 0, empty = 0, errors[RD_ERROR_COUNT] = {0};
    int open_failed = 0;
    const char *first_error = "";
    samples claims = {0}, dones = {0};
    for (int i = 0; i < threads; i++) {
        if (w[i].end_ms > end)
            end = w[i].end_ms;
        done += w[i].done;
        empty += w[i].empty;
        open_failed |= w[i].open_failed;
        for (int c = 0; c < RD_ERROR_COUNT; c++)
            errors[c] += w[i].errors[c];
        if (!first_error[0] && w[i].first_error[0])
            first_error = w[i].first_error;
        merge(&claims, &w[i].claim_ms);
        merge(&dones, &w[i].done_ms);
    }
    qsort(claims.v, claims.n, sizeof *claims.v, cmp_double);
    qsort(dones.v, dones.n, sizeof *dones.v, cmp_double);
    double secs = (end - t0) / 1e3;

    printf("{\"engine\": \"%s\", \"threads\": %d, \"payload_bytes\": %zu, \"queue\": %d, \"tiles_per_job\": %d, "
           "\"make_job_ms\": %.1f, \"jobs_done\": %d, \"tiles_done\": %ld, \"seconds\": %.3f, \"tiles_per_s\": %.1f, "
           "\"claim_p50_ms\": %.3f, \"claim_p99_ms\": %.3f, \"done_p50_ms\": %.3f, \"done_p99_ms\": %.3f, "
           "\"empty_claims\": %ld, \"open_failed\": %s, \"per_thread\": [",
           rd_store_engine_name(s), threads, payload_len, queue, tiles, t_make, atomic_load(&next_job) - queue, done,
           secs, secs > 0 ? (double)done / secs : 0.0, percentile(&claims, 50), percentile(&claims, 99),
           percentile(&dones, 50), percentile(&dones, 99), empty, open_failed ? "true" : "false");
    for (int i = 0; i < threads; i++)
        printf("%s%ld", i ? ", " : "", w[i].done);
    printf("], \"errors\": {");
    for (int c = 0, k = 0; c < RD_ERROR_COUNT; c++)
        if (errors[c])
            printf("%s\"%s\": %ld", k++ ? ", " : "", rd_error_name((rd_error_code)c), errors[c]);
    printf("}, \"first_error\": \"");
    for (const char *p = first_error; *p; p++)
        if (*p == '"' || *p == '\\')
            printf("\\%c", *p);
        else if ((unsigned char)*p >= 0x20)
            putchar(*p);
    printf("\"}\n");

    for (int i = 0; i < threads; i++) {
        rd_store_close(w[i].s);
        free(w[i].claim_ms.v);
        free(w[i].done_ms.v);
    }
    for (int k = 0, made = atomic_load(&next_job); k < made; k++) {
        char id[RD_STORE_ID_MAX];
        snprintf(id, sizeof id, "%s-%d", prefix, k);
        rd_store_job_delete(s, id, NULL);
    }
    rd_store_close(s);
    pthread_barrier_destroy(&ready);
    pthread_barrier_destroy(&go);
    free(claims.v);
    free(dones.v);
    free(payload);
    return 0;
}
