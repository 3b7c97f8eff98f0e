#include "store_cases.h"

#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "migrations.h"
#include "rayd/clock.h"
#include "store_internal.h"

static const char scene[] = "[render]\nwidth = 8\nheight = 8\n";

rd_store *store_env_open(const store_env *e)
{
    rd_error err = {0};
    rd_store *s = rd_store_open(e->spec, &e->opt, &err);
    cr_assert(s, "rd_store_open(%s): %s", e->spec, err.message);
    return s;
}

void sleep_ms_store(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

#define OK(call)                                                                                                       \
    do {                                                                                                               \
        rd_error e_ = {0};                                                                                             \
        rd_error_code c_ = (call);                                                                                     \
        cr_assert_eq(c_, RD_OK, "%s: %s (%s)", #call, e_.message, rd_error_name(c_));                                  \
    } while (0)

/* The call, with `&e_` as its error, fails with code want. */
#define FAILS(want, call)                                                                                              \
    do {                                                                                                               \
        rd_error e_ = {0};                                                                                             \
        rd_error_code c_ = (call);                                                                                     \
        cr_assert_eq(c_, (want), "%s: %s, not %s (%s)", #call, rd_error_name(c_), rd_error_name(want), e_.message);    \
        cr_assert_eq(e_.code, (want), "%s: the error's code", #call);                                                  \
        cr_assert(e_.message[0], "%s: no message", #call);                                                             \
    } while (0)

static rd_store_job_spec spec_of(const char *id, int64_t submitted_ms, int tiles, int passes)
{
    rd_store_job_spec j = {.id = id,
                           .scene = scene,
                           .scene_len = sizeof scene - 1,
                           .format = "cfg",
                           .query = "samples=4",
                           .width = 8,
                           .height = 8,
                           .memory_bytes = 4096,
                           .submitted_ms = submitted_ms,
                           .tiles = tiles,
                           .passes = passes};
    return j;
}

void store_put_job(rd_store *s, const char *id, int64_t submitted_ms, int tiles, int passes)
{
    rd_store_job_spec j = spec_of(id, submitted_ms, tiles, passes);
    OK(rd_store_job_create(s, &j, &e_));
}

static rd_store_job_info info_of(rd_store *s, const char *id)
{
    rd_store_job_info in;
    OK(rd_store_job_get(s, id, &in, &e_));
    return in;
}

static rd_store_status status_of(rd_store *s, const char *id)
{
    rd_store_job_info in = info_of(s, id);
    rd_store_job_info_free(&in);
    return in.status;
}

void case_create_get(const store_env *e)
{
    rd_store *s = store_env_open(e);
    cr_assert(strcmp(rd_store_engine_name(s), "sqlite") == 0 || strcmp(rd_store_engine_name(s), "postgresql") == 0);
    OK(rd_store_ping(s, &e_));
    /* Any bytes, a NUL among them; a size past 32 bits. */
    static const char bytes[] = "{\"a\":\0\xff\x01}";
    rd_store_job_spec j = {.id = "0123456789abcdef",
                           .scene = bytes,
                           .scene_len = sizeof bytes,
                           .format = "json",
                           .query = "width=320&samples=4&gamma=2.2",
                           .hdr = 1,
                           .width = 320,
                           .height = 240,
                           .memory_bytes = 12345678901LL,
                           .submitted_ms = 1700000000123LL};
    OK(rd_store_job_create(s, &j, &e_));
    rd_store_job_info in = info_of(s, j.id);
    cr_assert_str_eq(in.id, j.id);
    cr_assert_eq(in.status, RD_STORE_QUEUED);
    cr_assert_str_eq(in.format, "json");
    cr_assert(in.hdr == 1 && in.width == 320 && in.height == 240);
    cr_assert_eq(in.memory_bytes, 12345678901LL);
    cr_assert_eq(in.submitted_ms, 1700000000123LL);
    cr_assert(in.started_ms == 0 && in.finished_ms == 0 && in.error.code == RD_OK && !in.stats);
    cr_assert(in.tiles_total == 0 && in.passes == 0 && in.png_bytes == 0 && in.exr_bytes == 0);
    rd_store_job_input inp;
    OK(rd_store_job_input_get(s, j.id, &inp, &e_));
    cr_assert_eq(inp.scene_len, sizeof bytes);
    cr_assert_eq(memcmp(inp.scene, bytes, sizeof bytes), 0, "the scene's bytes come back as they went");
    cr_assert_eq(inp.scene[inp.scene_len], '\0');
    cr_assert_str_eq(inp.query, j.query);
    cr_assert_str_eq(inp.format, "json");
    cr_assert(inp.hdr == 1 && inp.width == 320 && inp.height == 240 && inp.memory_bytes == 12345678901LL &&
              inp.submitted_ms == j.submitted_ms);
    rd_store_job_input_free(&inp);
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "nosuchjob", &in, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_input_get(s, "nosuchjob", &inp, &e_));
    /* No query is an empty one. */
    rd_store_job_spec k = spec_of("noquery", 1, 0, 0);
    k.query = NULL;
    OK(rd_store_job_create(s, &k, &e_));
    OK(rd_store_job_input_get(s, "noquery", &inp, &e_));
    cr_assert_str_eq(inp.query, "");
    rd_store_job_input_free(&inp);
    rd_store_close(s);
}

static void fill(unsigned char *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++)
        p[i] = (unsigned char)((i * 2654435761u + seed) >> 13);
}

static void check_image(rd_store *s, const char *id, rd_store_image_kind kind, const unsigned char *want, size_t n)
{
    unsigned char *d = NULL;
    size_t len = 0;
    OK(rd_store_job_image(s, id, kind, &d, &len, &e_));
    cr_assert_eq(len, n);
    cr_assert_eq(memcmp(d, want, n), 0, "the image's bytes come back as they went");
    free(d);
}

static void lifecycle_done(rd_store *s)
{
    static unsigned char png[1000], exr[3000];
    fill(png, sizeof png, 1);
    fill(exr, sizeof exr, 2);
    int64_t before = rd_wall_ms();
    store_put_job(s, "a", 1, 0, 0);
    unsigned char *d;
    size_t len;
    FAILS(RD_ERR_INVALID, rd_store_job_image(s, "a", RD_STORE_PNG, &d, &len, &e_));
    OK(rd_store_job_start(s, "a", &e_));
    OK(rd_store_job_start(s, "a", &e_));
    OK(rd_store_job_stats(s, "a", "{\"samples\":4,\"name\":\"\xc3\xa9\"}", &e_));
    rd_store_job_info in = info_of(s, "a");
    cr_assert_eq(in.status, RD_STORE_RUNNING);
    cr_assert(in.started_ms >= before - 5000 && in.started_ms <= before + 5000, "started %lld, now %lld",
              (long long)in.started_ms, (long long)before);
    cr_assert_str_eq(in.stats, "{\"samples\":4,\"name\":\"\xc3\xa9\"}");
    rd_store_job_info_free(&in);
    rd_store_result r = {.png = png, .png_len = sizeof png, .exr = exr, .exr_len = sizeof exr, .stats = "{\"rays\":9}"};
    OK(rd_store_job_finish(s, "a", &r, &e_));
    in = info_of(s, "a");
    cr_assert_eq(in.status, RD_STORE_DONE);
    cr_assert(in.finished_ms >= in.started_ms && in.png_bytes == sizeof png && in.exr_bytes == sizeof exr);
    cr_assert_str_eq(in.stats, "{\"rays\":9}");
    rd_store_job_info_free(&in);
    check_image(s, "a", RD_STORE_PNG, png, sizeof png);
    check_image(s, "a", RD_STORE_EXR, exr, sizeof exr);
    /* An ended job stays as it ended. */
    FAILS(RD_ERR_CANCELLED, rd_store_job_finish(s, "a", &r, &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_job_start(s, "a", &e_));
    int changed = 7;
    OK(rd_store_job_cancel(s, "a", &changed, &e_));
    cr_assert_eq(changed, 0);
    cr_assert_eq(status_of(s, "a"), RD_STORE_DONE);
}

static void lifecycle_others(rd_store *s)
{
    unsigned char png[10] = {1, 2, 3};
    unsigned char *d;
    size_t len;
    store_put_job(s, "b", 2, 0, 0);
    rd_store_result r = {.png = png, .png_len = sizeof png};
    OK(rd_store_job_finish(s, "b", &r, &e_));
    FAILS(RD_ERR_INVALID, rd_store_job_image(s, "b", RD_STORE_EXR, &d, &len, &e_));
    store_put_job(s, "c", 3, 0, 0);
    rd_error why = {.code = RD_ERR_SYNTAX, .line = 3, .column = 7};
    snprintf(why.message, sizeof why.message, "<upload>:3:7: expected '='");
    OK(rd_store_job_fail(s, "c", &why, NULL, &e_));
    rd_store_job_info in = info_of(s, "c");
    cr_assert_eq(in.status, RD_STORE_FAILED);
    cr_assert(in.error.code == RD_ERR_SYNTAX && in.error.line == 3 && in.error.column == 7);
    cr_assert_str_eq(in.error.message, why.message);
    cr_assert(in.finished_ms > 0);
    rd_store_job_info_free(&in);
    FAILS(RD_ERR_INVALID, rd_store_job_image(s, "c", RD_STORE_PNG, &d, &len, &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_job_fail(s, "c", &why, NULL, &e_));
    store_put_job(s, "d", 4, 0, 0);
    int changed = 0;
    OK(rd_store_job_cancel(s, "d", &changed, &e_));
    cr_assert_eq(changed, 1);
    cr_assert_eq(status_of(s, "d"), RD_STORE_CANCELLED);
    FAILS(RD_ERR_CANCELLED, rd_store_job_start(s, "d", &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_job_stats(s, "d", "{}", &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_job_finish(s, "d", &r, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_start(s, "nosuch", &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_finish(s, "nosuch", &r, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_cancel(s, "nosuch", NULL, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_image(s, "nosuch", RD_STORE_PNG, &d, &len, &e_));
}

void case_lifecycle(const store_env *e)
{
    rd_store *s = store_env_open(e);
    lifecycle_done(s);
    lifecycle_others(s);
    rd_store_close(s);
}

static void end_job(rd_store *s, const char *id)
{
    unsigned char png[4] = {9};
    rd_store_result r = {.png = png, .png_len = sizeof png};
    OK(rd_store_job_finish(s, id, &r, &e_));
}

void case_list_expire_delete(const store_env *e)
{
    rd_store *s = store_env_open(e);
    store_put_job(s, "j3", 300, 0, 0);
    store_put_job(s, "j1", 100, 0, 0);
    store_put_job(s, "j2", 200, 0, 0);
    store_put_job(s, "j4", 400, 0, 0);
    store_put_job(s, "j0", 50, 0, 0);
    end_job(s, "j1");
    OK(rd_store_job_cancel(s, "j4", NULL, &e_));
    rd_store_job_brief *l = NULL;
    size_t n = 0;
    OK(rd_store_jobs_list(s, RD_STORE_MASK(RD_STORE_QUEUED), 100, &l, &n, &e_));
    cr_assert_eq(n, 3);
    cr_assert(strcmp(l[0].id, "j0") == 0 && strcmp(l[1].id, "j2") == 0 && strcmp(l[2].id, "j3") == 0,
              "oldest submission first");
    cr_assert(l[0].status == RD_STORE_QUEUED && l[0].submitted_ms == 50);
    free(l);
    OK(rd_store_jobs_list(s, ~0u, 2, &l, &n, &e_));
    cr_assert(n == 2 && strcmp(l[0].id, "j0") == 0 && strcmp(l[1].id, "j1") == 0 && l[1].status == RD_STORE_DONE);
    free(l);
    OK(rd_store_jobs_list(s, RD_STORE_MASK(RD_STORE_FAILED), 10, &l, &n, &e_));
    cr_assert(n == 0 && l == NULL);
    size_t gone = 99;
    OK(rd_store_jobs_expire(s, 3600 * 1000, &gone, &e_));
    cr_assert_eq(gone, 0, "nothing ended an hour ago");
    sleep_ms_store(50);
    OK(rd_store_jobs_expire(s, 10, &gone, &e_));
    cr_assert_eq(gone, 2, "the two ended jobs, not the queued ones");
    rd_store_job_info in;
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "j1", &in, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "j4", &in, &e_));
    cr_assert_eq(status_of(s, "j2"), RD_STORE_QUEUED);
    OK(rd_store_job_delete(s, "j2", &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "j2", &in, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_delete(s, "j2", &e_));
    OK(rd_store_jobs_list(s, ~0u, 100, &l, &n, &e_));
    cr_assert_eq(n, 2);
    free(l);
    rd_store_close(s);
}

static int claim(rd_store *s, const char *daemon, int max, int lease_ms, rd_store_tile *out)
{
    int n = -1;
    OK(rd_store_claim(s, daemon, max, lease_ms, out, &n, &e_));
    cr_assert(n >= 0 && n <= max);
    return n;
}

static rd_store_tile_outcome tile_done(rd_store *s, const char *daemon, const rd_store_tile *t, const char *data)
{
    rd_store_tile_outcome o = (rd_store_tile_outcome)-1;
    OK(rd_store_tile_done(s, daemon, t, data, strlen(data), &o, &e_));
    return o;
}

/* Done every claimed tile of a pass with "t<index>p<pass>": the outcomes. */
static void do_pass(rd_store *s, const char *id, int tiles, int pass)
{
    rd_store_tile t[16];
    int n = claim(s, "d1", 16, 10000, t);
    cr_assert_eq(n, tiles, "pass %d: all %d tiles claimable, got %d", pass, tiles, n);
    for (int i = 0; i < n; i++) {
        cr_assert(strcmp(t[i].job_id, id) == 0 && t[i].index == i && t[i].pass == pass);
        char data[32];
        snprintf(data, sizeof data, "t%dp%d", i, pass);
        rd_store_tile_outcome o = tile_done(s, "d1", &t[i], data);
        rd_store_tile_outcome want = i < n - 1 ? RD_STORE_TILE_MORE : RD_STORE_TILE_PASS_DONE;
        if (i == n - 1 && pass == 1)
            want = RD_STORE_TILE_JOB_DONE;
        cr_assert_eq(o, want, "tile %d of pass %d: outcome %d", i, pass, (int)o);
    }
}

static void check_tiles(rd_store *s, const char *id, int tiles, int passes)
{
    rd_store_tile_data *td = NULL;
    size_t n = 0;
    OK(rd_store_tiles_get(s, id, &td, &n, &e_));
    cr_assert_eq(n, (size_t)tiles);
    for (size_t i = 0; i < n; i++) {
        char want[48];
        snprintf(want, sizeof want, "t%zup%d", i, passes - 1);
        cr_assert(td[i].index == (int)i && td[i].passes == passes && td[i].len == strlen(want));
        cr_assert_eq(memcmp(td[i].data, want, td[i].len), 0);
    }
    rd_store_tiles_free(td, n);
}

/* The first pass of tj (5 tiles) by hand: claims, a tile done twice, a
 * pass completed. */
static void first_pass(rd_store *s)
{
    rd_store_job_info in = info_of(s, "tj");
    cr_assert(in.tiles_total == 5 && in.tiles_done == 0 && in.pass == 0 && in.passes == 2);
    rd_store_tile_data one;
    OK(rd_store_tile_get(s, "tj", 4, &one, &e_));
    cr_assert(one.index == 4 && one.passes == 0 && one.data == NULL);
    rd_store_tile t[8];
    cr_assert_eq(claim(s, "d1", 3, 10000, t), 3);
    cr_assert(t[0].index == 0 && t[1].index == 1 && t[2].index == 2 && t[0].pass == 0);
    in = info_of(s, "tj");
    cr_assert(in.status == RD_STORE_RUNNING && in.started_ms > 0, "a claim starts the job");
    cr_assert_eq(tile_done(s, "d1", &t[1], "x"), RD_STORE_TILE_MORE);
    in = info_of(s, "tj");
    cr_assert(in.tiles_done == 1 && in.pass == 0);
    /* A tile is done once per pass. */
    FAILS(RD_ERR_TIMEOUT, rd_store_tile_done(s, "d1", &t[1], "y", 1, NULL, &e_));
    cr_assert_eq(tile_done(s, "d1", &t[0], "t0p0"), RD_STORE_TILE_MORE);
    cr_assert_eq(tile_done(s, "d1", &t[2], "t2p0"), RD_STORE_TILE_MORE);
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 2, "the two left");
    cr_assert(t[0].index == 3 && t[1].index == 4);
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 0, "nothing until the pass ends");
    /* The re-done tile 1 of the first claim is no one's. */
    rd_store_tile t1 = {.index = 1, .pass = 0};
    snprintf(t1.job_id, sizeof t1.job_id, "tj");
    cr_assert_eq(tile_done(s, "d1", &t[0], "t3p0"), RD_STORE_TILE_MORE);
    cr_assert_eq(tile_done(s, "d1", &t[1], "t4p0"), RD_STORE_TILE_PASS_DONE);
    FAILS(RD_ERR_TIMEOUT, rd_store_tile_done(s, "d1", &t1, "z", 1, NULL, &e_));
    in = info_of(s, "tj");
    cr_assert(in.pass == 1 && in.tiles_done == 0, "pass %d, %d tiles", in.pass, in.tiles_done);
    OK(rd_store_tile_get(s, "tj", 2, &one, &e_));
    cr_assert(one.passes == 1 && one.len == 4 && memcmp(one.data, "t2p0", 4) == 0);
    free(one.data);
}

void case_tiles_and_passes(const store_env *e)
{
    rd_store *s = store_env_open(e);
    store_put_job(s, "tj", 10, 5, 2);
    first_pass(s);
    rd_store_tile t[8];
    rd_store_tile_data one;
    do_pass(s, "tj", 5, 1);
    rd_store_job_info in = info_of(s, "tj");
    cr_assert(in.pass == 2 && in.tiles_done == 5 && in.status == RD_STORE_RUNNING);
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 0, "a complete job has nothing to claim");
    check_tiles(s, "tj", 5, 2);
    end_job(s, "tj");
    rd_store_tile_data *td = NULL;
    size_t n = 9;
    OK(rd_store_tiles_get(s, "tj", &td, &n, &e_));
    cr_assert(n == 0 && td == NULL, "an ended job's tiles are dropped");
    FAILS(RD_ERR_NOT_FOUND, rd_store_tile_get(s, "tj", 0, &one, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_tiles_get(s, "nosuch", &td, &n, &e_));
    /* Tiles made later, once. */
    store_put_job(s, "later", 20, 0, 0);
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 0, "a job without tiles is not claimable");
    OK(rd_store_tiles_init(s, "later", 3, 1, &e_));
    FAILS(RD_ERR_INVALID, rd_store_tiles_init(s, "later", 3, 1, &e_));
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 3);
    /* Cancelling drops the tiles under their holder. */
    OK(rd_store_job_cancel(s, "later", NULL, &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_tile_done(s, "d1", &t[0], "r", 1, NULL, &e_));
    FAILS(RD_ERR_CANCELLED, rd_store_tiles_init(s, "tj", 3, 1, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_tiles_init(s, "nosuch", 3, 1, &e_));
    rd_store_close(s);
}

void case_claim_oldest_job_first(const store_env *e)
{
    rd_store *s = store_env_open(e);
    store_put_job(s, "young", 2000, 2, 1);
    store_put_job(s, "old", 1000, 2, 1);
    store_put_job(s, "notiles", 500, 0, 0);
    rd_store_tile t[8];
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 2, "one job per claim");
    cr_assert(strcmp(t[0].job_id, "old") == 0 && strcmp(t[1].job_id, "old") == 0);
    cr_assert_eq(claim(s, "d1", 8, 10000, t), 2);
    cr_assert(strcmp(t[0].job_id, "young") == 0);
    cr_assert_eq(status_of(s, "notiles"), RD_STORE_QUEUED);
    rd_store_close(s);
}

static int disjoint(const rd_store_tile *a, int na, const rd_store_tile *b, int nb)
{
    for (int i = 0; i < na; i++)
        for (int j = 0; j < nb; j++)
            if (a[i].index == b[j].index)
                return 0;
    return 1;
}

void case_lease_expiry(const store_env *e)
{
    rd_store *a = store_env_open(e), *b = store_env_open(e);
    store_put_job(a, "lj", 1, 6, 1);
    rd_store_tile ta[8], tb[8], tc[8];
    cr_assert_eq(claim(a, "daemon-a", 3, 300, ta), 3);
    cr_assert_eq(claim(b, "daemon-b", 8, 60000, tb), 3, "the other three");
    cr_assert(disjoint(ta, 3, tb, 3), "a live lease is never handed out again");
    cr_assert_eq(claim(b, "daemon-b", 8, 60000, tc), 0);
    sleep_ms_store(500);
    cr_assert_eq(claim(b, "daemon-b", 8, 60000, tc), 3, "a's leases ran out");
    cr_assert(!disjoint(ta, 3, tc, 3) && disjoint(tb, 3, tc, 3));
    FAILS(RD_ERR_TIMEOUT, rd_store_tile_done(a, "daemon-a", &ta[0], "late", 4, NULL, &e_));
    int renewed = -1;
    OK(rd_store_renew(a, "daemon-a", 1000, &renewed, &e_));
    cr_assert_eq(renewed, 0, "a lease taken by another is not renewed");
    int job_done = 0;
    for (int i = 0; i < 3; i++) {
        job_done += tile_done(b, "daemon-b", &tb[i], "b") == RD_STORE_TILE_JOB_DONE;
        job_done += tile_done(b, "daemon-b", &tc[i], "c") == RD_STORE_TILE_JOB_DONE;
    }
    cr_assert_eq(job_done, 1);
    rd_store_close(a);
    rd_store_close(b);
}

void case_renew_and_release(const store_env *e)
{
    rd_store *a = store_env_open(e), *b = store_env_open(e);
    store_put_job(a, "rj", 1, 2, 1);
    rd_store_tile ta[4], tb[4];
    double t0 = rd_now_ms();
    cr_assert_eq(claim(a, "daemon-a", 4, 1000, ta), 2);
    sleep_ms_store(500);
    int renewed = 0;
    OK(rd_store_renew(a, "daemon-a", 1000, &renewed, &e_));
    cr_assert_eq(renewed, 2);
    sleep_ms_store(1200 - (long)(rd_now_ms() - t0));
    /* Past the first lease, within the renewed one. */
    cr_assert_lt(rd_now_ms() - t0, 1450, "the machine is too slow for this test's margins");
    cr_assert_eq(claim(b, "daemon-b", 4, 60000, tb), 0, "renewed leases hold");
    int released = 0;
    OK(rd_store_release(a, "daemon-a", &released, &e_));
    cr_assert_eq(released, 2);
    cr_assert_eq(claim(b, "daemon-b", 4, 60000, tb), 2, "released tiles are claimable at once");
    FAILS(RD_ERR_TIMEOUT, rd_store_tile_done(a, "daemon-a", &ta[0], "x", 1, NULL, &e_));
    rd_store_close(a);
    rd_store_close(b);
}

/* Concurrent claims. */

#define MAX_TILES 1024

typedef struct {
    const store_env *env;
    char daemon[16];
    atomic_int *claims; /* [pass * tiles + index]: times claimed by live daemons */
    atomic_int *dones;  /* times done */
    atomic_int *pass_done, *job_done, *errors;
    int tiles;
    double deadline;
    int claimed; /* by this thread */
} farm_arg;

static void farm_tile(farm_arg *f, rd_store *s, const rd_store_tile *t)
{
    int k = t->pass * f->tiles + t->index;
    atomic_fetch_add(&f->claims[k], 1);
    char data[32];
    snprintf(data, sizeof data, "%s:%d:%d", f->daemon, t->pass, t->index);
    rd_store_tile_outcome o;
    rd_error err = {0};
    rd_error_code rc;
    /* Busy is "try again" (store.h): other writers held SQLite's lock past
     * the timeout, which a loaded machine makes happen. */
    while ((rc = rd_store_tile_done(s, f->daemon, t, data, strlen(data), &o, &err)) == RD_ERR_BUSY)
        ;
    if (rc != RD_OK) {
        atomic_fetch_add(f->errors, 1);
        return;
    }
    atomic_fetch_add(&f->dones[k], 1);
    if (o == RD_STORE_TILE_PASS_DONE)
        atomic_fetch_add(f->pass_done, 1);
    if (o == RD_STORE_TILE_JOB_DONE)
        atomic_fetch_add(f->job_done, 1);
}

static void *farm_main(void *arg)
{
    farm_arg *f = arg;
    rd_error err = {0};
    rd_store *s = rd_store_open(f->env->spec, &f->env->opt, &err);
    /* Opening reads the schema in a transaction: busy, too, means try again. */
    for (int i = 0; !s && err.code == RD_ERR_BUSY && i < 10; i++)
        s = rd_store_open(f->env->spec, &f->env->opt, &err);
    if (!s) {
        atomic_fetch_add(f->errors, 1);
        return NULL;
    }
    rd_store_tile t[4];
    while (!atomic_load(f->job_done) && rd_now_ms() < f->deadline) {
        int n = 0;
        rd_error_code rc = rd_store_claim(s, f->daemon, 4, 60000, t, &n, &err);
        if (rc == RD_ERR_BUSY)
            continue;
        if (rc != RD_OK) {
            atomic_fetch_add(f->errors, 1);
            break;
        }
        for (int i = 0; i < n; i++)
            farm_tile(f, s, &t[i]);
        f->claimed += n;
        if (n == 0)
            sleep_ms_store(5); /* the pass's last tiles are another's */
    }
    rd_store_close(s);
    return NULL;
}

/* A daemon that claims tiles with a short lease and dies. */
static int farm_casualty(const store_env *e)
{
    rd_store *s = store_env_open(e);
    rd_store_tile t[5];
    int n = claim(s, "casualty", 5, 400, t);
    rd_store_close(s);
    return n;
}

void case_concurrent_claims(const store_env *e, int threads, int tiles, int passes)
{
    cr_assert(threads <= 8 && tiles * passes <= MAX_TILES);
    rd_store *s = store_env_open(e);
    store_put_job(s, "farm", 1, tiles, passes);
    static atomic_int claims[MAX_TILES], dones[MAX_TILES];
    for (int k = 0; k < MAX_TILES; k++) {
        atomic_store(&claims[k], 0);
        atomic_store(&dones[k], 0);
    }
    atomic_int pass_done = 0, job_done = 0, errors = 0;
    cr_assert_eq(farm_casualty(e), 5);
    farm_arg args[8];
    pthread_t th[8];
    double t0 = rd_now_ms();
    for (int i = 0; i < threads; i++) {
        args[i] = (farm_arg){.env = e,
                             .claims = claims,
                             .dones = dones,
                             .pass_done = &pass_done,
                             .job_done = &job_done,
                             .errors = &errors,
                             .tiles = tiles,
                             .deadline = t0 + 20000};
        snprintf(args[i].daemon, sizeof args[i].daemon, "daemon-%d", i);
        cr_assert_eq(pthread_create(&th[i], NULL, farm_main, &args[i]), 0);
    }
    for (int i = 0; i < threads; i++)
        pthread_join(th[i], NULL);
    double ms = rd_now_ms() - t0;
    cr_assert_eq(atomic_load(&errors), 0, "claims and tile results all succeed");
    for (int k = 0; k < tiles * passes; k++) {
        cr_assert_eq(atomic_load(&claims[k]), 1, "tile %d of pass %d claimed %d times", k % tiles, k / tiles,
                     atomic_load(&claims[k]));
        cr_assert_eq(atomic_load(&dones[k]), 1);
    }
    cr_assert_eq(atomic_load(&pass_done), passes - 1);
    cr_assert_eq(atomic_load(&job_done), 1);
    int took_part = 0;
    for (int i = 0; i < threads; i++)
        took_part += args[i].claimed > 0;
    /* SQLite lets one writer in at a time and its busy handler is not fair:
     * one handle may win every claim. Only PostgreSQL's SKIP LOCKED claims
     * run side by side, so only there must the work be shared. */
    if (strcmp(rd_store_engine_name(s), "postgresql") == 0)
        cr_assert_geq(took_part, 2, "the work was shared");
    rd_store_job_info in = info_of(s, "farm");
    cr_assert(in.pass == passes && in.tiles_done == tiles);
    if (getenv("RAYD_STORE_REPORT")) {
        fprintf(stderr, "%s: %d handles, %d tiles x %d passes in %.0f ms (400 of them waiting for a lease):",
                rd_store_engine_name(s), threads, tiles, passes, ms);
        for (int i = 0; i < threads; i++)
            fprintf(stderr, " %d", args[i].claimed);
        fprintf(stderr, "\n");
    }
    rd_store_close(s);
}

/* Durability. */

void case_durable_across_reopen(const store_env *e)
{
    rd_store *s = store_env_open(e);
    char id[16];
    for (int i = 0; i < 20; i++) {
        snprintf(id, sizeof id, "job%02d", i);
        store_put_job(s, id, 100 + i, 4, 1);
    }
    /* Two tiles of each of the first ten done, two held by a daemon that
     * then stops (releasing them) without finishing anything. */
    for (int i = 0; i < 10; i++) {
        rd_store_tile t[4];
        cr_assert_eq(claim(s, "d1", 4, 60000, t), 4);
        snprintf(id, sizeof id, "job%02d", i);
        cr_assert_str_eq(t[0].job_id, id);
        cr_assert_eq(tile_done(s, "d1", &t[0], "t0p0"), RD_STORE_TILE_MORE);
        cr_assert_eq(tile_done(s, "d1", &t[1], "t1p0"), RD_STORE_TILE_MORE);
    }
    int released = 0;
    OK(rd_store_release(s, "d1", &released, &e_));
    cr_assert_eq(released, 20);
    rd_store_close(s);
    s = store_env_open(e);
    rd_store_job_brief *l = NULL;
    size_t n = 0;
    OK(rd_store_jobs_list(s, ~0u, 100, &l, &n, &e_));
    cr_assert_eq(n, 20, "every job is still there");
    free(l);
    for (int i = 0; i < 20; i++) {
        snprintf(id, sizeof id, "job%02d", i);
        rd_store_job_info in = info_of(s, id);
        cr_assert_eq(in.tiles_done, i < 10 ? 2 : 0);
        cr_assert_eq(in.status, i < 10 ? RD_STORE_RUNNING : RD_STORE_QUEUED);
        rd_store_job_info_free(&in);
        rd_store_tile_data *td;
        OK(rd_store_tiles_get(s, id, &td, &n, &e_));
        cr_assert_eq(n, i < 10 ? 2 : 0);
        cr_assert(n == 0 || (td[1].len == 4 && memcmp(td[1].data, "t1p0", 4) == 0));
        rd_store_tiles_free(td, n);
    }
    /* The resumed job goes on with the tiles left. */
    rd_store_tile t[8];
    cr_assert_eq(claim(s, "d2", 8, 60000, t), 2);
    cr_assert(strcmp(t[0].job_id, "job00") == 0 && t[0].index == 2 && t[1].index == 3);
    rd_store_close(s);
}

void case_survives_kill(const store_env *e)
{
    pid_t pid = fork();
    cr_assert_geq(pid, 0);
    if (pid == 0) {
        rd_error err;
        rd_store *s = rd_store_open(e->spec, &e->opt, &err);
        rd_store_job_spec j = spec_of("killed0", 1, 2, 1);
        char id[16];
        for (int i = 0; s && i < 5; i++) {
            snprintf(id, sizeof id, "killed%d", i);
            j.id = id;
            if (rd_store_job_create(s, &j, &err) != RD_OK)
                _exit(3);
        }
        raise(SIGKILL); /* no close, nothing flushed by hand */
        _exit(4);
    }
    int st = 0;
    waitpid(pid, &st, 0);
    cr_assert(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL, "the child died by SIGKILL (status %d)", st);
    rd_store *s = store_env_open(e);
    for (int i = 0; i < 5; i++) {
        char id[16];
        snprintf(id, sizeof id, "killed%d", i);
        cr_assert_eq(status_of(s, id), RD_STORE_QUEUED, "%s survived", id);
    }
    rd_store_close(s);
}

/* Limits and arguments. */

static void limits_refused(const store_env *e)
{
    store_env small = *e;
    small.opt.limits = (rd_store_limits){
        .scene_bytes = 1000, .text_bytes = 100, .image_bytes = 2000, .tile_bytes = 500, .tiles = 10, .passes = 3};
    rd_store *s = store_env_open(&small);
    static char big[4000];
    memset(big, 'x', sizeof big - 1);
    rd_store_job_spec j = spec_of("lim", 1, 0, 0);
    j.scene = big;
    j.scene_len = 1001;
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    j = spec_of("lim", 1, 0, 0);
    j.query = big + sizeof big - 102;
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    j = spec_of("lim", 1, 11, 1);
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    j = spec_of("lim", 1, 10, 4);
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    rd_store_job_info in;
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "lim", &in, &e_));
    store_put_job(s, "lim", 1, 10, 3);
    FAILS(RD_ERR_LIMIT, rd_store_job_stats(s, "lim", big + sizeof big - 102, &e_));
    rd_store_tile t[1];
    cr_assert_eq(claim(s, "d1", 1, 60000, t), 1);
    FAILS(RD_ERR_LIMIT, rd_store_tile_done(s, "d1", &t[0], big, 501, NULL, &e_));
    rd_store_result r = {.png = (const unsigned char *)big, .png_len = 2001};
    FAILS(RD_ERR_LIMIT, rd_store_job_finish(s, "lim", &r, &e_));
    r = (rd_store_result){
        .png = (const unsigned char *)big, .png_len = 10, .exr = (const unsigned char *)big, .exr_len = 2001};
    FAILS(RD_ERR_LIMIT, rd_store_job_finish(s, "lim", &r, &e_));
    in = info_of(s, "lim");
    cr_assert(in.status == RD_STORE_RUNNING && in.tiles_done == 0 && !in.stats, "nothing was changed");
    rd_store_close(s);
}

static void bad_arguments(const store_env *e)
{
    rd_store *s = store_env_open(e);
    rd_store_job_spec j = spec_of("has space", 1, 0, 0);
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j.id = "0123456789012345678901234567890123456789012345678901234567890123";
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j.id = NULL;
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j = spec_of("ok", 1, 0, 0);
    j.format = "xml";
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j = spec_of("ok", 1, 0, 0);
    j.query = "width=\xff";
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j = spec_of("ok", 1, 0, 0);
    j.width = -1;
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    j = spec_of("ok", 1, 3, 0);
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    store_put_job(s, "ok", 1, 2, 1);
    rd_store_tile t[2];
    int n;
    FAILS(RD_ERR_INVALID, rd_store_claim(s, "d1", 0, 1000, t, &n, &e_));
    FAILS(RD_ERR_INVALID, rd_store_claim(s, "d1", 1, 0, t, &n, &e_));
    FAILS(RD_ERR_INVALID, rd_store_claim(s, "bad daemon", 1, 1000, t, &n, &e_));
    FAILS(RD_ERR_INVALID, rd_store_renew(s, "d1", -5, &n, &e_));
    rd_store_tile bad = {.index = -1};
    snprintf(bad.job_id, sizeof bad.job_id, "ok");
    FAILS(RD_ERR_INVALID, rd_store_tile_done(s, "d1", &bad, "x", 1, NULL, &e_));
    rd_error why = {0};
    FAILS(RD_ERR_INVALID, rd_store_job_fail(s, "ok", &why, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_job_finish(s, "ok", NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_tiles_init(s, "ok", 0, 1, &e_));
    FAILS(RD_ERR_INVALID, rd_store_jobs_expire(s, -1, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_job_stats(s, "ok", "\xc3", &e_));
    /* Defaults: a scene far over 16 MiB is refused before it is sent. */
    size_t huge = (size_t)64 << 20;
    char *h = malloc(huge);
    cr_assert(h);
    memset(h, '#', huge);
    j = spec_of("huge", 1, 0, 0);
    j.scene = h;
    j.scene_len = huge;
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    free(h);
    cr_assert_eq(rd_store_open("", NULL, NULL), NULL);
    rd_store_close(NULL);
    rd_store_close(s);
}

void case_limits_and_bad_arguments(const store_env *e)
{
    limits_refused(e);
    bad_arguments(e);
}

/* Wake-ups. */

typedef struct {
    rd_store *s;
    int timeout_ms;
    rd_store_event ev;
    rd_error_code code;
    double woke_at;
} waiter;

static void *wait_main(void *arg)
{
    waiter *w = arg;
    rd_error err = {0};
    w->code = rd_store_wait(w->s, w->timeout_ms, &w->ev, &err);
    w->woke_at = rd_now_ms();
    return NULL;
}

void case_wait_wakes(const store_env *e, double max_ms)
{
    rd_store *a = store_env_open(e), *b = store_env_open(e);
    rd_store_event ev;
    /* Nothing happens: the whole timeout, then NONE. */
    double t0 = rd_now_ms();
    OK(rd_store_wait(a, 200, &ev, &e_));
    cr_assert(ev.kind == RD_STORE_EV_NONE && rd_now_ms() - t0 >= 195, "%.0f ms", rd_now_ms() - t0);
    /* Its own commit does not wake it. */
    store_put_job(a, "own", 1, 0, 0);
    OK(rd_store_wait(a, 200, &ev, &e_));
    cr_assert_eq(ev.kind, RD_STORE_EV_NONE, "woken by its own commit (%d)", (int)ev.kind);
    waiter w = {.s = a, .timeout_ms = 5000};
    pthread_t th;
    cr_assert_eq(pthread_create(&th, NULL, wait_main, &w), 0);
    sleep_ms_store(300);
    /* The waiting handle's other calls are not held up by its wait. */
    double t1 = rd_now_ms();
    OK(rd_store_ping(a, &e_));
    cr_assert_lt(rd_now_ms() - t1, 1000.0);
    store_put_job(b, "theirs", 2, 0, 0);
    double committed = rd_now_ms();
    pthread_join(th, NULL);
    cr_assert_eq(w.code, RD_OK);
    cr_assert_lt(w.woke_at - committed, max_ms, "woke %.1f ms after the commit", w.woke_at - committed);
    if (e->events_named) {
        cr_assert_eq(w.ev.kind, RD_STORE_EV_SUBMITTED);
        cr_assert_str_eq(w.ev.job_id, "theirs");
        unsigned char png[4] = {1};
        rd_store_result r = {.png = png, .png_len = 4};
        OK(rd_store_job_finish(b, "own", &r, &e_));
        OK(rd_store_wait(a, 2000, &ev, &e_));
        cr_assert(ev.kind == RD_STORE_EV_ENDED && strcmp(ev.job_id, "own") == 0);
        OK(rd_store_tiles_init(b, "theirs", 2, 1, &e_));
        OK(rd_store_wait(a, 2000, &ev, &e_));
        cr_assert(ev.kind == RD_STORE_EV_TILES && strcmp(ev.job_id, "theirs") == 0);
    } else {
        cr_assert_eq(w.ev.kind, RD_STORE_EV_CHANGED);
    }
    if (getenv("RAYD_STORE_REPORT"))
        fprintf(stderr, "%s: woke %.2f ms after another handle's commit\n", rd_store_engine_name(a),
                w.woke_at - committed);
    rd_store_close(a);
    rd_store_close(b);
}

/* Gated passes. */

static rd_store_job_spec gated_spec(const char *id, int64_t submitted_ms, int tiles, int passes, const char *schedule)
{
    rd_store_job_spec j = spec_of(id, submitted_ms, tiles, passes);
    j.gated = 1;
    j.schedule = schedule;
    return j;
}

static void put_gated(rd_store *s, const char *id, int64_t submitted_ms, int tiles, int passes, const char *schedule)
{
    rd_store_job_spec j = gated_spec(id, submitted_ms, tiles, passes, schedule);
    OK(rd_store_job_create(s, &j, &e_));
}

/* Claims every tile of pass of job id (all of them must come, and only
 * them) and completes them: the last one's outcome. */
static rd_store_tile_outcome run_pass(rd_store *s, const char *id, int tiles, int pass)
{
    rd_store_tile t[16];
    cr_assert(tiles <= 16);
    int n = claim(s, "d1", 16, 10000, t);
    cr_assert_eq(n, tiles, "pass %d of %s: %d tiles claimed, not %d", pass, id, n, tiles);
    rd_store_tile_outcome o = RD_STORE_TILE_MORE;
    for (int i = 0; i < n; i++) {
        cr_assert(strcmp(t[i].job_id, id) == 0 && t[i].pass == pass, "tile %d of pass %d of %s claimed", t[i].index,
                  t[i].pass, t[i].job_id);
        char data[32];
        snprintf(data, sizeof data, "t%dp%d", t[i].index, pass);
        o = tile_done(s, "d1", &t[i], data);
        if (i < n - 1)
            cr_assert_eq(o, RD_STORE_TILE_MORE, "tile %d of %d", i, n);
    }
    return o;
}

/* pass_open fails with code, and its message says why in words. */
static void open_refused(rd_store *s, const char *id, int pass, const char *schedule, rd_error_code code,
                         const char *words)
{
    rd_error err = {0};
    rd_error_code c = rd_store_pass_open(s, id, pass, schedule, &err);
    cr_assert_eq(c, code, "pass_open(%s, %d): %s, not %s (%s)", id, pass, rd_error_name(c), rd_error_name(code),
                 err.message);
    cr_assert_eq(err.code, code);
    cr_assert(strstr(err.message, words), "pass_open(%s, %d): \"%s\" does not say \"%s\"", id, pass, err.message,
              words);
}

/* The job's gated, open_pass, pass and schedule (NULL: none). */
static void check_gate(rd_store *s, const char *id, int gated, int open_pass, int pass, const char *schedule)
{
    rd_store_job_info in = info_of(s, id);
    cr_assert_eq(in.gated, gated, "%s: gated %d", id, in.gated);
    cr_assert_eq(in.open_pass, open_pass, "%s: open_pass %d, not %d", id, in.open_pass, open_pass);
    cr_assert_eq(in.pass, pass, "%s: pass %d, not %d", id, in.pass, pass);
    if (schedule)
        cr_assert(in.schedule && strcmp(in.schedule, schedule) == 0, "%s: schedule \"%s\", not \"%s\"", id,
                  in.schedule ? in.schedule : "(none)", schedule);
    else
        cr_assert_null(in.schedule, "%s: schedule \"%s\", not none", id, in.schedule);
    rd_store_job_info_free(&in);
    cr_assert(!in.schedule && !in.stats, "rd_store_job_info_free clears what it frees");
}

void case_gated_passes(const store_env *e)
{
    rd_store *s = store_env_open(e), *b = store_env_open(e);
    put_gated(s, "gj", 10, 3, 3, "pass 0: 1 spp");
    store_put_job(s, "uj", 20, 2, 1);
    check_gate(s, "gj", 1, 1, 0, "pass 0: 1 spp");
    cr_assert_eq(run_pass(s, "gj", 3, 0), RD_STORE_TILE_PASS_DONE, "PASS_DONE is still said for a gated job");
    check_gate(s, "gj", 1, 1, 1, "pass 0: 1 spp");
    /* Pass 1 waits for its opening, and the younger job is not held up
     * behind it. */
    cr_assert_eq(run_pass(s, "uj", 2, 0), RD_STORE_TILE_JOB_DONE);
    rd_store_tile t[16];
    cr_assert_eq(claim(s, "d1", 16, 10000, t), 0, "pass 1 of gj is not open");
    cr_assert_eq(claim(b, "d2", 16, 10000, t), 0, "not for another handle either");
    OK(rd_store_pass_open(b, "gj", 1, "pass 1: 4 spp", &e_));
    check_gate(s, "gj", 1, 2, 1, "pass 1: 4 spp");
    cr_assert_eq(run_pass(s, "gj", 3, 1), RD_STORE_TILE_PASS_DONE);
    cr_assert_eq(claim(s, "d1", 16, 10000, t), 0, "pass 2 of gj is not open");
    /* NULL keeps the schedule. */
    OK(rd_store_pass_open(s, "gj", 2, NULL, &e_));
    check_gate(s, "gj", 1, 3, 2, "pass 1: 4 spp");
    cr_assert_eq(run_pass(s, "gj", 3, 2), RD_STORE_TILE_JOB_DONE);
    check_gate(s, "gj", 1, 3, 3, "pass 1: 4 spp");
    check_tiles(s, "gj", 3, 3);
    rd_store_close(s);
    rd_store_close(b);
}

void case_gated_refusals(const store_env *e)
{
    rd_store *s = store_env_open(e);
    put_gated(s, "g1", 10, 2, 3, NULL);
    open_refused(s, "g1", 0, "s", RD_ERR_INVALID, "pass 0");
    rd_store_tile t[4];
    cr_assert_eq(claim(s, "d1", 4, 10000, t), 2);
    cr_assert_eq(tile_done(s, "d1", &t[0], "t0p0"), RD_STORE_TILE_MORE);
    open_refused(s, "g1", 1, "s", RD_ERR_INVALID, "0 of its passes are complete, not 1");
    check_gate(s, "g1", 1, 1, 0, NULL);
    cr_assert_eq(tile_done(s, "d1", &t[1], "t1p0"), RD_STORE_TILE_PASS_DONE);
    open_refused(s, "g1", 2, "s", RD_ERR_INVALID, "1 of its passes are complete, not 2");
    OK(rd_store_pass_open(s, "g1", 1, "first", &e_));
    /* Once: a second opening changes nothing, its schedule included. */
    open_refused(s, "g1", 1, "second", RD_ERR_INVALID, "open already");
    check_gate(s, "g1", 1, 2, 1, "first");
    cr_assert_eq(run_pass(s, "g1", 2, 1), RD_STORE_TILE_PASS_DONE);
    OK(rd_store_pass_open(s, "g1", 2, NULL, &e_));
    cr_assert_eq(run_pass(s, "g1", 2, 2), RD_STORE_TILE_JOB_DONE);
    /* Its pass 3 would be next by the counts, but there is none. */
    check_gate(s, "g1", 1, 3, 3, "first");
    open_refused(s, "g1", 3, NULL, RD_ERR_INVALID, "no pass 3");
    end_job(s, "g1");
    open_refused(s, "g1", 3, NULL, RD_ERR_CANCELLED, "done");
    /* Ended between its pass completing and its next opening. */
    put_gated(s, "g2", 30, 1, 2, "kept");
    cr_assert_eq(run_pass(s, "g2", 1, 0), RD_STORE_TILE_PASS_DONE);
    OK(rd_store_job_cancel(s, "g2", NULL, &e_));
    open_refused(s, "g2", 1, "late", RD_ERR_CANCELLED, "cancelled");
    check_gate(s, "g2", 1, 1, 1, "kept");
    /* An ungated job's passes open by themselves. */
    store_put_job(s, "u", 40, 1, 2);
    cr_assert_eq(run_pass(s, "u", 1, 0), RD_STORE_TILE_PASS_DONE);
    open_refused(s, "u", 1, "s", RD_ERR_INVALID, "not gated");
    check_gate(s, "u", 0, 1, 1, NULL);
    cr_assert_eq(run_pass(s, "u", 1, 1), RD_STORE_TILE_JOB_DONE, "its pass 1 was claimable at once");
    FAILS(RD_ERR_NOT_FOUND, rd_store_pass_open(s, "nosuch", 1, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_pass_open(s, "bad id", 1, NULL, &e_));
    rd_store_close(s);
}

void case_gated_schedule(const store_env *e)
{
    store_env small = *e;
    small.opt.limits.text_bytes = 100;
    rd_store *s = store_env_open(&small);
    static char text[200];
    memset(text, 's', sizeof text - 1);
    const char *at_limit = text + sizeof text - 1 - 100, *over = at_limit - 1;
    const char *json = "{\"spp\":[1,4,16],\"name\":\"\xc3\xa9t\xc3\xa9\"}";
    put_gated(s, "sj", 1, 1, 3, json);
    check_gate(s, "sj", 1, 1, 0, json);
    /* An ungated job keeps one too; none is none. */
    rd_store_job_spec j = spec_of("wj", 2, 0, 0);
    j.schedule = "ungated";
    OK(rd_store_job_create(s, &j, &e_));
    check_gate(s, "wj", 0, 1, 0, "ungated");
    store_put_job(s, "nj", 3, 0, 0);
    check_gate(s, "nj", 0, 1, 0, NULL);
    j = gated_spec("big", 4, 1, 2, over);
    FAILS(RD_ERR_LIMIT, rd_store_job_create(s, &j, &e_));
    j = gated_spec("big", 4, 1, 2, "\xc3");
    FAILS(RD_ERR_INVALID, rd_store_job_create(s, &j, &e_));
    rd_store_job_info in;
    FAILS(RD_ERR_NOT_FOUND, rd_store_job_get(s, "big", &in, &e_));
    put_gated(s, "edge", 5, 0, 0, at_limit);
    check_gate(s, "edge", 1, 1, 0, at_limit);
    cr_assert_eq(run_pass(s, "sj", 1, 0), RD_STORE_TILE_PASS_DONE);
    FAILS(RD_ERR_LIMIT, rd_store_pass_open(s, "sj", 1, over, &e_));
    FAILS(RD_ERR_INVALID, rd_store_pass_open(s, "sj", 1, "\xff", &e_));
    check_gate(s, "sj", 1, 1, 1, json);
    OK(rd_store_pass_open(s, "sj", 1, at_limit, &e_));
    check_gate(s, "sj", 1, 2, 1, at_limit);
    cr_assert_eq(run_pass(s, "sj", 1, 1), RD_STORE_TILE_PASS_DONE);
    /* An empty schedule replaces it: only NULL keeps it. */
    OK(rd_store_pass_open(s, "sj", 2, "", &e_));
    check_gate(s, "sj", 1, 3, 2, "");
    rd_store_close(s);
}

void case_gated_wait(const store_env *e)
{
    rd_store *a = store_env_open(e), *b = store_env_open(e);
    put_gated(b, "wj", 2, 2, 2, NULL);
    cr_assert_eq(run_pass(b, "wj", 2, 0), RD_STORE_TILE_PASS_DONE);
    /* What a saw so far, until it is quiet. On PostgreSQL, no TILES: the
     * pass that completed opened nothing. */
    rd_store_event ev;
    int quiet = 0;
    for (int i = 0; i < 20 && !quiet; i++) {
        OK(rd_store_wait(a, 300, &ev, &e_));
        quiet = ev.kind == RD_STORE_EV_NONE;
        if (e->events_named)
            cr_assert_neq(ev.kind, RD_STORE_EV_TILES, "woken for tiles that are not claimable");
    }
    cr_assert(quiet, "a's events never ran out");
    waiter w = {.s = a, .timeout_ms = 5000};
    pthread_t th;
    cr_assert_eq(pthread_create(&th, NULL, wait_main, &w), 0);
    sleep_ms_store(200);
    OK(rd_store_pass_open(b, "wj", 1, "go", &e_));
    double committed = rd_now_ms();
    pthread_join(th, NULL);
    cr_assert_eq(w.code, RD_OK);
    cr_assert_lt(w.woke_at - committed, 1000.0, "woke %.1f ms after the pass opened", w.woke_at - committed);
    if (e->events_named) {
        cr_assert_eq(w.ev.kind, RD_STORE_EV_TILES, "woken by event %d", (int)w.ev.kind);
        cr_assert_str_eq(w.ev.job_id, "wj");
    } else {
        cr_assert_eq(w.ev.kind, RD_STORE_EV_CHANGED, "woken by event %d", (int)w.ev.kind);
    }
    /* A refused opening changed nothing and wakes nobody. */
    FAILS(RD_ERR_INVALID, rd_store_pass_open(b, "wj", 1, "again", &e_));
    OK(rd_store_wait(a, 300, &ev, &e_));
    cr_assert_eq(ev.kind, RD_STORE_EV_NONE, "woken by a refused opening (%d)", (int)ev.kind);
    rd_store_tile t[4];
    cr_assert_eq(claim(a, "d2", 4, 10000, t), 2, "the waiting handle claims the opened pass");
    cr_assert(t[0].pass == 1 && t[1].pass == 1);
    rd_store_close(a);
    rd_store_close(b);
}

#define RACERS 8

typedef struct {
    rd_store *s;
    atomic_int *go;
    int pass;
    char schedule[32];
    rd_error_code code;
    rd_error err;
} racer;

static void *race_main(void *arg)
{
    racer *r = arg;
    while (!atomic_load(r->go))
        ; /* every racer calls at once */
    r->code = rd_store_pass_open(r->s, "race", r->pass, r->schedule, &r->err);
    return NULL;
}

void case_gated_race(const store_env *e, int threads, int rounds)
{
    cr_assert(threads >= 2 && threads <= RACERS);
    rd_store *s = store_env_open(e);
    put_gated(s, "race", 1, 2, rounds + 1, NULL);
    rd_store *h[RACERS];
    for (int i = 0; i < threads; i++)
        h[i] = store_env_open(e);
    for (int p = 1; p <= rounds; p++) {
        cr_assert_eq(run_pass(s, "race", 2, p - 1), RD_STORE_TILE_PASS_DONE);
        atomic_int go = 0;
        racer r[RACERS];
        pthread_t th[RACERS];
        for (int i = 0; i < threads; i++) {
            r[i] = (racer){.s = h[i], .go = &go, .pass = p};
            snprintf(r[i].schedule, sizeof r[i].schedule, "won by %d", i);
            cr_assert_eq(pthread_create(&th[i], NULL, race_main, &r[i]), 0);
        }
        atomic_store(&go, 1);
        int won = 0, winner = -1;
        for (int i = 0; i < threads; i++) {
            pthread_join(th[i], NULL);
            cr_assert(r[i].code == RD_OK || r[i].code == RD_ERR_INVALID, "pass %d, racer %d: %s (%s)", p, i,
                      rd_error_name(r[i].code), r[i].err.message);
            if (r[i].code == RD_OK) {
                won++;
                winner = i;
            }
        }
        cr_assert_eq(won, 1, "pass %d opened by %d racers", p, won);
        check_gate(s, "race", 1, p + 1, p, r[winner].schedule);
    }
    cr_assert_eq(run_pass(s, "race", 2, rounds), RD_STORE_TILE_JOB_DONE);
    for (int i = 0; i < threads; i++)
        rd_store_close(h[i]);
    rd_store_close(s);
}

void case_upgrade_from_version_2(const store_env *e, void (*exec)(const char *sql), const char *blob)
{
    cr_assert_geq(rd_store_migration_count, 3);
    exec("CREATE TABLE schema_version (version INTEGER PRIMARY KEY, name TEXT NOT NULL, applied_ms BIGINT NOT NULL)");
    for (int i = 0; i < 2; i++) {
        char *sql = rd_store_migration_text(rd_store_migrations[i].sql, blob);
        cr_assert(sql);
        exec(sql);
        free(sql);
        char row[160];
        snprintf(row, sizeof row, "INSERT INTO schema_version VALUES (%d, '%s', 0)", rd_store_migrations[i].version,
                 rd_store_migrations[i].name);
        exec(row);
    }
    /* As a rayd of version 2 wrote it: a running job with 2 tiles of 2
     * passes, tile 0 of pass 0 done. */
    exec("INSERT INTO jobs (id, status, scene, format, query, hdr, width, height, memory_bytes, submitted_ms, "
         "started_ms, tiles_total, tiles_done, pass, passes) "
         "VALUES ('old', 'running', 'x', 'cfg', '', 0, 8, 8, 0, 1, 1, 2, 1, 0, 2)");
    exec("INSERT INTO tiles (job_id, tile, passes_done, data) VALUES ('old', 0, 1, 'r'), ('old', 1, 0, NULL)");
    rd_store *s = store_env_open(e);
    check_gate(s, "old", 0, 1, 0, NULL);
    rd_store_job_info in = info_of(s, "old");
    cr_assert(in.status == RD_STORE_RUNNING && in.tiles_done == 1 && in.passes == 2, "the job is as it was");
    rd_store_job_info_free(&in);
    cr_assert_eq(run_pass(s, "old", 1, 0), RD_STORE_TILE_PASS_DONE);
    cr_assert_eq(run_pass(s, "old", 2, 1), RD_STORE_TILE_JOB_DONE, "its passes open by themselves");
    rd_store_close(s);
}

/* Grades and batches. */

#define DAY_MS (24 * 3600 * 1000LL)

static rd_store_grade grade_of(const char *id, const char *assignment, const char *student, int64_t graded_ms)
{
    rd_store_grade g = {.id = id,
                        .assignment = assignment,
                        .student = student,
                        .pass = 1,
                        .failed_fraction = 0.000125,
                        .max_abs = 2,
                        .psnr_db = 51.25,
                        .ssim = 0.9990234375,
                        .verdict = "{\"pass\":true}",
                        .reference_key = "scene:5f2c core:0a9e",
                        .graded_ms = graded_ms};
    return g;
}

static void put_grade(rd_store *s, const rd_store_grade *g) { OK(rd_store_grade_put(s, g, NULL, 0, &e_)); }

static rd_store_grade grade_got(rd_store *s, const char *id)
{
    rd_store_grade g;
    OK(rd_store_grade_get(s, id, &g, &e_));
    return g;
}

/* The same double, bit for bit (NAN is NAN). */
static int same_double(double a, double b) { return (isnan(a) && isnan(b)) || memcmp(&a, &b, sizeof a) == 0; }

/* NULL and NULL, or the same text. */
static int same_text(const char *a, const char *b) { return a == b || (a && b && strcmp(a, b) == 0); }

/* got is what put stored of want: every field (a NULL student is "";
 * an error row's metrics are NAN). */
static void check_grade_eq(const rd_store_grade *got, const rd_store_grade *want)
{
    const char *id = want->id;
    cr_assert(same_text(got->id, want->id), "%s: id %s", id, got->id);
    cr_assert(same_text(got->batch_id, want->batch_id), "%s: batch %s, not %s", id,
              got->batch_id ? got->batch_id : "(none)", want->batch_id ? want->batch_id : "(none)");
    cr_assert(same_text(got->assignment, want->assignment), "%s: assignment %s", id, got->assignment);
    cr_assert(same_text(got->student, want->student ? want->student : ""), "%s: student \"%s\"", id,
              got->student ? got->student : "(null)");
    cr_assert_eq(got->pass, want->error ? 0 : want->pass != 0, "%s: pass %d", id, got->pass);
    const double g4[4] = {got->failed_fraction, got->max_abs, got->psnr_db, got->ssim};
    const double w4[4] = {want->failed_fraction, want->max_abs, want->psnr_db, want->ssim};
    for (int i = 0; i < 4; i++)
        cr_assert(want->error ? isnan(g4[i]) : same_double(g4[i], w4[i]), "%s: metric %d is %.17g, not %.17g", id, i,
                  g4[i], want->error ? NAN : w4[i]);
    cr_assert(same_text(got->verdict, want->verdict), "%s: verdict %s", id, got->verdict ? got->verdict : "(none)");
    cr_assert(same_text(got->reference_key, want->reference_key), "%s: reference key %s", id,
              got->reference_key ? got->reference_key : "(none)");
    cr_assert_eq(got->graded_ms, want->graded_ms, "%s: graded at %lld", id, (long long)got->graded_ms);
    cr_assert(same_text(got->error, want->error), "%s: error %s", id, got->error ? got->error : "(none)");
}

static void check_stored(rd_store *s, const rd_store_grade *want)
{
    rd_store_grade g = grade_got(s, want->id);
    check_grade_eq(&g, want);
    rd_store_grade_free(&g);
    cr_assert(!g.id && !g.assignment && !g.student && !g.verdict && !g.reference_key,
              "rd_store_grade_free clears what it frees");
}

static void check_no_grade(rd_store *s, const char *id)
{
    rd_store_grade g;
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_get(s, id, &g, &e_));
}

void case_grade_round_trip(const store_env *e)
{
    rd_store *s = store_env_open(e);
    /* Doubles that a text round trip with too few digits would change. */
    rd_store_grade a = grade_of("0123456789abcdef", "phong", "Zo\xc3\xab \xc3\x9cnal", 1700000000123LL);
    a.failed_fraction = 1.0 / 3.0;
    a.max_abs = 255;
    a.psnr_db = 99;
    a.ssim = 0.1 + 0.2;
    a.verdict = "{\"pass\":true,\"metrics\":{\"psnr_db\":99},\"note\":\"\xc3\xa9t\xc3\xa9\"}";
    a.reference_key = "scene:5f2c7a1b9e0d4c33 core:0a9e6b1f2d44";
    put_grade(s, &a);
    check_stored(s, &a);
    rd_store_grade b = grade_of("fedcba9876543210", "diffuse", NULL, 0);
    b.pass = 0;
    b.failed_fraction = 2.2250738585072014e-308;
    b.max_abs = 1e308;
    b.psnr_db = 0;
    b.ssim = 1 - DBL_EPSILON / 2;
    put_grade(s, &b);
    check_stored(s, &b);
    rd_store_grade c = grade_of("c0ffee00c0ffee00", "phong", "", 5);
    c.pass = 7; /* any true value is a pass */
    put_grade(s, &c);
    check_stored(s, &c);
    /* An id once. */
    rd_store_grade again = grade_of(a.id, "diffuse", "someone", 9);
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &again, NULL, 0, &e_));
    check_stored(s, &a);
    check_no_grade(s, "0123456789abcde0");
    /* Not a number, not kept. */
    const double bad[3] = {NAN, INFINITY, -INFINITY};
    for (int m = 0; m < 4; m++)
        for (int k = 0; k < 3; k++) {
            rd_store_grade g = grade_of("badmetric", "phong", "x", 1);
            double *metric[4] = {&g.failed_fraction, &g.max_abs, &g.psnr_db, &g.ssim};
            *metric[m] = bad[k];
            FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &g, NULL, 0, &e_));
        }
    check_no_grade(s, "badmetric");
    rd_store_close(s);
}

void case_grade_error_row(const store_env *e)
{
    rd_store *s = store_env_open(e);
    /* Its metrics, whatever they hold, are not kept: NAN is no refusal. */
    rd_store_grade g = grade_of("e000000000000001", "phong", "late student", 40);
    g.pass = 0;
    g.failed_fraction = 0.5;
    g.psnr_db = NAN;
    g.verdict = NULL;
    g.reference_key = NULL;
    g.error = "mine.png: the PNG's size is 100x100, not the scene's 320x240";
    put_grade(s, &g);
    check_stored(s, &g);
    /* With the error answer and the reference, if known. */
    rd_store_grade h = g;
    h.id = "e000000000000002";
    h.verdict = "{\"error\":{\"code\":\"size_mismatch\"}}";
    h.reference_key = "scene:1 core:2";
    put_grade(s, &h);
    check_stored(s, &h);
    rd_store_grade_filter f = {.student = "late student", .max = 10};
    rd_store_grade *l = NULL;
    size_t n = 0;
    OK(rd_store_grades_list(s, &f, &l, &n, &e_));
    cr_assert_eq(n, 2);
    check_grade_eq(&l[0], &g);
    check_grade_eq(&l[1], &h);
    rd_store_grades_free(l, n);
    /* Refused: a pass that was not graded, an empty message, a diff; a
     * graded row without its verdict or reference. */
    rd_store_grade r = g;
    r.id = "e000000000000003";
    r.pass = 1;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &r, NULL, 0, &e_));
    r.pass = 0;
    r.error = "";
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &r, NULL, 0, &e_));
    r.error = "damaged";
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G'};
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &r, png, sizeof png, &e_));
    rd_store_grade v = grade_of("e000000000000003", "phong", "x", 1);
    v.verdict = NULL;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &v, NULL, 0, &e_));
    v = grade_of("e000000000000003", "phong", "x", 1);
    v.reference_key = NULL;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &v, NULL, 0, &e_));
    check_no_grade(s, "e000000000000003");
    rd_store_close(s);
}

static void check_diff(rd_store *s, const char *id, const unsigned char *want, size_t n)
{
    unsigned char *d = NULL;
    size_t len = 0;
    OK(rd_store_grade_image(s, id, RD_STORE_GRADE_DIFF, &d, &len, &e_));
    cr_assert_eq(len, n);
    cr_assert_eq(memcmp(d, want, n), 0, "the diff's bytes come back as they went");
    free(d);
}

void case_grade_images(const store_env *e)
{
    rd_store *s = store_env_open(e);
    static unsigned char png[5000];
    fill(png, sizeof png, 7);
    png[10] = 0;
    rd_store_grade g = grade_of("d000000000000001", "phong", "a", 1);
    OK(rd_store_grade_put(s, &g, png, sizeof png, &e_));
    check_diff(s, g.id, png, sizeof png);
    check_stored(s, &g);
    unsigned char *d = NULL;
    size_t len = 0;
    FAILS(RD_ERR_INVALID, rd_store_grade_image(s, g.id, RD_STORE_GRADE_IMAGE, &d, &len, &e_));
    FAILS(RD_ERR_INVALID, rd_store_grade_image(s, g.id, (rd_store_grade_image_kind)7, &d, &len, &e_));
    /* One without a diff has none; no grade is no grade. */
    rd_store_grade h = grade_of("d000000000000002", "phong", "b", 2);
    put_grade(s, &h);
    FAILS(RD_ERR_INVALID, rd_store_grade_image(s, h.id, RD_STORE_GRADE_DIFF, &d, &len, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_image(s, "d000000000000003", RD_STORE_GRADE_DIFF, &d, &len, &e_));
    FAILS(RD_ERR_INVALID, rd_store_grade_image(s, "bad id", RD_STORE_GRADE_DIFF, &d, &len, &e_));
    cr_assert(d == NULL && len == 0, "nothing is written on an error");
    /* An empty diff is not none, it is refused (and so is the grade). */
    rd_store_grade k = grade_of("d000000000000004", "phong", "c", 3);
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &k, png, 0, &e_));
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &k, NULL, 10, &e_));
    check_no_grade(s, k.id);
    /* Each grade's own. */
    static unsigned char other[300];
    fill(other, sizeof other, 8);
    OK(rd_store_grade_put(s, &k, other, sizeof other, &e_));
    check_diff(s, k.id, other, sizeof other);
    check_diff(s, g.id, png, sizeof png);
    rd_store_close(s);
}

void case_grade_term(const store_env *e)
{
    rd_store *s = store_env_open(e);
    /* Zeroed fields: an image, submitted when graded, on time, no score. */
    rd_store_grade plain = grade_of("e000000000000001", "phong", "a", 5000);
    put_grade(s, &plain);
    rd_store_grade g = grade_got(s, plain.id);
    cr_assert_str_eq(g.kind, "image");
    cr_assert_eq(g.submitted_ms, 5000, "submitted when graded");
    cr_assert(g.late_ms == 0 && !g.closed && isnan(g.score) && isnan(g.points) && !g.regrade_of);
    rd_store_grade_free(&g);
    /* Every term field comes back as it went. */
    rd_store_grade t = grade_of("e000000000000002", "phong", "a", 9000);
    t.kind = "code";
    t.submitted_ms = 8000;
    t.late_ms = 86400001;
    t.closed = 1;
    t.score = 7.5;
    t.points = 10;
    t.regrade_of = plain.id;
    put_grade(s, &t);
    g = grade_got(s, t.id);
    cr_assert_str_eq(g.kind, "code");
    cr_assert(g.submitted_ms == 8000 && g.late_ms == 86400001 && g.closed == 1, "the times come back");
    cr_assert(g.score == 7.5 && g.points == 10, "the score comes back");
    cr_assert_str_eq(g.regrade_of, plain.id);
    rd_store_grade_free(&g);
    cr_assert(!g.kind && !g.regrade_of, "rd_store_grade_free clears them");
    /* Refused: a kind not known, a score over its points, a negative lateness. */
    rd_store_grade bad = grade_of("e000000000000003", "phong", "a", 1);
    bad.kind = "essay";
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &bad, NULL, 0, &e_));
    bad.kind = "image";
    bad.points = 1;
    bad.score = 1.5;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &bad, NULL, 0, &e_));
    bad.score = 1;
    bad.late_ms = -1;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &bad, NULL, 0, &e_));
    bad.regrade_of = "not an id";
    bad.late_ms = 0;
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &bad, NULL, 0, &e_));
    check_no_grade(s, bad.id);
    /* The image graded, stored after the grade, replaced by a second put. */
    static unsigned char png[700], again[90];
    fill(png, sizeof png, 3);
    fill(again, sizeof again, 4);
    OK(rd_store_grade_image_put(s, plain.id, RD_STORE_GRADE_IMAGE, png, sizeof png, &e_));
    OK(rd_store_grade_image_put(s, plain.id, RD_STORE_GRADE_IMAGE, again, sizeof again, &e_));
    unsigned char *d = NULL;
    size_t len = 0;
    OK(rd_store_grade_image(s, plain.id, RD_STORE_GRADE_IMAGE, &d, &len, &e_));
    cr_assert(len == sizeof again && memcmp(d, again, len) == 0, "the last image put is the one kept");
    free(d);
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_image_put(s, "e0000000000000ff", RD_STORE_GRADE_IMAGE, png, 10, &e_));
    FAILS(RD_ERR_INVALID, rd_store_grade_image_put(s, plain.id, RD_STORE_GRADE_IMAGE, png, 0, &e_));
    rd_store_close(s);
}

/* The ids f lists, joined by commas. */
static void check_list(rd_store *s, const rd_store_grade_filter *f, const char *want)
{
    rd_store_grade *l = NULL;
    size_t n = 99;
    OK(rd_store_grades_list(s, f, &l, &n, &e_));
    char got[512] = "";
    for (size_t i = 0; i < n; i++) {
        cr_assert(strlen(got) + strlen(l[i].id) + 2 < sizeof got);
        if (i)
            strcat(got, ",");
        strcat(got, l[i].id);
        if (f && f->assignment)
            cr_assert_str_eq(l[i].assignment, f->assignment);
        cr_assert(l[i].verdict && l[i].graded_ms >= (f ? f->since_ms : 0), "%s: the whole row is read", l[i].id);
    }
    cr_assert_str_eq(got, want, "listed %s, not %s", got, want);
    cr_assert(n > 0 || l == NULL, "an empty list is NULL");
    rd_store_grades_free(l, n);
}

void case_grades_list(const store_env *e)
{
    rd_store *s = store_env_open(e);
    OK(rd_store_batch_create(s, "b1", "phong", 3, NULL, NULL, &e_));
    OK(rd_store_batch_create(s, "b2", "phong", 3, NULL, NULL, &e_));
    struct {
        const char *id, *assignment, *student, *batch;
        int64_t ms;
    } rows[] = {
        {"g5", "phong", "ann", "b1", 500}, {"g1", "phong", "bob", NULL, 100}, {"g3", "diffuse", "ann", NULL, 300},
        {"g4b", "phong", "", "b1", 400},   {"g4a", "phong", "cy", "b2", 400}, {"g2", "diffuse", "", NULL, 200},
        {"g6", "phong", "bob", "b1", 600},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        rd_store_grade g = grade_of(rows[i].id, rows[i].assignment, rows[i].student, rows[i].ms);
        g.batch_id = rows[i].batch;
        put_grade(s, &g);
    }
    check_list(s, NULL, "g1,g2,g3,g4a,g4b,g5,g6");
    rd_store_grade_filter f = {.max = 100};
    check_list(s, &f, "g1,g2,g3,g4a,g4b,g5,g6");
    f.since_ms = 400;
    check_list(s, &f, "g4a,g4b,g5,g6");
    f.since_ms = 401;
    check_list(s, &f, "g5,g6");
    f = (rd_store_grade_filter){.assignment = "phong", .max = 100};
    check_list(s, &f, "g1,g4a,g4b,g5,g6");
    f.max = 2;
    check_list(s, &f, "g1,g4a");
    f = (rd_store_grade_filter){.student = "ann", .max = 100};
    check_list(s, &f, "g3,g5");
    f.student = "";
    check_list(s, &f, "g2,g4b");
    f.student = "nobody";
    check_list(s, &f, "");
    f = (rd_store_grade_filter){.batch_id = "b1", .max = 100};
    check_list(s, &f, "g4b,g5,g6");
    f.student = "bob";
    check_list(s, &f, "g6");
    f = (rd_store_grade_filter){.assignment = "diffuse", .student = "", .max = 100};
    check_list(s, &f, "g2");
    f = (rd_store_grade_filter){.assignment = "phong", .student = "ann", .batch_id = "b1", .since_ms = 500, .max = 9};
    check_list(s, &f, "g5");
    f.since_ms = 501;
    check_list(s, &f, "");
    f = (rd_store_grade_filter){.batch_id = "b2", .since_ms = 0, .max = 100};
    check_list(s, &f, "g4a");
    f.batch_id = "nosuch";
    check_list(s, &f, "");
    /* max 0 is none, without asking. */
    f = (rd_store_grade_filter){.max = 0};
    check_list(s, &f, "");
    f = (rd_store_grade_filter){.batch_id = "bad id", .max = 5};
    rd_store_grade *l = NULL;
    size_t n = 0;
    FAILS(RD_ERR_INVALID, rd_store_grades_list(s, &f, &l, &n, &e_));
    static char longname[300];
    memset(longname, 'a', sizeof longname - 1);
    f = (rd_store_grade_filter){.assignment = longname, .max = 5};
    FAILS(RD_ERR_LIMIT, rd_store_grades_list(s, &f, &l, &n, &e_));
    f = (rd_store_grade_filter){.student = "\xff", .max = 5};
    FAILS(RD_ERR_INVALID, rd_store_grades_list(s, &f, &l, &n, &e_));
    rd_store_close(s);
}

static rd_store_batch batch_got(rd_store *s, const char *id)
{
    rd_store_batch b;
    OK(rd_store_batch_get(s, id, &b, &e_));
    return b;
}

static void check_batch(rd_store *s, const char *id, int done, int total, rd_store_batch_status st)
{
    rd_store_batch b = batch_got(s, id);
    cr_assert_str_eq(b.id, id);
    cr_assert(b.done == done && b.total == total, "batch %s: %d of %d, not %d of %d", id, b.done, b.total, done, total);
    cr_assert_eq(b.status, st, "batch %s is %s, not %s", id, rd_store_batch_status_name(b.status),
                 rd_store_batch_status_name(st));
}

static void put_batch_grade(rd_store *s, const char *id, const char *batch, int error)
{
    rd_store_grade g = grade_of(id, "phong", id, 10);
    g.batch_id = batch;
    if (error) {
        g.pass = 0;
        g.error = "bad_image";
    }
    put_grade(s, &g);
}

void case_batch_progress(const store_env *e)
{
    rd_store *s = store_env_open(e);
    int64_t before = rd_wall_ms();
    OK(rd_store_batch_create(s, "class-1", "phong", 3, NULL, NULL, &e_));
    rd_store_batch b = batch_got(s, "class-1");
    cr_assert_str_eq(b.assignment, "phong");
    cr_assert(b.created_ms >= before - 5000 && b.created_ms <= before + 5000, "created %lld, now %lld",
              (long long)b.created_ms, (long long)before);
    check_batch(s, "class-1", 0, 3, RD_STORE_BATCH_RUNNING);
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "class-1", "phong", 5, NULL, NULL, &e_));
    check_batch(s, "class-1", 0, 3, RD_STORE_BATCH_RUNNING);
    put_batch_grade(s, "s1", "class-1", 0);
    check_batch(s, "class-1", 1, 3, RD_STORE_BATCH_RUNNING);
    /* Refused grades count for nothing: another assignment, an id taken,
     * a bad text. */
    rd_store_grade o = grade_of("s9", "diffuse", "s9", 10);
    o.batch_id = "class-1";
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &o, NULL, 0, &e_));
    o = grade_of("s1", "phong", "s1", 10);
    o.batch_id = "class-1";
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &o, NULL, 0, &e_));
    o = grade_of("s9", "phong", "s9", 10);
    o.batch_id = "class-1";
    o.verdict = "\xc3";
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, &o, NULL, 0, &e_));
    check_batch(s, "class-1", 1, 3, RD_STORE_BATCH_RUNNING);
    check_no_grade(s, "s9");
    /* One that could not be graded counts as graded. */
    put_batch_grade(s, "s2", "class-1", 1);
    check_batch(s, "class-1", 2, 3, RD_STORE_BATCH_RUNNING);
    put_batch_grade(s, "s3", "class-1", 0);
    check_batch(s, "class-1", 3, 3, RD_STORE_BATCH_DONE);
    /* Done takes no more. */
    o = grade_of("s4", "phong", "s4", 10);
    o.batch_id = "class-1";
    FAILS(RD_ERR_CANCELLED, rd_store_grade_put(s, &o, NULL, 0, &e_));
    check_no_grade(s, "s4");
    check_batch(s, "class-1", 3, 3, RD_STORE_BATCH_DONE);
    int changed = 7;
    OK(rd_store_batch_cancel(s, "class-1", &changed, &e_));
    cr_assert_eq(changed, 0);
    check_batch(s, "class-1", 3, 3, RD_STORE_BATCH_DONE);
    /* Cancelled: it keeps what it has and takes no more. */
    OK(rd_store_batch_create(s, "class-2", "phong", 5, NULL, NULL, &e_));
    put_batch_grade(s, "t1", "class-2", 0);
    OK(rd_store_batch_cancel(s, "class-2", &changed, &e_));
    cr_assert_eq(changed, 1);
    check_batch(s, "class-2", 1, 5, RD_STORE_BATCH_CANCELLED);
    OK(rd_store_batch_cancel(s, "class-2", &changed, &e_));
    cr_assert_eq(changed, 0);
    o = grade_of("t2", "phong", "t2", 10);
    o.batch_id = "class-2";
    FAILS(RD_ERR_CANCELLED, rd_store_grade_put(s, &o, NULL, 0, &e_));
    check_batch(s, "class-2", 1, 5, RD_STORE_BATCH_CANCELLED);
    rd_store_grade t1 = grade_got(s, "t1");
    cr_assert_str_eq(t1.batch_id, "class-2");
    rd_store_grade_free(&t1);
    /* No such batch. */
    o = grade_of("u1", "phong", "u1", 10);
    o.batch_id = "class-0";
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_put(s, &o, NULL, 0, &e_));
    check_no_grade(s, "u1");
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_get(s, "class-0", &b, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_cancel(s, "class-0", NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_get(s, "bad id", &b, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "class-3", "phong", 0, NULL, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "class-3", "", 2, NULL, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "class 3", "phong", 2, NULL, NULL, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_get(s, "class-3", &b, &e_));
    /* A batch of one is done by its one grade. */
    OK(rd_store_batch_create(s, "solo", "phong", 1, NULL, NULL, &e_));
    put_batch_grade(s, "v1", "solo", 0);
    check_batch(s, "solo", 1, 1, RD_STORE_BATCH_DONE);
    rd_store_close(s);
}

typedef struct {
    rd_store *s;
    atomic_int *go;
    char id[48], batch[32];
    rd_error_code code;
    rd_error err;
} grade_racer;

static void *grade_race_main(void *arg)
{
    grade_racer *r = arg;
    rd_store_grade g = grade_of(r->id, "phong", r->id, 10);
    g.batch_id = r->batch;
    while (!atomic_load(r->go))
        ; /* every racer puts at once */
    r->code = rd_store_grade_put(r->s, &g, NULL, 0, &r->err);
    return NULL;
}

/* threads handles put a grade each at once to a batch with slots left
 * (slots <= threads): the first slots are counted, the others refused,
 * and the batch is done with exactly its total. */
void case_batches_running(const store_env *e)
{
    rd_store *s = store_env_open(e);
    OK(rd_store_batch_create(s, "mine-1", "phong", 2, "host:8080", "m\xc3\xbcller\nbob\n", &e_));
    OK(rd_store_batch_create(s, "mine-2", "phong", 1, "host:8080", NULL, &e_));
    OK(rd_store_batch_create(s, "theirs", "phong", 1, "other:8080", "eve\n", &e_));
    OK(rd_store_batch_create(s, "nobody", "phong", 1, NULL, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "bad-1", "phong", 1, "a b", NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "bad-2", "phong", 1, NULL, "\xff\n", &e_));
    put_batch_grade(s, "done-1", "mine-2", 0);
    rd_store_batch *list = NULL;
    size_t n = 0;
    OK(rd_store_batches_running(s, "host:8080", 10, &list, &n, &e_));
    cr_assert_eq(n, 1, "%zu running batches of host:8080, not the one still running", n);
    cr_assert_str_eq(list[0].id, "mine-1");
    cr_assert(list[0].total == 2 && list[0].done == 0 && list[0].status == RD_STORE_BATCH_RUNNING);
    free(list);
    OK(rd_store_batches_running(s, "nobody:1", 10, &list, &n, &e_));
    cr_assert_eq(n, 0);
    FAILS(RD_ERR_INVALID, rd_store_batches_running(s, "", 10, &list, &n, &e_));
    char *students = NULL;
    OK(rd_store_batch_students(s, "mine-1", &students, &e_));
    cr_assert_str_eq(students, "m\xc3\xbcller\nbob\n");
    free(students);
    OK(rd_store_batch_students(s, "nobody", &students, &e_));
    cr_assert_str_eq(students, "");
    free(students);
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_students(s, "no-such", &students, &e_));
    rd_store_close(s);
}

static void batch_race_round(rd_store *s, rd_store **h, int threads, int slots, int round)
{
    char batch[32];
    snprintf(batch, sizeof batch, "race-%d-%d", threads, round);
    int total = slots + 2;
    OK(rd_store_batch_create(s, batch, "phong", total, NULL, NULL, &e_));
    for (int i = 0; i < 2; i++) {
        char id[48];
        snprintf(id, sizeof id, "%s-pre%d", batch, i);
        put_batch_grade(s, id, batch, 0);
    }
    atomic_int go = 0;
    grade_racer r[RACERS];
    pthread_t th[RACERS];
    for (int i = 0; i < threads; i++) {
        r[i] = (grade_racer){.s = h[i], .go = &go};
        snprintf(r[i].id, sizeof r[i].id, "%s-r%d", batch, i);
        snprintf(r[i].batch, sizeof r[i].batch, "%s", batch);
        cr_assert_eq(pthread_create(&th[i], NULL, grade_race_main, &r[i]), 0);
    }
    atomic_store(&go, 1);
    int ok = 0;
    for (int i = 0; i < threads; i++) {
        pthread_join(th[i], NULL);
        cr_assert(r[i].code == RD_OK || r[i].code == RD_ERR_CANCELLED, "%s: %s (%s)", r[i].id, rd_error_name(r[i].code),
                  r[i].err.message);
        ok += r[i].code == RD_OK;
        rd_store_grade g;
        rd_error err = {0};
        rd_error_code c = rd_store_grade_get(s, r[i].id, &g, &err);
        cr_assert_eq(c, r[i].code == RD_OK ? RD_OK : RD_ERR_NOT_FOUND, "%s is stored only if counted", r[i].id);
        if (c == RD_OK)
            rd_store_grade_free(&g);
    }
    cr_assert_eq(ok, slots, "%s: %d of %d racers counted for %d slots", batch, ok, threads, slots);
    check_batch(s, batch, total, total, RD_STORE_BATCH_DONE);
    rd_store_grade_filter f = {.batch_id = batch, .max = 100};
    rd_store_grade *l = NULL;
    size_t n = 0;
    OK(rd_store_grades_list(s, &f, &l, &n, &e_));
    cr_assert_eq(n, (size_t)total, "%s holds %zu grades", batch, n);
    rd_store_grades_free(l, n);
}

void case_batch_race(const store_env *e, int rounds)
{
    rd_store *s = store_env_open(e);
    rd_store *h[4];
    for (int i = 0; i < 4; i++)
        h[i] = store_env_open(e);
    for (int round = 0; round < rounds; round++) {
        batch_race_round(s, h, 2, 2, round); /* the last two grades, two handles */
        batch_race_round(s, h, 4, 2, round); /* four handles for the last two */
    }
    for (int i = 0; i < 4; i++)
        rd_store_close(h[i]);
    rd_store_close(s);
}

void case_grades_expire(const store_env *e)
{
    rd_store *s = store_env_open(e);
    int64_t t0 = rd_wall_ms();
    static unsigned char png[100];
    fill(png, sizeof png, 3);
    OK(rd_store_batch_create(s, "bold", "phong", 2, NULL, NULL, &e_));
    OK(rd_store_batch_create(s, "bkeep", "phong", 2, NULL, NULL, &e_));
    OK(rd_store_batch_create(s, "bempty", "phong", 3, NULL, NULL, &e_));
    rd_store_grade old1 = grade_of("old1", "phong", "a", t0 - 10 * DAY_MS);
    OK(rd_store_grade_put(s, &old1, png, sizeof png, &e_));
    rd_store_grade old2 = grade_of("old2", "phong", "b", t0 - 10 * DAY_MS);
    old2.batch_id = "bold";
    put_grade(s, &old2);
    rd_store_grade new1 = grade_of("new1", "phong", "c", t0 - 3600 * 1000);
    put_grade(s, &new1);
    /* A grade stamped later than the expiries below (a clock ahead): it
     * keeps its batch. */
    rd_store_grade late = grade_of("late", "phong", "d", t0 + DAY_MS);
    late.batch_id = "bkeep";
    put_grade(s, &late);
    size_t gone = 99;
    OK(rd_store_grades_expire(s, 30 * DAY_MS, &gone, &e_));
    cr_assert_eq(gone, 0, "nothing is 30 days old");
    OK(rd_store_grades_expire(s, 5 * DAY_MS, &gone, &e_));
    cr_assert_eq(gone, 2, "the two grades of 10 days ago, not %zu", gone);
    check_no_grade(s, "old1");
    check_no_grade(s, "old2");
    unsigned char *d = NULL;
    size_t len = 0;
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_image(s, "old1", RD_STORE_GRADE_DIFF, &d, &len, &e_));
    check_stored(s, &new1);
    check_stored(s, &late);
    /* The batches are younger than 5 days: kept, their counts too. */
    check_batch(s, "bold", 1, 2, RD_STORE_BATCH_RUNNING);
    check_batch(s, "bkeep", 1, 2, RD_STORE_BATCH_RUNNING);
    check_batch(s, "bempty", 0, 3, RD_STORE_BATCH_RUNNING);
    OK(rd_store_grades_expire(s, 5 * DAY_MS, &gone, &e_));
    cr_assert_eq(gone, 0);
    /* Past the batches' TTL: those without a grade go. */
    sleep_ms_store(60);
    OK(rd_store_grades_expire(s, 20, &gone, &e_));
    cr_assert_eq(gone, 1, "new1, not %zu", gone);
    check_no_grade(s, "new1");
    rd_store_batch b;
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_get(s, "bold", &b, &e_));
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_get(s, "bempty", &b, &e_));
    check_batch(s, "bkeep", 1, 2, RD_STORE_BATCH_RUNNING);
    check_stored(s, &late);
    check_list(s, NULL, "late");
    /* A batch that expired takes no grade. */
    rd_store_grade g = grade_of("after", "phong", "e", t0);
    g.batch_id = "bold";
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_put(s, &g, NULL, 0, &e_));
    FAILS(RD_ERR_INVALID, rd_store_grades_expire(s, -1, NULL, &e_));
    OK(rd_store_grades_expire(s, 0, NULL, &e_));
    check_stored(s, &late);
    rd_store_close(s);
}

void case_grade_limits(const store_env *e)
{
    store_env small = *e;
    small.opt.limits.text_bytes = 100;
    small.opt.limits.image_bytes = 2000;
    rd_store *s = store_env_open(&small);
    static char text[300], name[300];
    memset(text, 'v', sizeof text - 1);
    memset(name, 'n', sizeof name - 1);
    const char *text_at_limit = text + sizeof text - 1 - 100, *text_over = text_at_limit - 1;
    const char *name_at_limit = name + sizeof name - 1 - 255, *name_over = name_at_limit - 1;
    static unsigned char png[2001];
    fill(png, sizeof png, 5);
    OK(rd_store_batch_create(s, "lb", "phong", 50, NULL, NULL, &e_));
    struct {
        const char *why;
        rd_error_code code;
        rd_store_grade g;
        size_t png_len;
    } cases[] = {
        {"verdict over", RD_ERR_LIMIT, grade_of("x1", "phong", "s", 1), 0},
        {"reference over", RD_ERR_LIMIT, grade_of("x2", "phong", "s", 1), 0},
        {"error over", RD_ERR_LIMIT, grade_of("x3", "phong", "s", 1), 0},
        {"diff over", RD_ERR_LIMIT, grade_of("x4", "phong", "s", 1), 2001},
        {"student over", RD_ERR_LIMIT, grade_of("x5", "phong", name_over, 1), 0},
        {"assignment over", RD_ERR_LIMIT, grade_of("x6", name_over, "s", 1), 0},
        {"assignment empty", RD_ERR_INVALID, grade_of("x7", "", "s", 1), 0},
        {"assignment none", RD_ERR_INVALID, grade_of("x8", NULL, "s", 1), 0},
        {"student not UTF-8", RD_ERR_INVALID, grade_of("x9", "phong", "Zo\xeb", 1), 0},
        {"assignment not UTF-8", RD_ERR_INVALID, grade_of("x10", "ph\xc3", "s", 1), 0},
        {"verdict not UTF-8", RD_ERR_INVALID, grade_of("x11", "phong", "s", 1), 0},
        {"id with a space", RD_ERR_INVALID, grade_of("x 12", "phong", "s", 1), 0},
        {"id too long", RD_ERR_INVALID,
         grade_of("0123456789012345678901234567890123456789012345678901234567890123", "phong", "s", 1), 0},
        {"no id", RD_ERR_INVALID, grade_of(NULL, "phong", "s", 1), 0},
        {"batch id bad", RD_ERR_INVALID, grade_of("x15", "phong", "s", 1), 0},
        {"graded before 1970", RD_ERR_INVALID, grade_of("x16", "phong", "s", -1), 0},
    };
    cases[0].g.verdict = text_over;
    cases[1].g.reference_key = text_over;
    cases[2].g.error = text_over;
    cases[2].g.pass = 0;
    cases[10].g.verdict = "{\"a\":\"\xff\"}";
    cases[14].g.batch_id = "no/such";
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        cases[i].g.batch_id = cases[i].g.batch_id ? cases[i].g.batch_id : "lb";
        rd_error err = {0};
        rd_error_code c = rd_store_grade_put(s, &cases[i].g, cases[i].png_len ? png : NULL, cases[i].png_len, &err);
        cr_assert_eq(c, cases[i].code, "%s: %s, not %s (%s)", cases[i].why, rd_error_name(c),
                     rd_error_name(cases[i].code), err.message);
        cr_assert(err.code == c && err.message[0], "%s: its error", cases[i].why);
    }
    FAILS(RD_ERR_INVALID, rd_store_grade_put(s, NULL, NULL, 0, &e_));
    check_batch(s, "lb", 0, 50, RD_STORE_BATCH_RUNNING);
    /* At the limits: kept. */
    rd_store_grade a = grade_of("y1", "phong", name_at_limit, 1);
    a.batch_id = "lb";
    a.verdict = text_at_limit;
    a.reference_key = text_at_limit;
    OK(rd_store_grade_put(s, &a, png, 2000, &e_));
    check_stored(s, &a);
    check_diff(s, "y1", png, 2000);
    rd_store_grade b = grade_of("y2", name_at_limit, "", 2);
    b.pass = 0;
    b.error = text_at_limit;
    put_grade(s, &b);
    check_stored(s, &b);
    check_batch(s, "lb", 1, 50, RD_STORE_BATCH_RUNNING);
    check_list(s, NULL, "y1,y2");
    FAILS(RD_ERR_LIMIT, rd_store_batch_create(s, "lb2", name_over, 2, NULL, NULL, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_create(s, "lb2", "\xff", 2, NULL, NULL, &e_));
    OK(rd_store_batch_create(s, "lb2", name_at_limit, 2, NULL, NULL, &e_));
    rd_store_batch bb = batch_got(s, "lb2");
    cr_assert_str_eq(bb.assignment, name_at_limit);
    rd_store_close(s);
}

void case_upgrade_from_version_3(const store_env *e, void (*exec)(const char *sql), const char *blob)
{
    cr_assert_geq(rd_store_migration_count, 4);
    exec("CREATE TABLE schema_version (version INTEGER PRIMARY KEY, name TEXT NOT NULL, applied_ms BIGINT NOT NULL)");
    for (int i = 0; i < 3; i++) {
        char *sql = rd_store_migration_text(rd_store_migrations[i].sql, blob);
        cr_assert(sql);
        exec(sql);
        free(sql);
        char row[160];
        snprintf(row, sizeof row, "INSERT INTO schema_version VALUES (%d, '%s', 0)", rd_store_migrations[i].version,
                 rd_store_migrations[i].name);
        exec(row);
    }
    /* As a rayd of version 3 wrote it: a finished job with its PNG. */
    exec("INSERT INTO jobs (id, status, scene, format, query, hdr, width, height, memory_bytes, submitted_ms, "
         "started_ms, finished_ms, stats) VALUES ('old', 'done', 'x', 'cfg', '', 0, 8, 8, 0, 1, 2, 3, '{\"rays\":1}')");
    exec("INSERT INTO results (job_id, kind, data) VALUES ('old', 'png', 'PNGDATA')");
    rd_store *s = store_env_open(e);
    rd_store_job_info in = info_of(s, "old");
    cr_assert(in.status == RD_STORE_DONE && in.finished_ms == 3 && in.png_bytes == 7, "the job is as it was");
    cr_assert_str_eq(in.stats, "{\"rays\":1}");
    rd_store_job_info_free(&in);
    check_image(s, "old", RD_STORE_PNG, (const unsigned char *)"PNGDATA", 7);
    check_list(s, NULL, "");
    OK(rd_store_batch_create(s, "first", "phong", 1, NULL, NULL, &e_));
    rd_store_grade g = grade_of("a1b2c3d4e5f60718", "phong", "ann", 1700000000000LL);
    g.batch_id = "first";
    OK(rd_store_grade_put(s, &g, (const unsigned char *)"DIFF", 4, &e_));
    check_stored(s, &g);
    check_diff(s, g.id, (const unsigned char *)"DIFF", 4);
    check_batch(s, "first", 1, 1, RD_STORE_BATCH_DONE);
    rd_store_close(s);
    /* Opening again applies nothing and keeps them. */
    s = store_env_open(e);
    check_stored(s, &g);
    rd_store_close(s);
}

/* The ids of a batch list, "," between them. */
static void check_batches(rd_store *s, const rd_store_batch_filter *f, const char *want)
{
    rd_store_batch *l = NULL;
    size_t n = 99;
    OK(rd_store_batches_list(s, f, &l, &n, &e_));
    char got[256] = "";
    for (size_t i = 0; i < n; i++)
        snprintf(got + strlen(got), sizeof got - strlen(got), "%s%s", i ? "," : "", l[i].id);
    free(l);
    cr_assert_str_eq(got, want, "batches listed: %s, not %s", got, want);
}

/* ids (n of them, as a deletion gave them) are exactly want's, any order. */
static void check_ids(rd_store_grade_id *ids, size_t n, const char *const *want, size_t k)
{
    cr_assert_eq(n, k, "%zu grades deleted, not %zu", n, k);
    for (size_t i = 0; i < k; i++) {
        int found = 0;
        for (size_t j = 0; j < n; j++)
            found |= strcmp(ids[j].id, want[i]) == 0;
        cr_assert(found, "grade %s is not among the deleted", want[i]);
    }
    free(ids);
}

static void put_diff_grade(rd_store *s, const char *id, const char *batch, const char *student)
{
    static const unsigned char diff[] = "\x89PNG diff";
    rd_store_grade g = grade_of(id, "phong", student, 10);
    g.batch_id = batch;
    OK(rd_store_grade_put(s, &g, diff, sizeof diff, &e_));
}

static void check_no_image(rd_store *s, const char *id)
{
    unsigned char *data = NULL;
    size_t len = 0;
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_image(s, id, RD_STORE_GRADE_DIFF, &data, &len, &e_));
}

void case_batches_list(const store_env *e)
{
    rd_store *s = store_env_open(e);
    const char *ids[] = {"b-old", "b-mid", "b-new"};
    for (int i = 0; i < 3; i++) {
        OK(rd_store_batch_create(s, ids[i], i == 1 ? "diffuse" : "phong", 2, NULL, NULL, &e_));
        sleep_ms_store(5);
    }
    check_batches(s, NULL, "b-new,b-mid,b-old");
    rd_store_batch_filter f = {.max = 2};
    check_batches(s, &f, "b-new,b-mid");
    f = (rd_store_batch_filter){.assignment = "phong", .max = 10};
    check_batches(s, &f, "b-new,b-old");
    /* The next page from the last one's time: it again, then the older. */
    rd_store_batch mid;
    OK(rd_store_batch_get(s, "b-mid", &mid, &e_));
    f = (rd_store_batch_filter){.until_ms = mid.created_ms, .max = 10};
    check_batches(s, &f, "b-mid,b-old");
    f = (rd_store_batch_filter){.until_ms = 1, .max = 10};
    check_batches(s, &f, "");
    f = (rd_store_batch_filter){.assignment = "nosuch", .max = 10};
    check_batches(s, &f, "");
    f = (rd_store_batch_filter){.max = 0};
    check_batches(s, &f, "");
    rd_store_batch *l = NULL;
    size_t n = 0;
    f = (rd_store_batch_filter){.assignment = "\xff", .max = 5};
    FAILS(RD_ERR_INVALID, rd_store_batches_list(s, &f, &l, &n, &e_));
    f = (rd_store_batch_filter){.assignment = "", .max = 5};
    FAILS(RD_ERR_INVALID, rd_store_batches_list(s, &f, &l, &n, &e_));
    rd_store_close(s);
}

void case_batch_delete(const store_env *e)
{
    rd_store *s = store_env_open(e);
    OK(rd_store_batch_create(s, "run", "phong", 3, NULL, NULL, &e_));
    put_diff_grade(s, "r1", "run", "ann");
    /* Running: refused, nothing deleted. */
    rd_store_grade_id *ids = NULL;
    size_t n = 7;
    FAILS(RD_ERR_INVALID, rd_store_batch_delete(s, "run", &ids, &n, &e_));
    cr_assert(n == 7 && ids == NULL, "a refused delete gives nothing");
    check_batch(s, "run", 1, 3, RD_STORE_BATCH_RUNNING);
    /* Cancelled: it goes, with its grades and their images; a grade of no
     * batch and another batch's stay. */
    OK(rd_store_batch_create(s, "other", "phong", 1, NULL, NULL, &e_));
    put_diff_grade(s, "o1", "other", "ann");
    put_diff_grade(s, "alone", NULL, "ann");
    put_diff_grade(s, "r2", "run", "ben");
    OK(rd_store_batch_cancel(s, "run", NULL, &e_));
    OK(rd_store_batch_delete(s, "run", &ids, &n, &e_));
    check_ids(ids, n, (const char *const[]){"r1", "r2"}, 2);
    rd_store_batch b;
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_get(s, "run", &b, &e_));
    check_no_grade(s, "r1");
    check_no_grade(s, "r2");
    check_no_image(s, "r1");
    check_batch(s, "other", 1, 1, RD_STORE_BATCH_DONE);
    rd_store_grade kept = grade_got(s, "alone");
    rd_store_grade_free(&kept);
    /* Done: it goes too; ids and n may be NULL. */
    OK(rd_store_batch_delete(s, "other", NULL, NULL, &e_));
    check_no_grade(s, "o1");
    check_no_image(s, "o1");
    FAILS(RD_ERR_NOT_FOUND, rd_store_batch_delete(s, "other", &ids, &n, &e_));
    FAILS(RD_ERR_INVALID, rd_store_batch_delete(s, "bad id", &ids, &n, &e_));
    kept = grade_got(s, "alone");
    rd_store_grade_free(&kept);
    rd_store_close(s);
}

void case_grades_delete(const store_env *e)
{
    rd_store *s = store_env_open(e);
    OK(rd_store_batch_create(s, "c", "phong", 2, NULL, NULL, &e_));
    put_diff_grade(s, "a1", "c", "ann");
    put_diff_grade(s, "b1", "c", "ben");
    put_diff_grade(s, "a2", NULL, "ann");
    put_diff_grade(s, "u1", NULL, "");
    rd_store_grade_id *ids = NULL;
    size_t n = 0;
    OK(rd_store_grades_delete(s, "ann", &ids, &n, &e_));
    check_ids(ids, n, (const char *const[]){"a1", "a2"}, 2);
    check_no_grade(s, "a1");
    check_no_grade(s, "a2");
    check_no_image(s, "a2");
    /* The batch keeps its count; its rows no longer show her. */
    check_batch(s, "c", 2, 2, RD_STORE_BATCH_DONE);
    rd_store_grade_filter f = {.batch_id = "c", .max = 10};
    rd_store_grade *rows = NULL;
    OK(rd_store_grades_list(s, &f, &rows, &n, &e_));
    cr_assert(n == 1 && strcmp(rows[0].id, "b1") == 0, "the batch's rows after ann left: %zu", n);
    rd_store_grades_free(rows, n);
    /* Nobody of that name: none, not an error. */
    OK(rd_store_grades_delete(s, "ann", &ids, &n, &e_));
    cr_assert(n == 0 && ids == NULL, "a second delete found %zu", n);
    FAILS(RD_ERR_INVALID, rd_store_grades_delete(s, "\xc3", &ids, &n, &e_));
    /* One grade. */
    OK(rd_store_grade_delete(s, "u1", &e_));
    check_no_grade(s, "u1");
    FAILS(RD_ERR_NOT_FOUND, rd_store_grade_delete(s, "u1", &e_));
    FAILS(RD_ERR_INVALID, rd_store_grade_delete(s, "no such id", &e_));
    rd_store_grade b1 = grade_got(s, "b1");
    rd_store_grade_free(&b1);
    rd_store_close(s);
}
