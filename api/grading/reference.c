#include "reference.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "grade.h"
#include "png_write.h"
#include "rayd/render.h"
#include "scene_load.h"
#include "scene_write.h"
#include "file_io.h"

#ifndef RD_CORE_HASH
#define RD_CORE_HASH "unversioned"
#endif

const char *rd_renderer_id(void) { return "rayd-core-" RD_CORE_HASH; }

/* FNV-1a, 64 bits: a cache key, not a defence against forgery. */
static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ULL;
    }
    return h;
}

rd_error_code rd_reference_key(const rd_scene *s, char key[17], rd_error *err)
{
    char *text;
    rd_error_code rc = rd_scene_write_cfg(s, &text, err);
    if (rc)
        return rc;
    uint64_t h = 0xcbf29ce484222325ULL;
    h = fnv(h, rd_renderer_id(), strlen(rd_renderer_id()));
    h = fnv(h, text, strlen(text));
    free(text);
    for (size_t i = 0; i < s->mesh_count; i++) {
        const rd_mesh *m = &s->meshes[i];
        h = fnv(h, m->positions, m->npositions * sizeof *m->positions);
        h = fnv(h, m->normals, m->nnormals * sizeof *m->normals);
        h = fnv(h, m->uvs, m->nuvs * sizeof *m->uvs);
        h = fnv(h, m->faces, m->nfaces * sizeof *m->faces);
    }
    for (size_t i = 0; i < s->texture_count; i++) {
        const rd_texture *t = &s->textures[i];
        h = fnv(h, &t->width, sizeof t->width);
        h = fnv(h, &t->height, sizeof t->height);
        h = fnv(h, t->rgb, (size_t)t->width * (size_t)t->height * 3 * sizeof(float));
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

rd_error_code rd_reference_get(const rd_scene *s, const char *cache_dir, int threads, uint8_t **rgb, int *w, int *h,
                               int *from_cache, rd_error *err)
{
    *rgb = NULL;
    *from_cache = 0;
    char key[17], path[1100];
    rd_error_code rc = rd_reference_key(s, key, err);
    if (rc)
        return rc;
    if (cache_dir) {
        snprintf(path, sizeof path, "%s/%s.png", cache_dir, key);
        char *data;
        size_t len;
        rd_error ignore;
        if (rd_read_file(path, 1u << 30, "(cache)", &data, &len, &ignore) == RD_OK) {
            int cw, ch;
            rc = rd_grade_load_png((unsigned char *)data, len, (size_t)1 << 28, rgb, &cw, &ch, &ignore);
            free(data);
            if (rc == RD_OK && cw == s->render.width && ch == s->render.height) {
                *w = cw;
                *h = ch;
                *from_cache = 1;
                return RD_OK;
            }
            free(*rgb);
            *rgb = NULL;
        }
    }
    rd_render_options ro = {0};
    ro.threads = threads;
    rd_image img;
    rd_render_stats st;
    rc = rd_render(s, &ro, &img, &st, err);
    if (rc)
        return rc;
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    uint8_t *out = malloc(n);
    if (!out) {
        rd_image_free(&img);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    rd_image_to_rgb8(&img, s->render.gamma, out);
    *w = img.width;
    *h = img.height;
    rd_image_free(&img);
    if (cache_dir) {
        /* A failure to cache only costs a render next time. */
        unsigned char *png;
        size_t len;
        rd_error ignore;
        rd_png_options po = {6, RD_PNG_FILTER_ALL};
        mkdirs(cache_dir);
        if (rd_png_encode(out, *w, *h, &po, &png, &len, &ignore) == RD_OK) {
            rd_write_file(path, png, len, &ignore);
            free(png);
        }
    }
    *rgb = out;
    return RD_OK;
}
