/* Hostile and heavy clients against the real `rayd serve`: each test is one
 * way a single request used to take the daemon down or hold it, and asserts
 * the answer the client gets and that the daemon is still serving after.
 * Same conventions as test_daemon.c (tests/support/daemon_harness.h). The
 * inputs live in tests/hostile/. */
#include <arpa/inet.h>
#include <criterion/criterion.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "support/daemon_harness.h"

TestSuite(hostile, .init = setup, .fini = teardown, .timeout = 180);

#define FORM "multipart/form-data; boundary=XyZ"

/* ---- raw sockets, for what libcurl will not send ----------------------- */

static int raw_connect(int port)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    cr_assert_geq(fd, 0);
    struct sockaddr_in a = {0};
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    cr_assert_eq(connect(fd, (struct sockaddr *)&a, sizeof a), 0, "connect: %s", strerror(errno));
    return fd;
}

/* Reads until the peer closes or timeout_s passes; returns the bytes
 * (malloc'ed, NUL-terminated) and *closed = 1 when the peer closed. */
static char *raw_read_all(int fd, double timeout_s, size_t *len, int *closed)
{
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap + 1);
    double t0 = now_s();
    *closed = 0;
    while (now_s() - t0 < timeout_s) {
        struct pollfd p = {fd, POLLIN, 0};
        if (poll(&p, 1, 50) <= 0)
            continue;
        if (n == cap)
            buf = realloc(buf, (cap *= 2) + 1);
        ssize_t k = recv(fd, buf + n, cap - n, 0);
        if (k <= 0) {
            *closed = 1;
            break;
        }
        n += (size_t)k;
    }
    buf[n] = 0;
    *len = n;
    return buf;
}

static void assert_healthy(int port)
{
    resp r;
    GET(port, "/healthz", &r);
    cr_assert_eq(r.code, 200, "the daemon no longer answers /healthz (%s)", curl_easy_strerror(r.rc));
    resp_free(&r);
}

static char *job_field(int port, const char *id, const char *key, char *out, size_t n)
{
    char path[128];
    snprintf(path, sizeof path, "/v1/jobs/%s", id);
    resp r;
    GET(port, path, &r);
    out[0] = 0;
    if (r.code == 200)
        json_str(r.body, key, out, n);
    resp_free(&r);
    return out;
}

/* ---- 1. form parts without a field name --------------------------------- */

Test(hostile, form_part_without_name_is_400)
{
    server *s = start_server_default();
    static const char *const files[] = {"tests/hostile/grade_no_content_disposition.multipart",
                                        "tests/hostile/grade_part_without_headers.multipart",
                                        "tests/hostile/grade_unquoted_name.multipart"};
    for (size_t i = 0; i < 3; i++) {
        size_t len;
        char *body = slurp(files[i], &len);
        cr_assert_not_null(body, "%s missing", files[i]);
        resp r;
        POST(s->port, "/v1/grade", FORM, body, len, &r);
        assert_error(&r, 400, "parse_error");
        cr_assert(strstr(r.body, "no field name"), "%s: the message does not say what was wrong: %s", files[i], r.body);
        resp_free(&r);
        free(body);
        assert_healthy(s->port);
    }
    assert_clean_exit(s, 20);
}

/* Errors found while a form is still arriving are answered at its end. */
Test(hostile, form_errors_mid_upload_are_answered)
{
    server *s = start_server("--max-body-bytes", "100000");
    /* a field over the limit */
    size_t n = 150000;
    char *big = malloc(n + 400);
    int h = snprintf(big, 400,
                     "--XyZ\r\nContent-Disposition: form-data; name=\"image\"; filename=\"a.png\"\r\n"
                     "Content-Type: image/png\r\n\r\n");
    memset(big + h, 'x', n);
    size_t len = (size_t)h + n;
    len += (size_t)sprintf(big + len, "\r\n--XyZ--\r\n");
    resp r;
    POST(s->port, "/v1/grade", FORM, big, len, &r);
    assert_error(&r, 413, "too_large");
    cr_assert(strstr(r.body, "--max-body-bytes"), "%s", r.body);
    resp_free(&r);
    free(big);
    /* an assignment name far too long */
    char form[1024];
    char name[201];
    memset(name, 'a', 200);
    name[200] = 0;
    int fl = snprintf(form, sizeof form,
                      "--XyZ\r\nContent-Disposition: form-data; name=\"assignment\"\r\n\r\n%s\r\n--XyZ--\r\n", name);
    POST(s->port, "/v1/grade", FORM, form, (size_t)fl, &r);
    assert_error(&r, 400, "parse_error");
    resp_free(&r);
    /* a nested multipart/mixed part */
    fl = snprintf(form, sizeof form,
                  "--XyZ\r\nContent-Disposition: form-data; name=\"image\"\r\nContent-Type: multipart/mixed; "
                  "boundary=In\r\n\r\n--In\r\nContent-Disposition: file; filename=\"a.png\"\r\n\r\nxx\r\n--In--\r\n"
                  "--XyZ--\r\n");
    POST(s->port, "/v1/grade", FORM, form, (size_t)fl, &r);
    cr_assert(r.code >= 400 && r.code < 500, "a nested form got %ld (%s)", r.code, curl_easy_strerror(r.rc));
    resp_free(&r);
    assert_healthy(s->port);
    assert_clean_exit(s, 20);
}

/* ---- 2. runaway renders ------------------------------------------------- */

Test(hostile, runaway_job_honours_delete_and_timeout)
{
    server *s = start_server("--job-timeout-ms", "3000", "--threads", "2");
    size_t len;
    char *cfg = slurp("tests/hostile/runaway_area.cfg", &len);
    char a[64], b[64], st[64];
    submit_job(s->port, "", "text/plain", cfg, len, a, sizeof a);
    submit_job(s->port, "", "text/plain", cfg, len, b, sizeof b);
    cr_assert(wait_job_status(s->port, a, "running", 10, st, sizeof st), "job a never ran: %s", st);
    cr_assert(wait_job_status(s->port, b, "running", 10, st, sizeof st), "job b never ran: %s", st);
    /* Both render threads are busy inside one pixel each. */
    char path[128];
    snprintf(path, sizeof path, "/v1/jobs/%s", a);
    double t0 = now_s();
    resp r;
    DELETE(s->port, path, &r);
    cr_assert_eq(r.code, 200);
    resp_free(&r);
    cr_assert(wait_job_status(s->port, a, "cancelled", 1.0, st, sizeof st),
              "DELETE did not stop the job within 1 s (status %s)", st);
    double cancel_s = now_s() - t0;
    /* A probe renders on the freed thread. */
    size_t pl;
    char *phong = scene_text("scenes/phong.cfg", &pl);
    POST(s->port, "/v1/render?width=64&height=64", "text/plain", phong, pl, &r);
    assert_png(&r, 64, 64);
    resp_free(&r);
    free(phong);
    /* The other fails on its time limit, not much later than it. */
    cr_assert(wait_job_status(s->port, b, "failed", 5.0, st, sizeof st), "job b did not fail on its limit: %s", st);
    snprintf(path, sizeof path, "/v1/jobs/%s", b);
    GET(s->port, path, &r);
    cr_assert(strstr(r.body, "time_limit") && strstr(r.body, "--job-timeout-ms"), "%s", r.body);
    double elapsed;
    cr_assert(json_num(r.body, "elapsed_ms", &elapsed));
    cr_assert_lt(elapsed, 3000 + 1000, "the job ran %.0f ms past a 3000 ms limit", elapsed - 3000);
    resp_free(&r);
    cr_log_info("runaway: cancelled %.0f ms after DELETE; timed out after %.0f ms", cancel_s * 1e3, elapsed);
    free(cfg);
    assert_clean_exit(s, 20);
}

/* SIGTERM with a runaway synchronous client: every client answered, exit 0. */
Test(hostile, sigterm_with_runaway_sync_render_exits_0)
{
    server *s = start_server("--drain-ms", "1000", "--threads", "2");
    size_t len;
    char *cfg = slurp("tests/hostile/runaway_area.cfg", &len);
    bg_req b;
    bg_start(&b, s->port, "/v1/render", cfg, len, 60000);
    cr_assert_geq(wait_metric_ge(s->port, "rayd_jobs_running", 1, 10), 1);
    double secs;
    int st = stop_server(s, 10, &secs);
    cr_assert(st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 0, "rayd did not exit 0 (wait status %d)", st);
    cr_assert_lt(secs, 1.0 + 3.0, "stopping took %.1f s with --drain-ms 1000", secs);
    cr_assert(bg_join(&b, 10), "the waiting client got nothing");
    assert_error(&b.r, 503, "cancelled");
    resp_free(&b.r);
    free(cfg);
}

/* ---- 3. eviction keeps the newest --------------------------------------- */

Test(hostile, kept_jobs_evict_the_oldest)
{
    server *s = start_server("--max-jobs-kept", "8");
    size_t len;
    char *cfg = scene_text("scenes/phong.cfg", &len);
    char ids[12][64];
    /* Synchronous renders, already answered, keep their status in memory. */
    for (int i = 0; i < 12; i++) {
        resp r;
        POST(s->port, "/v1/render" SMALL_QUERY, "text/plain", cfg, len, &r);
        assert_png(&r, 8, 8);
        cr_assert(header(&r, "X-Rayd-Job", ids[i], sizeof ids[i]), "no X-Rayd-Job header");
        resp_free(&r);
    }
    for (int i = 0; i < 12; i++) {
        char path[128];
        snprintf(path, sizeof path, "/v1/jobs/%s", ids[i]);
        resp r;
        GET(s->port, path, &r);
        cr_assert_eq(r.code, i < 4 ? 404 : 200, "job %d of 12 (kept 8): %ld", i, r.code);
        resp_free(&r);
    }
    cr_assert_eq(get_metric(s->port, "rayd_jobs_kept"), 8);
    free(cfg);
    assert_clean_exit(s, 20);
}

/* Stored jobs stay until --result-ttl, then go with their images. */
Test(hostile, stored_jobs_expire_after_result_ttl)
{
    server *s = start_server("--result-ttl", "1", "--lease-ms", "500");
    size_t len;
    char *cfg = scene_text("scenes/phong.cfg", &len);
    char id[64], st[64], path[128];
    submit_job(s->port, SMALL_QUERY, "text/plain", cfg, len, id, sizeof id);
    cr_assert(wait_job_status(s->port, id, "done", 10, st, sizeof st), "%s", st);
    snprintf(path, sizeof path, "/v1/jobs/%s/image", id);
    resp r;
    GET(s->port, path, &r);
    assert_png(&r, 8, 8);
    resp_free(&r);
    long code = 200;
    for (double t0 = now_s(); code != 404 && now_s() - t0 < 10; sleep_ms(100)) {
        GET(s->port, path, &r);
        code = r.code;
        resp_free(&r);
    }
    cr_assert_eq(code, 404, "the image was still served 10 s after a 1 s --result-ttl");
    free(cfg);
    assert_clean_exit(s, 20);
}

/* ---- 4. the memory budget ----------------------------------------------- */

Test(hostile, job_that_never_fits_the_budget_is_413)
{
    server *s = start_server("--memory-budget", "50000000");
    size_t len;
    char *cfg = scene_text("scenes/phong.cfg", &len);
    resp r;
    /* 1024x1024 with samples > 1 holds 63 bytes a pixel: 66 MB. */
    POST(s->port, "/v1/render?width=1024&height=1024&samples=4", "text/plain", cfg, len, &r);
    assert_error(&r, 413, "too_large");
    cr_assert(strstr(r.body, "--memory-budget"), "%s", r.body);
    resp_free(&r);
    POST(s->port, "/v1/jobs?width=1024&height=1024&samples=4", "text/plain", cfg, len, &r);
    assert_error(&r, 413, "too_large");
    resp_free(&r);
    POST(s->port, "/v1/render?width=256&height=256&samples=4", "text/plain", cfg, len, &r);
    assert_png(&r, 256, 256);
    resp_free(&r);
    cr_assert_eq(get_metric(s->port, "rayd_memory_budget_bytes"), 50000000);
    free(cfg);
    assert_clean_exit(s, 20);
}

Test(hostile, jobs_wait_for_memory_instead_of_starting_together)
{
    server *s = start_server("--memory-budget", "100000000", "--threads", "2");
    size_t len;
    char *cfg = scene_text("scenes/area_light.cfg", &len);
    char a[64], b[64], st[64];
    /* Each needs about 66 MB: one fits, two do not. */
    submit_job(s->port, "?width=1024&height=1024&samples=64", "text/plain", cfg, len, a, sizeof a);
    submit_job(s->port, "?width=1024&height=1024&samples=64", "text/plain", cfg, len, b, sizeof b);
    cr_assert(wait_job_status(s->port, a, "running", 10, st, sizeof st), "%s", st);
    /* Rendering the first holds its memory; the second waits in the store. */
    cr_assert_geq(wait_metric_ge(s->port, "rayd_farm_memory_bytes", 60e6, 10), 60e6, "the first job holds no memory");
    sleep_ms(1000);
    cr_assert_eq(get_metric(s->port, "rayd_jobs_running"), 1);
    cr_assert_str_eq(job_field(s->port, b, "status", st, sizeof st), "queued", "the second job did not wait");
    /* Cancelling the first lets the second start. */
    char path[128];
    snprintf(path, sizeof path, "/v1/jobs/%s", a);
    resp r;
    DELETE(s->port, path, &r);
    resp_free(&r);
    cr_assert(wait_job_status(s->port, b, "running", 10, st, sizeof st), "the waiting job never started: %s", st);
    snprintf(path, sizeof path, "/v1/jobs/%s", b);
    DELETE(s->port, path, &r);
    resp_free(&r);
    free(cfg);
    assert_clean_exit(s, 20);
}

/* ---- 5. PNG allocation bomb --------------------------------------------- */

static long vm_hwm_kb(pid_t pid)
{
    char path[64];
    snprintf(path, sizeof path, "/proc/%d/status", (int)pid);
    char *t = slurp(path, NULL);
    const char *p = t ? strstr(t, "VmHWM:") : NULL;
    long kb = p ? strtol(p + 6, NULL, 10) : -1;
    free(t);
    return kb;
}

Test(hostile, png_chunk_bomb_costs_no_memory)
{
    server *s = start_server_default();
    size_t plen;
    char *png = slurp("tests/hostile/png_chunk_len_2GB_320x240.png", &plen);
    char head[] = "--XyZ\r\nContent-Disposition: form-data; name=\"assignment\"\r\n\r\nphong\r\n"
                  "--XyZ\r\nContent-Disposition: form-data; name=\"image\"; filename=\"a.png\"\r\n"
                  "Content-Type: image/png\r\n\r\n";
    char tail[] = "\r\n--XyZ--\r\n";
    size_t len = strlen(head) + plen + strlen(tail);
    char *body = malloc(len);
    memcpy(body, head, strlen(head));
    memcpy(body + strlen(head), png, plen);
    memcpy(body + strlen(head) + plen, tail, strlen(tail));
    for (int i = 0; i < 4; i++) {
        resp r;
        POST(s->port, "/v1/grade", FORM, body, len, &r);
        assert_error(&r, 422, "bad_image");
        resp_free(&r);
    }
    long hwm = vm_hwm_kb(s->pid);
    /* The sanitizer build's own overhead is far below this; the bomb asked for 2 GB. */
    cr_assert_lt(hwm, 300 * 1024, "peak memory %ld kB after a 195-byte PNG", hwm);
    free(body);
    free(png);
    assert_clean_exit(s, 20);
}

/* ---- 6. slow clients ---------------------------------------------------- */

Test(hostile, trickled_headers_and_bodies_are_cut_off)
{
    server *s = start_server("--header-timeout-ms", "500", "--body-timeout-ms", "1000");
    /* One header byte every 100 ms: idle time never exceeds the idle limit. */
    int fd = raw_connect(s->port);
    const char *req = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\r\n";
    double t0 = now_s();
    int cut = 0;
    for (size_t i = 0; req[i] && now_s() - t0 < 10; i++) {
        if (send(fd, req + i, 1, MSG_NOSIGNAL) != 1) {
            cut = 1;
            break;
        }
        struct pollfd p = {fd, POLLIN, 100};
        if (poll(&p, 1, 100) > 0) {
            char c;
            if (recv(fd, &c, 1, 0) <= 0) {
                cut = 1;
                break;
            }
        }
    }
    double hdr_s = now_s() - t0;
    close(fd);
    cr_assert(cut, "a connection trickling its headers was never closed");
    cr_assert_lt(hdr_s, 0.5 + 2.0, "closed only after %.1f s (header deadline 0.5 s)", hdr_s);
    /* A body announced whole but sent a byte at a time. */
    fd = raw_connect(s->port);
    const char *start = "POST /v1/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1000\r\n\r\n";
    cr_assert_eq(send(fd, start, strlen(start), MSG_NOSIGNAL), (ssize_t)strlen(start));
    t0 = now_s();
    cut = 0;
    for (int i = 0; i < 100 && !cut; i++) {
        if (send(fd, "x", 1, MSG_NOSIGNAL) != 1)
            cut = 1;
        struct pollfd p = {fd, POLLIN, 0};
        if (poll(&p, 1, 100) > 0) {
            char c;
            if (recv(fd, &c, 1, 0) <= 0)
                cut = 1;
        }
    }
    double body_s = now_s() - t0;
    close(fd);
    cr_assert(cut, "a trickled body was never cut off");
    cr_assert_lt(body_s, 1.0 + 2.0, "closed only after %.1f s (body deadline 1 s)", body_s);
    cr_assert_geq(get_metric(s->port, "rayd_http_deadline_closed_total"), 2);
    /* A kept-alive connection idles as before: the next request on it works. */
    fd = raw_connect(s->port);
    const char *get = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
    send(fd, get, strlen(get), MSG_NOSIGNAL);
    sleep_ms(1200);
    send(fd, get, strlen(get), MSG_NOSIGNAL);
    sleep_ms(300);
    size_t n;
    int closed;
    shutdown(fd, SHUT_WR);
    char *got = raw_read_all(fd, 3, &n, &closed);
    close(fd);
    int answers = 0;
    for (const char *p = got; (p = strstr(p, "HTTP/1.1 200")); p++)
        answers++;
    cr_assert_eq(answers, 2, "two requests 1.2 s apart on one connection: %d answers", answers);
    free(got);
    assert_clean_exit(s, 20);
}

/* ---- 7. nothing slow on the HTTP threads -------------------------------- */

Test(hostile, fifo_in_the_scenes_folder_does_not_hang)
{
    char dir[] = "/tmp/rayd-fifo-XXXXXX";
    cr_assert_not_null(mkdtemp(dir));
    char fifo[300];
    snprintf(fifo, sizeof fifo, "%s/f.obj", dir);
    cr_assert_eq(mkfifo(fifo, 0600), 0);
    server *s = start_server("--scenes", dir);
    const char *scene = "[material m]\ntype = diffuse\n[mesh]\nfile = f.obj\nmaterial = m\n";
    for (int i = 0; i < 3; i++) {
        resp r;
        req_opts o = {.method = "POST",
                      .path = "/v1/render?width=8&height=8",
                      .ctype = "text/plain",
                      .body = scene,
                      .len = strlen(scene),
                      .timeout_ms = 10000};
        http(s->port, &o, &r);
        cr_assert_eq(r.code, 422, "a FIFO as a mesh: %ld (%s)", r.code, curl_easy_strerror(r.rc));
        cr_assert(strstr(r.body, "not a regular file"), "%s", r.body);
        resp_free(&r);
    }
    assert_healthy(s->port);
    assert_clean_exit(s, 20);
    unlink(fifo);
    rmdir(dir);
}

/* The HTTP threads answer while every render thread is busy. */
Test(hostile, http_threads_answer_while_renders_run)
{
    server *s = start_server("--threads", "2");
    size_t len;
    char *cfg = slurp("tests/hostile/runaway_area.cfg", &len);
    char a[64], b[64], st[64];
    submit_job(s->port, "", "text/plain", cfg, len, a, sizeof a);
    submit_job(s->port, "", "text/plain", cfg, len, b, sizeof b);
    cr_assert(wait_job_status(s->port, b, "running", 10, st, sizeof st), "%s", st);
    for (int i = 0; i < 20; i++) {
        assert_healthy(s->port);
        resp r;
        GET(s->port, "/metrics", &r);
        cr_assert_eq(r.code, 200);
        resp_free(&r);
    }
    free(cfg);
    assert_clean_exit(s, 20);
}

/* ---- 8. answers that never came ----------------------------------------- */

Test(hostile, half_closed_client_gets_its_image)
{
    server *s = start_server_default();
    size_t len;
    char *cfg = scene_text("scenes/phong.cfg", &len);
    int fd = raw_connect(s->port);
    char head[300];
    int hl = snprintf(head, sizeof head,
                      "POST /v1/render?width=256&height=256&samples=16 HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                      "Content-Type: text/plain\r\nContent-Length: %zu\r\nConnection: close\r\n\r\n",
                      len);
    send(fd, head, (size_t)hl, MSG_NOSIGNAL);
    send(fd, cfg, len, MSG_NOSIGNAL);
    shutdown(fd, SHUT_WR);
    size_t n;
    int closed;
    char *got = raw_read_all(fd, 30, &n, &closed);
    close(fd);
    char *final = strstr(got, "HTTP/1.1 200 OK");
    cr_assert_not_null(final, "a half-closed client got no image: %.200s", got);
    cr_assert(strstr(final, "Content-Type: image/png"), "%.300s", final);
    free(got);
    free(cfg);
    assert_clean_exit(s, 20);
}

Test(hostile, too_many_query_arguments_is_431)
{
    server *s = start_server_default();
    size_t cap = 600 * 8 + 200, off = 0;
    char *req = malloc(cap);
    off += (size_t)snprintf(req, cap, "GET /healthz?a0=1");
    for (int i = 1; i < 600; i++)
        off += (size_t)snprintf(req + off, cap - off, "&a%d=1", i);
    off += (size_t)snprintf(req + off, cap - off, " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    int fd = raw_connect(s->port);
    send(fd, req, off, MSG_NOSIGNAL);
    size_t n;
    int closed;
    char *got = raw_read_all(fd, 5, &n, &closed);
    close(fd);
    cr_assert(strncmp(got, "HTTP/1.1 431", 12) == 0, "600 query arguments: %.120s", got);
    cr_assert(strstr(got, "--max-query-args"), "%s", got);
    cr_assert(closed, "the connection stayed open");
    free(got);
    free(req);
    assert_healthy(s->port);
    assert_clean_exit(s, 20);
}

/* ---- 9. links out of the scene and assignment folders ------------------- */

Test(hostile, symlinks_out_of_folders_are_not_served)
{
    char dir[] = "/tmp/rayd-links-XXXXXX";
    cr_assert_not_null(mkdtemp(dir));
    char adir[300], p[400];
    snprintf(adir, sizeof adir, "%s/assignments", dir);
    cr_assert_eq(mkdir(adir, 0700), 0);
    snprintf(p, sizeof p, "%s/evil.cfg", dir);
    cr_assert_eq(symlink("/etc/passwd", p), 0);
    snprintf(p, sizeof p, "%s/good.cfg", dir);
    FILE *f = fopen(p, "w");
    fputs("[render]\nwidth = 8\n", f);
    fclose(f);
    snprintf(p, sizeof p, "%s/zz.cfg", adir);
    cr_assert_eq(symlink("/etc/passwd", p), 0);
    server *s = start_server("--scenes", dir, "--assignments", adir);
    resp r;
    GET(s->port, "/v1/scenes/evil.cfg", &r);
    assert_error(&r, 404, "not_found");
    resp_free(&r);
    GET(s->port, "/v1/scenes", &r);
    cr_assert(!strstr(r.body, "evil"), "the list advertises a link out: %s", r.body);
    cr_assert(strstr(r.body, "good.cfg"), "%s", r.body);
    resp_free(&r);
    GET(s->port, "/v1/assignments/zz/scene", &r);
    assert_error(&r, 404, "not_found");
    cr_assert(!strstr(r.body, "root:"), "%s", r.body);
    resp_free(&r);
    assert_clean_exit(s, 20);
    snprintf(p, sizeof p, "%s/zz.cfg", adir);
    unlink(p);
    rmdir(adir);
    snprintf(p, sizeof p, "%s/evil.cfg", dir);
    unlink(p);
    snprintf(p, sizeof p, "%s/good.cfg", dir);
    unlink(p);
    rmdir(dir);
}
