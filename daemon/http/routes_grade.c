/* POST /v1/grade, GET /v1/assignments, GET /v1/grades/{id}/...: grading
 * through the same render queue as everything else, so no HTTP thread ever
 * renders a reference. References stay in memory (and in --cache-dir) by
 * scene and renderer; finished grades keep their images for the page. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

#include "asset_source.h"
#include "assignment.h"
#include "grading.h"
#include "http_internal.h"
#include "png_read.h"
#include "png_write.h"
#include "reference.h"
#include "scene_assets.h"
#include "scene_load.h"
#include "file_io.h"

enum { REF_CACHE = 32, GRADES_KEPT = 256 };

typedef struct {
    char key[17];
    uint8_t *rgb;
    int w, h;
    double used;
} ref_entry;

typedef struct {
    char id[24];
    unsigned char *diff, *reference, *image; /* PNGs */
    size_t diff_len, reference_len, image_len;
    double t;
} grade_entry;

struct rd_grades {
    pthread_mutex_t mu;
    ref_entry refs[REF_CACHE];
    grade_entry kept[GRADES_KEPT];
    size_t next;
    uint64_t key;
    uint64_t counter;
    rd_jq *jobs;                /* told of every byte the caches hold */
    size_t bytes, cap;
};

/* The form as it arrives, on the HTTP thread. */
struct rd_grade_req {
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    int too_big;
    const char *bad;            /* the form is malformed: why (answered once it has arrived) */
};

/* One grade on a render thread: prepared (scene, image, reference from the
 * caches), rendered only when no reference is cached, then finished
 * (compare, heat map, the kept PNGs, the verdict). */
typedef struct {
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    rd_server *srv;
    rd_grade_output out;
    char refkey[17];
    unsigned status;            /* an error's HTTP status when not the scene code's */
    const char *slug;
    char *json;                 /* the verdict */
} grade_task;

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

struct rd_grades *rd_grades_new(rd_jq *jobs, size_t cap)
{
    struct rd_grades *g = calloc(1, sizeof *g);
    if (g) {
        g->jobs = jobs;
        g->cap = cap;
        pthread_mutex_init(&g->mu, NULL);
        if (getrandom(&g->key, sizeof g->key, 0) != (ssize_t)sizeof g->key)
            g->key = (uint64_t)now_ms() * 0x9e3779b97f4a7c15ULL;
    }
    return g;
}

void rd_grades_free(struct rd_grades *g)
{
    if (!g)
        return;
    for (int i = 0; i < REF_CACHE; i++)
        free(g->refs[i].rgb);
    for (int i = 0; i < GRADES_KEPT; i++) {
        free(g->kept[i].diff);
        free(g->kept[i].reference);
        free(g->kept[i].image);
    }
    pthread_mutex_destroy(&g->mu);
    free(g);
}

static size_t kept_bytes(const grade_entry *e) { return e->diff_len + e->reference_len + e->image_len; }

static void drop_ref(struct rd_grades *g, ref_entry *e)
{
    if (!e->rgb)
        return;
    size_t n = (size_t)e->w * (size_t)e->h * 3;
    g->bytes -= n;
    rd_jq_external_bytes(g->jobs, -(long long)n);
    free(e->rgb);
    e->rgb = NULL;
}

static void drop_kept(struct rd_grades *g, grade_entry *e)
{
    size_t n = kept_bytes(e);
    g->bytes -= n;
    rd_jq_external_bytes(g->jobs, -(long long)n);
    free(e->diff);
    free(e->reference);
    free(e->image);
    memset(e, 0, sizeof *e);
}

/* The caches grew by delta bytes: past --grade-cache-bytes, the least
 * recently used references go first, then the oldest kept grades. Under
 * g->mu. */
static void account(struct rd_grades *g, long long delta)
{
    g->bytes += (size_t)delta;
    rd_jq_external_bytes(g->jobs, delta);
    while (g->bytes > g->cap) {
        ref_entry *lru = NULL;
        for (int i = 0; i < REF_CACHE; i++)
            if (g->refs[i].rgb && (!lru || g->refs[i].used < lru->used))
                lru = &g->refs[i];
        if (lru) {
            drop_ref(g, lru);
            continue;
        }
        grade_entry *old = NULL;
        for (int i = 0; i < GRADES_KEPT; i++)
            if (g->kept[i].id[0] && (!old || g->kept[i].t < old->t))
                old = &g->kept[i];
        if (!old)
            break;
        drop_kept(g, old);
    }
}

/* A copy of the cached reference, or NULL. */
static uint8_t *ref_lookup(struct rd_grades *g, const char *key, int w, int h)
{
    uint8_t *copy = NULL;
    pthread_mutex_lock(&g->mu);
    for (int i = 0; i < REF_CACHE; i++)
        if (g->refs[i].rgb && strcmp(g->refs[i].key, key) == 0 && g->refs[i].w == w && g->refs[i].h == h) {
            size_t n = (size_t)w * (size_t)h * 3;
            if ((copy = malloc(n)))
                memcpy(copy, g->refs[i].rgb, n);
            g->refs[i].used = now_ms();
            break;
        }
    pthread_mutex_unlock(&g->mu);
    return copy;
}

static void ref_store(struct rd_grades *g, const char *key, const uint8_t *rgb, int w, int h)
{
    size_t n = (size_t)w * (size_t)h * 3;
    uint8_t *copy = malloc(n);
    if (!copy)
        return;
    memcpy(copy, rgb, n);
    pthread_mutex_lock(&g->mu);
    int slot = 0;
    for (int i = 0; i < REF_CACHE; i++) {
        if (!g->refs[i].rgb) {
            slot = i;
            break;
        }
        if (g->refs[i].used < g->refs[slot].used)
            slot = i;
    }
    drop_ref(g, &g->refs[slot]);
    snprintf(g->refs[slot].key, sizeof g->refs[slot].key, "%s", key);
    g->refs[slot].rgb = copy;
    g->refs[slot].w = w;
    g->refs[slot].h = h;
    g->refs[slot].used = now_ms();
    account(g, (long long)n);
    pthread_mutex_unlock(&g->mu);
}

static unsigned char *encode(const uint8_t *rgb, int w, int h, size_t *len)
{
    unsigned char *png = NULL;
    rd_error err;
    rd_png_options po = rd_png_options_default();
    if (rd_png_encode(rgb, w, h, &po, &png, len, &err))
        return NULL;
    return png;
}

/* Keeps the images of a finished grade for GET /v1/grades/{id}/...; returns its id. */
static void keep(struct rd_grades *g, const rd_grade_output *o, char id[24])
{
    size_t n = (size_t)o->width * (size_t)o->height * 3;
    uint8_t *heat = malloc(n);
    grade_entry e;
    memset(&e, 0, sizeof e);
    if (heat) {
        rd_grade_heatmap(o->reference, o->image, o->width, o->height, o->thresholds.fail, heat);
        e.diff = encode(heat, o->width, o->height, &e.diff_len);
        free(heat);
    }
    e.reference = encode(o->reference, o->width, o->height, &e.reference_len);
    e.image = encode(o->image, o->width, o->height, &e.image_len);
    e.t = now_ms();
    pthread_mutex_lock(&g->mu);
    uint64_t z = g->key ^ ++g->counter;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    snprintf(e.id, sizeof e.id, "g%016llx", (unsigned long long)(z ^ (z >> 31)));
    grade_entry *slot = &g->kept[g->next++ % GRADES_KEPT];
    drop_kept(g, slot);
    *slot = e;
    account(g, (long long)kept_bytes(&e));
    pthread_mutex_unlock(&g->mu);
    memcpy(id, e.id, sizeof e.id);
}

void rd_grade_req_free(rd_req *r)
{
    if (r->post)
        MHD_destroy_post_processor(r->post);
    r->post = NULL;
    if (r->grade) {
        free(r->grade->image);
        free(r->grade->scene);
        free(r->grade);
        r->grade = NULL;
    }
}

static enum MHD_Result on_field(void *cls, enum MHD_ValueKind kind, const char *key, const char *filename,
                                const char *content_type, const char *encoding, const char *data, uint64_t off,
                                size_t size)
{
    (void)kind, (void)filename, (void)content_type, (void)encoding, (void)off;
    rd_req *r = cls;
    rd_grade_req *g = r->grade;
    /* A part without a Content-Disposition name (or with an unquoted one)
     * comes with no key at all. */
    if (!key) {
        g->bad = "a form part has no field name (Content-Disposition: form-data; name=\"...\")";
        return MHD_NO;
    }
    if (size && !data)
        return MHD_YES;
    char **buf = NULL;
    size_t *len = NULL;
    if (strcmp(key, "image") == 0) {
        buf = &g->image;
        len = &g->image_len;
    } else if (strcmp(key, "scene") == 0) {
        buf = &g->scene;
        len = &g->scene_len;
    } else if (strcmp(key, "assignment") == 0) {
        size_t have = strlen(g->assignment);
        if (have + size < sizeof g->assignment) {
            memcpy(g->assignment + have, data, size);
            g->assignment[have + size] = 0;
            return MHD_YES;
        }
        g->bad = "the 'assignment' field is longer than an assignment name can be";
        return MHD_NO;
    } else {
        return MHD_YES; /* other fields are ignored */
    }
    if (*len + size > r->srv->opt.max_body_bytes) {
        g->too_big = 1;
        return MHD_NO;
    }
    char *p = realloc(*buf, *len + size + 1);
    if (!p)
        return MHD_NO;
    memcpy(p + *len, data, size);
    *len += size;
    p[*len] = 0;
    *buf = p;
    return MHD_YES;
}

enum MHD_Result rd_route_grade_begin(rd_req *r)
{
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (!ct || strncasecmp(ct, "multipart/form-data", 19) != 0)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL,
                              "send multipart/form-data with 'image' and 'assignment' or 'scene'");
    r->grade = calloc(1, sizeof *r->grade);
    if (!r->grade)
        return MHD_NO;
    r->post = MHD_create_post_processor(r->conn, 64 * 1024, on_field, r);
    if (!r->post)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, "the form could not be read");
    return MHD_YES;
}

/* libmicrohttpd 0.9.75 cannot answer in the middle of an upload, so a form
 * found bad stops being parsed and the rest of it is read and dropped; the
 * answer goes out once it has all arrived (one that runs far past the limit
 * has its connection closed instead). */
enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size)
{
    rd_grade_req *g = r->grade;
    if (g->bad || g->too_big) {
        r->discarded += size;
        return r->discarded > 3 * r->srv->opt.max_body_bytes + (1u << 20) ? MHD_NO : MHD_YES;
    }
    if (MHD_post_process(r->post, data, size) != MHD_YES && !g->bad && !g->too_big)
        g->bad = "the form data is malformed";
    return MHD_YES;
}

/* The kept images' addresses and the cache flag, added to the verdict. */
static char *verdict_json(const rd_grade_output *o, const char *id)
{
    char url[80];
    snprintf(url, sizeof url, "/v1/grades/%s/diff.png", id);
    char *json = rd_grade_json(o, url);
    cJSON *root = json ? cJSON_Parse(json) : NULL;
    free(json);
    if (!root)
        return NULL;
    cJSON_AddStringToObject(root, "id", id);
    snprintf(url, sizeof url, "/v1/grades/%s/reference.png", id);
    cJSON_AddStringToObject(root, "reference_url", url);
    snprintf(url, sizeof url, "/v1/grades/%s/image.png", id);
    cJSON_AddStringToObject(root, "image_url", url);
    cJSON_AddBoolToObject(root, "reference_cached", o->reference_cached);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

static rd_error_code fail_as(grade_task *t, unsigned status, const char *slug, rd_error_code rc)
{
    t->status = status;
    t->slug = slug;
    return rc;
}

/* Width and height from a PNG's IHDR, which the signature check put at a
 * fixed place, so a size mismatch is found before decoding anything. */
static int png_size(const unsigned char *p, size_t len, unsigned *w, unsigned *h)
{
    if (len < 24 || memcmp(p + 12, "IHDR", 4) != 0)
        return 0;
    *w = (unsigned)p[16] << 24 | (unsigned)p[17] << 16 | (unsigned)p[18] << 8 | p[19];
    *h = (unsigned)p[20] << 24 | (unsigned)p[21] << 16 | (unsigned)p[22] << 8 | p[23];
    return 1;
}

/* The reference from memory or --cache-dir; NULL when neither has it. */
static uint8_t *cached_reference(grade_task *t, int w, int h)
{
    rd_server *srv = t->srv;
    uint8_t *ref = ref_lookup(srv->grades, t->refkey, w, h);
    if (ref || !srv->opt.cache_dir)
        return ref;
    char path[1100];
    char *data;
    size_t len;
    int cw, ch;
    rd_error err;
    snprintf(path, sizeof path, "%s/%s.png", srv->opt.cache_dir, t->refkey);
    if (rd_read_file(path, 1u << 30, "(cache)", &data, &len, &err) != RD_OK)
        return NULL;
    if (rd_grade_load_png((unsigned char *)data, len, (size_t)w * (size_t)h, &ref, &cw, &ch, &err) || cw != w ||
        ch != h) {
        free(ref);
        ref = NULL;
    }
    free(data);
    return ref;
}

static rd_error_code load_scene(grade_task *t, rd_scene *s, rd_error *err)
{
    rd_server *srv = t->srv;
    rd_grade_output *o = &t->out;
    rd_error_code rc;
    char *dir;
    if (t->assignment[0]) {
        rd_assignment a;
        rc = rd_assignment_load(srv->opt.assignments_dir, t->assignment, &a, err);
        if (rc)
            return fail_as(t, rc == RD_ERR_IO ? 404 : 422, rc == RD_ERR_IO ? "not_found" : "bad_assignment", rc);
        snprintf(o->assignment, sizeof o->assignment, "%s", a.name);
        snprintf(o->title, sizeof o->title, "%s", a.title);
        o->thresholds = a.thresholds;
        rc = rd_scene_load_file(a.scene_path, &srv->opt.limits, s, err);
        dir = rd_dirname(a.scene_path);
    } else {
        rc = rd_scene_parse(t->scene, t->scene_len, RD_FMT_AUTO, "<upload>", &srv->opt.limits, s, err);
        dir = strdup(srv->opt.scenes_dir);
    }
    if (!rc)
        rc = rd_scene_check_limits(s, &srv->opt.limits, "<upload>", err);
    if (!rc) {
        rd_asset_source src = rd_asset_folder(dir ? dir : ".");
        rc = rd_scene_load_assets(s, &src, &srv->opt.limits, NULL, err);
    }
    free(dir);
    return rc;
}

static rd_error_code load_image(grade_task *t, int w, int h, rd_error *err)
{
    rd_grade_output *o = &t->out;
    const unsigned char *png = (const unsigned char *)t->image;
    if (!rd_png_sniff(png, t->image_len))
        return fail_as(t, 415, "unsupported_media_type",
                       rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image is not a PNG file"));
    unsigned iw, ih;
    if (png_size(png, t->image_len, &iw, &ih) && (iw != (unsigned)w || ih != (unsigned)h))
        return fail_as(t, 422, "size_mismatch",
                       rd_error_set(err, RD_ERR_INVALID, 0, 0, "the image is %ux%u; the %s renders %dx%d", iw, ih,
                                    t->assignment[0] ? "assignment" : "scene", w, h));
    int dw, dh;
    rd_error_code rc = rd_grade_load_png(png, t->image_len, t->srv->opt.limits.max_pixels, &o->image, &dw, &dh, err);
    if (rc)
        return rc == RD_ERR_LIMIT ? fail_as(t, 413, "too_large", rc) : fail_as(t, 422, "bad_image", rc);
    free(t->image);
    t->image = NULL;
    o->width = dw;
    o->height = dh;
    return RD_OK;
}

static rd_error_code prepare_grade(void *arg, rd_scene *s, int *render, rd_error *err)
{
    grade_task *t = arg;
    rd_grade_output *o = &t->out;
    o->thresholds = rd_grade_thresholds_default();
    rd_error_code rc = load_scene(t, s, err);
    if (!rc)
        rc = load_image(t, s->render.width, s->render.height, err);
    if (!rc && rd_reference_key(s, t->refkey, err))
        rc = fail_as(t, 503, "unavailable", RD_ERR_NOMEM);
    if (rc)
        return rc;
    o->reference = cached_reference(t, o->width, o->height);
    o->reference_cached = o->reference != NULL;
    *render = !o->reference;
    return RD_OK;
}

static rd_error_code finish_grade(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    grade_task *t = arg;
    rd_server *srv = t->srv;
    rd_grade_output *o = &t->out;
    if (rgb) {
        size_t n = (size_t)w * (size_t)h * 3;
        if (!(o->reference = malloc(n)))
            return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        memcpy(o->reference, rgb, n);
        ref_store(srv->grades, t->refkey, rgb, w, h);
        if (srv->opt.cache_dir) {
            size_t len;
            unsigned char *png = encode(rgb, w, h, &len);
            char path[1100];
            rd_error ignore;
            snprintf(path, sizeof path, "%s/%s.png", srv->opt.cache_dir, t->refkey);
            if (png)
                rd_write_file(path, png, len, &ignore);
            free(png);
        }
    }
    rd_grade_compare(o->reference, o->image, o->width, o->height, &o->thresholds, &o->result);
    char id[24];
    keep(srv->grades, o, id);
    t->json = verdict_json(o, id);
    return t->json ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

static void free_grade(void *arg)
{
    grade_task *t = arg;
    if (!t)
        return;
    free(t->image);
    free(t->scene);
    free(t->json);
    rd_grade_output_free(&t->out);
    free(t);
}

enum MHD_Result rd_route_grade(rd_req *r)
{
    rd_server *srv = r->srv;
    rd_grade_req *g = r->grade;
    if (!g)
        return rd_reply_error(r, 400, "parse_error", NULL, "no form");
    if (g->too_big) {
        char msg[160];
        snprintf(msg, sizeof msg, "a form field is over the limit of %zu bytes (--max-body-bytes)",
                 srv->opt.max_body_bytes);
        return rd_reply_error(r, 413, "too_large", NULL, msg);
    }
    if (g->bad)
        return rd_reply_error(r, 400, "parse_error", NULL, g->bad);
    if (atomic_load(&srv->draining))
        return rd_reply_error_hdr(r, 503, "draining", "the server is shutting down", "Retry-After", "5");
    if (!g->image || !g->image_len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'image' file");
    if (!g->assignment[0] == !g->scene)
        return rd_reply_error(r, 400, "parse_error", NULL, "give exactly one of 'assignment' or 'scene'");
    grade_task *t = calloc(1, sizeof *t);
    if (!t)
        return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
    t->srv = srv;
    t->image = g->image;
    t->image_len = g->image_len;
    t->scene = g->scene;
    t->scene_len = g->scene_len;
    memcpy(t->assignment, g->assignment, sizeof t->assignment);
    g->image = g->scene = NULL;
    rd_jq_task task = {prepare_grade, finish_grade, free_grade, t, t->image_len + t->scene_len};
    rd_jq_submit_options so = {.watch_fd = rd_req_socket(r), .watch_http11 = r->http11, .done = rd_req_on_done,
                               .user = r};
    rd_jq_job *job;
    rd_error err = {0};
    rd_error_code rc = rd_jq_submit(srv->jobs, &task, &so, &job, &err);
    if (rc == RD_ERR_BUSY)
        return rd_reply_error_hdr(r, 503, "queue_full", err.message, "Retry-After", "1");
    if (rc)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    rd_jq_info info;
    rd_jq_info_get(srv->jobs, job, &info);
    snprintf(r->job_id, sizeof r->job_id, "%s", info.id);
    return rd_req_wait(r, job) ? rd_route_grade_resumed(r) : MHD_YES;
}

enum MHD_Result rd_route_grade_resumed(rd_req *r)
{
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, r->job, &info);
    grade_task *t = rd_jq_task_arg(r->job);
    if (info.status == RD_JOB_DONE && t->json) {
        char *json = t->json;
        t->json = NULL;
        return rd_reply_json(r, 200, json);
    }
    if (info.status == RD_JOB_FAILED) {
        rd_error_code c = info.error.code;
        if (t->status)
            return rd_reply_error(r, t->status, t->slug, &info.error, NULL);
        if (c == RD_ERR_TIMEOUT)
            return rd_reply_error(r, 422, "time_limit", &info.error, NULL);
        return rd_reply_error(r, rd_status_for(c), rd_code_for(c), &info.error, NULL);
    }
    if (info.hung_up)
        return MHD_NO;
    return rd_reply_error_hdr(r, 503, "cancelled", "the grade was cancelled (the server is shutting down)",
                              "Retry-After", "5");
}

enum MHD_Result rd_route_grade_files(rd_req *r, const char *rest)
{
    /* rest: "{id}/diff.png", "{id}/reference.png" or "{id}/image.png" */
    const char *slash = strchr(rest, '/');
    if (!slash || slash - rest >= 24)
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade");
    char id[24];
    memcpy(id, rest, (size_t)(slash - rest));
    id[slash - rest] = 0;
    const char *what = slash + 1;
    struct rd_grades *g = r->srv->grades;
    unsigned char *copy = NULL;
    size_t len = 0;
    pthread_mutex_lock(&g->mu);
    for (int i = 0; i < GRADES_KEPT; i++) {
        grade_entry *e = &g->kept[i];
        if (!e->id[0] || strcmp(e->id, id) != 0)
            continue;
        const unsigned char *src = strcmp(what, "diff.png") == 0        ? e->diff
                                   : strcmp(what, "reference.png") == 0 ? e->reference
                                   : strcmp(what, "image.png") == 0     ? e->image
                                                                        : NULL;
        len = strcmp(what, "diff.png") == 0        ? e->diff_len
              : strcmp(what, "reference.png") == 0 ? e->reference_len
                                                   : e->image_len;
        if (src && (copy = malloc(len)))
            memcpy(copy, src, len);
        break;
    }
    pthread_mutex_unlock(&g->mu);
    if (!copy)
        return rd_reply_error(r, 404, "not_found", NULL, "no such grade image (the last 256 grades are kept)");
    return rd_reply(r, 200, "image/png", copy, len, 1);
}

enum MHD_Result rd_route_assignments(rd_req *r, const char *name)
{
    if (name && *name) {
        char n[80];
        const char *slash = strchr(name, '/');
        size_t len = slash ? (size_t)(slash - name) : strlen(name);
        if (len >= sizeof n || (slash && strcmp(slash, "/scene") != 0))
            return rd_reply_error(r, 404, "not_found", NULL, "no such assignment");
        memcpy(n, name, len);
        n[len] = 0;
        rd_assignment a;
        rd_error err = {0};
        char *text;
        size_t tl;
        if (rd_assignment_load(r->srv->opt.assignments_dir, n, &a, &err) ||
            rd_read_file(a.scene_path, r->srv->opt.limits.max_bytes, "--max-scene-bytes", &text, &tl, &err))
            return rd_reply_error(r, 404, "not_found", NULL, "no such assignment");
        return rd_reply(r, 200, "text/x-rayd-cfg", text, tl, 1);
    }
    rd_assignment *list;
    size_t n;
    rd_error err = {0};
    if (rd_assignment_list(r->srv->opt.assignments_dir, &list, &n, &err))
        return rd_reply_json(r, 200, strdup("{\"assignments\":[]}"));
    cJSON *root = cJSON_CreateObject(), *arr = cJSON_AddArrayToObject(root, "assignments");
    for (size_t i = 0; i < n; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", list[i].name);
        cJSON_AddStringToObject(o, "title", list[i].title);
        rd_scene s;
        rd_scene_init(&s);
        rd_error e2;
        if (rd_scene_load_file(list[i].scene_path, NULL, &s, &e2) == RD_OK) {
            cJSON_AddNumberToObject(o, "width", s.render.width);
            cJSON_AddNumberToObject(o, "height", s.render.height);
        }
        rd_scene_free(&s);
        cJSON *t = cJSON_AddObjectToObject(o, "thresholds");
        cJSON_AddNumberToObject(t, "fail", list[i].thresholds.fail);
        cJSON_AddNumberToObject(t, "fail_fraction", list[i].thresholds.fail_fraction);
        cJSON_AddNumberToObject(t, "hard_fail", list[i].thresholds.hard_fail);
        cJSON_AddNumberToObject(t, "hard_fail_pixels", list[i].thresholds.hard_fail_pixels);
        char url[200];
        snprintf(url, sizeof url, "/v1/assignments/%s/scene", list[i].name);
        cJSON_AddStringToObject(o, "scene_url", url);
        cJSON_AddItemToArray(arr, o);
    }
    free(list);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return rd_reply_json(r, 200, text);
}
