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
};

struct rd_grade_req {
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    int too_big;
    /* set once the scene is loaded */
    rd_grade_output out;
    char refkey[17];
};

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

struct rd_grades *rd_grades_new(void)
{
    struct rd_grades *g = calloc(1, sizeof *g);
    if (g) {
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
    free(g->refs[slot].rgb);
    snprintf(g->refs[slot].key, sizeof g->refs[slot].key, "%s", key);
    g->refs[slot].rgb = copy;
    g->refs[slot].w = w;
    g->refs[slot].h = h;
    g->refs[slot].used = now_ms();
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
    free(slot->diff);
    free(slot->reference);
    free(slot->image);
    *slot = e;
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
        rd_grade_output_free(&r->grade->out);
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
        } else {
            g->too_big = 1;
        }
        return MHD_YES;
    } else {
        return MHD_YES; /* other fields are ignored */
    }
    if (*len + size > r->srv->opt.max_body_bytes) {
        g->too_big = 1;
        return MHD_YES;
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

enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size)
{
    if (MHD_post_process(r->post, data, size) != MHD_YES)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form data is malformed");
    if (r->grade->too_big) {
        char msg[160];
        snprintf(msg, sizeof msg, "a form field is over the limit of %zu bytes (--max-body-bytes)",
                 r->srv->opt.max_body_bytes);
        return rd_reply_error(r, 413, "too_large", NULL, msg);
    }
    return MHD_YES;
}

static enum MHD_Result answer(rd_req *r)
{
    rd_grade_req *g = r->grade;
    rd_grade_output *o = &g->out;
    rd_grade_compare(o->reference, o->image, o->width, o->height, &o->thresholds, &o->result);
    char id[24], url[80];
    keep(r->srv->grades, o, id);
    snprintf(url, sizeof url, "/v1/grades/%s/diff.png", id);
    char *json = rd_grade_json(o, url);
    if (!json)
        return MHD_NO;
    /* Add the id and the other images' addresses for the page. */
    cJSON *root = cJSON_Parse(json);
    free(json);
    if (!root)
        return MHD_NO;
    cJSON_AddStringToObject(root, "id", id);
    snprintf(url, sizeof url, "/v1/grades/%s/reference.png", id);
    cJSON_AddStringToObject(root, "reference_url", url);
    snprintf(url, sizeof url, "/v1/grades/%s/image.png", id);
    cJSON_AddStringToObject(root, "image_url", url);
    cJSON_AddBoolToObject(root, "reference_cached", o->reference_cached);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return rd_reply_json(r, 200, text);
}

enum MHD_Result rd_route_grade(rd_req *r)
{
    rd_server *srv = r->srv;
    rd_grade_req *g = r->grade;
    if (!g)
        return rd_reply_error(r, 400, "parse_error", NULL, "no form");
    if (atomic_load(&srv->draining))
        return rd_reply_error_hdr(r, 503, "draining", "the server is shutting down", "Retry-After", "5");
    if (!g->image || !g->image_len)
        return rd_reply_error(r, 400, "parse_error", NULL, "the form has no 'image' file");
    if (!g->assignment[0] == !g->scene)
        return rd_reply_error(r, 400, "parse_error", NULL, "give exactly one of 'assignment' or 'scene'");
    rd_grade_output *o = &g->out;
    memset(o, 0, sizeof *o);
    o->thresholds = rd_grade_thresholds_default();
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    rd_error_code rc;
    char *dir;
    if (g->assignment[0]) {
        rd_assignment a;
        rc = rd_assignment_load(srv->opt.assignments_dir, g->assignment, &a, &err);
        if (rc) {
            rd_scene_free(&s);
            return rd_reply_error(r, 404, "not_found", &err, NULL);
        }
        snprintf(o->assignment, sizeof o->assignment, "%s", a.name);
        snprintf(o->title, sizeof o->title, "%s", a.title);
        o->thresholds = a.thresholds;
        rc = rd_scene_load_file(a.scene_path, &srv->opt.limits, &s, &err);
        dir = rd_dirname(a.scene_path);
    } else {
        rc = rd_scene_parse(g->scene, g->scene_len, RD_FMT_AUTO, "<upload>", &srv->opt.limits, &s, &err);
        dir = strdup(srv->opt.scenes_dir);
    }
    if (!rc)
        rc = rd_scene_check_limits(&s, &srv->opt.limits, "<upload>", &err);
    if (!rc) {
        rd_asset_source src = rd_asset_folder(dir ? dir : ".");
        rc = rd_scene_load_assets(&s, &src, &srv->opt.limits, NULL, &err);
    }
    free(dir);
    if (rc) {
        rd_scene_free(&s);
        return rd_reply_error(r, rd_status_for(rc), rd_code_for(rc), &err, NULL);
    }
    if (!rd_png_sniff((unsigned char *)g->image, g->image_len)) {
        rd_scene_free(&s);
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, "the image is not a PNG file");
    }
    int iw, ih;
    rc = rd_grade_load_png((unsigned char *)g->image, g->image_len, srv->opt.limits.max_pixels, &o->image, &iw, &ih,
                           &err);
    if (rc) {
        rd_scene_free(&s);
        return rc == RD_ERR_LIMIT ? rd_reply_error(r, 413, "too_large", &err, NULL)
                                  : rd_reply_error(r, 422, "bad_image", &err, NULL);
    }
    if (iw != s.render.width || ih != s.render.height) {
        char msg[200];
        snprintf(msg, sizeof msg, "the image is %dx%d; the %s renders %dx%d", iw, ih,
                 g->assignment[0] ? "assignment" : "scene", s.render.width, s.render.height);
        rd_scene_free(&s);
        return rd_reply_error(r, 422, "size_mismatch", NULL, msg);
    }
    o->width = iw;
    o->height = ih;
    if (rd_reference_key(&s, g->refkey, &err)) {
        rd_scene_free(&s);
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    }
    o->reference = ref_lookup(srv->grades, g->refkey, iw, ih);
    if (!o->reference && srv->opt.cache_dir) {
        char path[1100];
        char *data;
        size_t len;
        int cw, chh;
        snprintf(path, sizeof path, "%s/%s.png", srv->opt.cache_dir, g->refkey);
        if (rd_read_file(path, 1u << 30, "(cache)", &data, &len, &err) == RD_OK) {
            if (rd_grade_load_png((unsigned char *)data, len, (size_t)1 << 28, &o->reference, &cw, &chh, &err) ||
                cw != iw || chh != ih) {
                free(o->reference);
                o->reference = NULL;
            }
            free(data);
        }
    }
    if (o->reference) {
        o->reference_cached = 1;
        rd_scene_free(&s);
        return answer(r);
    }
    /* Render the reference as an ordinary job; answer when it is done. */
    rd_jq_job *job;
    rc = rd_jq_submit(srv->jobs, &s, NULL, rd_req_socket(r), rd_req_on_done, r, &job, &err);
    if (rc == RD_ERR_LIMIT)
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
    rd_server *srv = r->srv;
    rd_grade_req *g = r->grade;
    rd_jq_info info;
    rd_jq_info_get(srv->jobs, r->job, &info);
    if (info.status != RD_JOB_DONE)
        return rd_reply_error(r, info.status == RD_JOB_FAILED ? 422 : 503,
                              info.status == RD_JOB_FAILED ? "render_failed" : "cancelled",
                              info.status == RD_JOB_FAILED ? &info.error : NULL, "the reference render was cancelled");
    unsigned char *png;
    size_t len;
    rd_error err = {0};
    if (rd_jq_png(srv->jobs, r->job, 0, &png, &len, &err))
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    rd_jq_release_png(srv->jobs, r->job);
    int w, h;
    rd_error_code rc = rd_grade_load_png(png, len, (size_t)1 << 28, &g->out.reference, &w, &h, &err);
    if (!rc && srv->opt.cache_dir) {
        char path[1100];
        snprintf(path, sizeof path, "%s/%s.png", srv->opt.cache_dir, g->refkey);
        rd_error ignore;
        rd_write_file(path, png, len, &ignore);
    }
    free(png);
    if (rc)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    ref_store(srv->grades, g->refkey, g->out.reference, w, h);
    return answer(r);
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
