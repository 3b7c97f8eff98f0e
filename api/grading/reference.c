#include "reference.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "file_io.h"
#include "grade.h"
#include "hash.h"
#include "png_read.h"
#include "png_write.h"
#include "scene_write.h"

#ifndef RD_CORE_HASH
#define RD_CORE_HASH "unversioned"
#endif

const char *rd_renderer_id(void) { return "rayd-core-" RD_CORE_HASH; }

rd_error_code rd_reference_key(const rd_scene *s, char key[17], rd_error *err)
{
    char *text;
    rd_error_code rc = rd_scene_write_cfg(s, &text, err);
    if (rc)
        return rc;
    uint64_t h = RD_FNV_OFFSET;
    h = rd_fnv1a(h, rd_renderer_id(), strlen(rd_renderer_id()));
    h = rd_fnv1a(h, text, strlen(text));
    free(text);
    for (size_t i = 0; i < s->mesh_count; i++) {
        const rd_mesh *m = &s->meshes[i];
        h = rd_fnv1a(h, m->positions, m->npositions * sizeof *m->positions);
        h = rd_fnv1a(h, m->normals, m->nnormals * sizeof *m->normals);
        h = rd_fnv1a(h, m->uvs, m->nuvs * sizeof *m->uvs);
        h = rd_fnv1a(h, m->faces, m->nfaces * sizeof *m->faces);
    }
    for (size_t i = 0; i < s->texture_count; i++) {
        const rd_texture *t = &s->textures[i];
        h = rd_fnv1a(h, &t->width, sizeof t->width);
        h = rd_fnv1a(h, &t->height, sizeof t->height);
        h = rd_fnv1a(h, t->rgb, (size_t)t->width * (size_t)t->height * 3 * sizeof(float));
    }
    snprintf(key, 17, "%016llx", (unsigned long long)h);
    return RD_OK;
}

static void mkdirs(const char *dir)
{
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", dir);
    for (char *p = buf + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            mkdir(buf, 0755);
            *p = '/';
        }
    mkdir(buf, 0755);
}

enum { REF_SLOTS = 32 };

typedef struct {
    char key[17];
    uint8_t *rgb; /* NULL: a free slot */
    int w, h;
    uint64_t used; /* the cache's use counter at the last get or put */
} ref_slot;

struct rd_ref_cache {
    pthread_mutex_t mu;
    ref_slot slots[REF_SLOTS];
    uint64_t uses;
    size_t bytes, max_bytes;
    const char *dir;
    void (*on_bytes)(void *user, long long delta);
    void *user;
};

static size_t rgb_bytes(int w, int h) { return (size_t)w * (size_t)h * 3; }

rd_ref_cache *rd_ref_cache_new(size_t max_bytes, const char *dir, void (*on_bytes)(void *, long long), void *user)
{
    rd_ref_cache *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    pthread_mutex_init(&c->mu, NULL);
    c->max_bytes = max_bytes;
    c->dir = dir;
    c->on_bytes = on_bytes;
    c->user = user;
    return c;
}

static void count(rd_ref_cache *c, long long delta)
{
    c->bytes += (size_t)delta;
    if (c->on_bytes)
        c->on_bytes(c->user, delta);
}

static void drop(rd_ref_cache *c, ref_slot *e)
{
    if (!e->rgb)
        return;
    count(c, -(long long)rgb_bytes(e->w, e->h));
    free(e->rgb);
    e->rgb = NULL;
}

void rd_ref_cache_free(rd_ref_cache *c)
{
    if (!c)
        return;
    /* Whoever listened to on_bytes may be gone already. */
    for (int i = 0; i < REF_SLOTS; i++)
        free(c->slots[i].rgb);
    pthread_mutex_destroy(&c->mu);
    free(c);
}

/* Drops the least recently used until the memory fits. Under c->mu. */
static void trim(rd_ref_cache *c)
{
    while (c->bytes > c->max_bytes) {
        ref_slot *lru = NULL;
        for (int i = 0; i < REF_SLOTS; i++)
            if (c->slots[i].rgb && (!lru || c->slots[i].used < lru->used))
                lru = &c->slots[i];
        if (!lru)
            return;
        drop(c, lru);
    }
}

/* Takes rgb over (the caller's copy) into memory. Under c->mu. */
static void keep(rd_ref_cache *c, const char *key, uint8_t *rgb, int w, int h)
{
    if (rgb_bytes(w, h) > c->max_bytes) {
        free(rgb);
        return;
    }
    ref_slot *slot = &c->slots[0];
    for (int i = 0; i < REF_SLOTS; i++) {
        if (c->slots[i].rgb && strcmp(c->slots[i].key, key) == 0) {
            slot = &c->slots[i];
            break;
        }
        if (!c->slots[i].rgb || (slot->rgb && c->slots[i].used < slot->used))
            slot = &c->slots[i];
    }
    drop(c, slot);
    snprintf(slot->key, sizeof slot->key, "%s", key);
    slot->rgb = rgb;
    slot->w = w;
    slot->h = h;
    slot->used = ++c->uses;
    count(c, (long long)rgb_bytes(w, h));
    trim(c);
}

static uint8_t *copy_of(const uint8_t *rgb, size_t n)
{
    uint8_t *p = malloc(n);
    if (p)
        memcpy(p, rgb, n);
    return p;
}

/* dir/KEY.png decoded, if it is a w x h PNG. */
static uint8_t *read_disk(const rd_ref_cache *c, const char *key, int w, int h)
{
    char path[1100];
    if (!c->dir || (size_t)snprintf(path, sizeof path, "%s/%s.png", c->dir, key) >= sizeof path)
        return NULL;
    size_t most = rd_png_file_bound(w, h);
    char *data;
    size_t len;
    rd_error ignore;
    if (rd_read_file(path, most, "(the reference cache)", &data, &len, &ignore) != RD_OK)
        return NULL;
    uint8_t *rgb = NULL;
    int cw, ch;
    if (rd_grade_load_png((unsigned char *)data, len, (size_t)w * (size_t)h, &rgb, &cw, &ch, &ignore) != RD_OK ||
        cw != w || ch != h) {
        free(rgb);
        rgb = NULL;
    }
    free(data);
    return rgb;
}

uint8_t *rd_ref_cache_get(rd_ref_cache *c, const char *key, int w, int h)
{
    uint8_t *out = NULL;
    pthread_mutex_lock(&c->mu);
    for (int i = 0; i < REF_SLOTS; i++) {
        ref_slot *e = &c->slots[i];
        if (e->rgb && strcmp(e->key, key) == 0 && e->w == w && e->h == h) {
            out = copy_of(e->rgb, rgb_bytes(w, h));
            e->used = ++c->uses;
            break;
        }
    }
    pthread_mutex_unlock(&c->mu);
    if (out)
        return out;
    out = read_disk(c, key, w, h);
    if (out) {
        uint8_t *kept = copy_of(out, rgb_bytes(w, h));
        pthread_mutex_lock(&c->mu);
        if (kept)
            keep(c, key, kept, w, h);
        pthread_mutex_unlock(&c->mu);
    }
    return out;
}

void rd_ref_cache_put(rd_ref_cache *c, const char *key, const uint8_t *rgb, int w, int h)
{
    uint8_t *kept = copy_of(rgb, rgb_bytes(w, h));
    pthread_mutex_lock(&c->mu);
    if (kept)
        keep(c, key, kept, w, h);
    pthread_mutex_unlock(&c->mu);
    char path[1100];
    if (!c->dir || (size_t)snprintf(path, sizeof path, "%s/%s.png", c->dir, key) >= sizeof path)
        return;
    unsigned char *png;
    size_t len;
    rd_error ignore;
    rd_png_options po = {6, RD_PNG_FILTER_ALL};
    mkdirs(c->dir);
    if (rd_png_encode(rgb, w, h, &po, &png, &len, &ignore) == RD_OK) {
        rd_write_file(path, png, len, &ignore);
        free(png);
    }
}

void rd_ref_cache_set_max_bytes(rd_ref_cache *c, size_t max_bytes)
{
    pthread_mutex_lock(&c->mu);
    c->max_bytes = max_bytes;
    trim(c);
    pthread_mutex_unlock(&c->mu);
}

size_t rd_ref_cache_bytes(rd_ref_cache *c)
{
    pthread_mutex_lock(&c->mu);
    size_t n = c->bytes;
    pthread_mutex_unlock(&c->mu);
    return n;
}
