#include "code_image.h"

#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"
#include "rayd/render.h"

typedef struct {
    rd_code_query *q;
    size_t n, cap, max;
    int over;
    /* replaying */
    const rd_frame_value *values;
    size_t next, mismatched;
} calls;

static void put3(double d[3], rd_vec3 v)
{
    d[0] = v.x;
    d[1] = v.y;
    d[2] = v.z;
}

rayd_code_material rd_code_material_of(const rd_material *m)
{
    rayd_code_material c;
    put3(c.kd, m->kd);
    put3(c.ks, m->ks);
    put3(c.ambient, m->ambient);
    c.shininess = m->shininess;
    c.roughness = m->roughness;
    return c;
}

static rd_code_query query_of(const rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L, rd_vec3 V)
{
    rd_code_query q;
    memset(&q, 0, sizeof q); /* padding too: queries are compared bytewise */
    q.m = rd_code_material_of(m);
    put3(q.h.normal, n);
    put3(q.h.position, p);
    q.h.t = t;
    put3(q.incoming, L);
    put3(q.outgoing, V);
    return q;
}

static rd_rgb record(void *user, const rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L, rd_vec3 V)
{
    calls *c = user;
    if (c->over || c->n >= c->max) {
        c->over = 1;
        return v3(0, 0, 0);
    }
    if (!rd_grow_array((void **)&c->q, &c->cap, c->n + 1, sizeof *c->q, 4096)) {
        c->over = 2;
        return v3(0, 0, 0);
    }
    c->q[c->n++] = query_of(m, n, p, t, L, V);
    return v3(0, 0, 0);
}

static rd_rgb replay(void *user, const rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L, rd_vec3 V)
{
    calls *c = user;
    size_t i = c->next++;
    rd_code_query q = query_of(m, n, p, t, L, V);
    if (i >= c->n || memcmp(&q, &c->q[i], sizeof q) != 0) {
        c->mismatched++;
        return v3(0, 0, 0);
    }
    const rd_frame_value *v = &c->values[i];
    /* NaN, infinite and negative channels become 0 in the material (material.c) */
    return v->status == RD_VALUE_RETURNED ? v3(v->rgb[0], v->rgb[1], v->rgb[2]) : v3(0, 0, 0);
}

/* Renders s with reflect in place for type t's materials, then puts them back. */
static rd_error_code render_with(rd_scene *s, rd_material_type t, rd_reflect_fn fn, calls *c, rd_image *img,
                                 rd_error *err)
{
    for (size_t i = 0; i < s->material_count; i++)
        if (s->materials[i].type == t) {
            s->materials[i].reflect = fn;
            s->materials[i].reflect_user = c;
        }
    rd_render_options ro = {0};
    ro.threads = 1;
    rd_render_stats st;
    rd_error_code rc = rd_render(s, &ro, img, &st, err);
    for (size_t i = 0; i < s->material_count; i++) {
        s->materials[i].reflect = NULL;
        s->materials[i].reflect_user = NULL;
    }
    return rc;
}

rd_error_code rd_code_record(rd_scene *s, rd_material_type t, size_t max, rd_code_query **q, size_t *n, size_t *cap,
                             rd_error *err)
{
    calls c = {*q, *n, *cap, max, 0, NULL, 0, 0};
    rd_image img;
    rd_error_code rc = render_with(s, t, record, &c, &img, err);
    if (!rc)
        rd_image_free(&img);
    *q = c.q;
    *n = c.n;
    *cap = c.cap;
    if (!rc && c.over == 2)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory recording the image's shading calls");
    if (!rc && c.over)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0,
                            "the assignment's image takes more than %zu shading calls: too many to grade code with",
                            max);
    return rc;
}

rd_error_code rd_code_replay(rd_scene *s, rd_material_type t, const rd_code_query *q, const rd_frame_value *values,
                             size_t n, uint8_t **rgb, int *w, int *h, size_t *mismatched, rd_error *err)
{
    calls c = {(rd_code_query *)q, n, n, n, 0, values, 0, 0};
    rd_image img;
    rd_error_code rc = render_with(s, t, replay, &c, &img, err);
    if (rc)
        return rc;
    *mismatched = c.mismatched + (c.next < n ? n - c.next : 0);
    *rgb = malloc((size_t)img.width * (size_t)img.height * 3);
    if (!*rgb) {
        rd_image_free(&img);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    rd_image_to_rgb8(&img, s->render.gamma, *rgb);
    *w = img.width;
    *h = img.height;
    rd_image_free(&img);
    return RD_OK;
}
