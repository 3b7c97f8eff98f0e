/* The numerical-stability cases (cases.h). Each case loads its scenes with
 * load_scene (tests/support/load.h: rd_scene_load_file, then
 * rd_scene_load_assets from the scene's folder), transforms them in code where
 * the case is parametric, renders with rd_render, and measures.
 *
 * Reference values come from a small long-double tracer (lref_*, below):
 * the camera rays of shading.md, spheres, planes and triangles, point and
 * directional lights with shadows, and the diffuse, Phong, Blinn-Phong,
 * Cook-Torrance and pseudo-normal materials, all in 64-bit-mantissa long
 * double from the scene's double inputs. A pixel whose centre ray (or one
 * of its shadow rays) passes within a band of a decision boundary
 * (silhouette, triangle edge, shadow edge, terminator) is a "boundary
 * pixel": the band is what double-precision inputs and rays can resolve,
 * 64·ε·(coordinate magnitudes) with ε = 2^-52, so those pixels may go either
 * way and are counted, not compared. Every other pixel must match the
 * reference within 1 level of 255 per channel. */
#define _GNU_SOURCE
#include "cases.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "asset_source.h"
#include "file_io.h"
#include "fresnel.h"
#include "light.h"
#include "material.h"
#include "rayd/render.h"
#include "rayd/scene.h"
#include "scene_assets.h"
#include "scene_limits.h"
#include "scene_load.h"
#include "support/load.h"
#include "support/rng.h"

const char *rd_stability_scene_dir = "scenes/extreme";
int rd_stability_threads = 1;

/* ---- results ---------------------------------------------------------------- */

static void note(rd_case_result *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void note(rd_case_result *r, const char *fmt, ...)
{
    size_t n = strlen(r->detail);
    if (n + 1 >= sizeof r->detail)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->detail + n, sizeof r->detail - n, fmt, ap);
    va_end(ap);
}

static void worst(rd_case_result *r, double v)
{
    if (!(v <= r->worst))
        r->worst = v;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* ---- scenes and renders --------------------------------------------------- */

static int load(rd_case_result *r, const char *name, rd_scene *s)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", rd_stability_scene_dir, name);
    rd_error err = {0};
    rd_warnings w = {0};
    if (load_scene(path, s, &w, &err) != RD_OK) {
        r->error = 1;
        note(r, "load %s: %s. ", path, err.message);
        return 0;
    }
    return 1;
}

typedef struct {
    rd_image img;
    rd_render_stats st;
    uint8_t *rgb8;
    int w, h;
} shot;

static void shot_free(shot *o)
{
    rd_image_free(&o->img);
    free(o->rgb8);
    memset(o, 0, sizeof *o);
}

/* Renders s; counts non-finite values and samples into r. */
static int shoot(rd_case_result *r, const rd_scene *s, shot *o)
{
    memset(o, 0, sizeof *o);
    rd_render_options opt = {0};
    opt.threads = rd_stability_threads;
    rd_error err = {0};
    if (rd_render(s, &opt, &o->img, &o->st, &err) != RD_OK) {
        r->error = 1;
        note(r, "rd_render: %s. ", err.message);
        return 0;
    }
    r->renders++;
    r->nonfinite += o->st.nonfinite;
    o->w = o->img.width;
    o->h = o->img.height;
    size_t n = (size_t)o->w * (size_t)o->h * 3;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(o->img.rgb[i]))
            r->bad_values++;
    o->rgb8 = malloc(n ? n : 1);
    if (!o->rgb8) {
        r->error = 1;
        note(r, "out of memory. ");
        rd_image_free(&o->img);
        return 0;
    }
    rd_image_to_rgb8(&o->img, s->render.gamma, o->rgb8);
    return 1;
}

static size_t diff_bytes(const shot *a, const shot *b)
{
    size_t n = (size_t)a->w * (size_t)a->h * 3, d = 0;
    if (a->w != b->w || a->h != b->h)
        return n ? n : 1;
    for (size_t i = 0; i < n; i++)
        d += a->rgb8[i] != b->rgb8[i];
    return d;
}

/* Pixels that differ in any channel; *maxlev gets the largest difference. */
static size_t diff_pixels(const shot *a, const shot *b, int *maxlev)
{
    size_t n = (size_t)a->w * (size_t)a->h, d = 0;
    int m = 0;
    for (size_t i = 0; i < n; i++) {
        int any = 0;
        for (int c = 0; c < 3; c++) {
            int k = abs((int)a->rgb8[3 * i + c] - (int)b->rgb8[3 * i + c]);
            if (k)
                any = 1;
            if (k > m)
                m = k;
        }
        d += any;
    }
    if (maxlev)
        *maxlev = m;
    return d;
}

static const uint8_t *px(const shot *o, int x, int y) { return o->rgb8 + 3 * ((size_t)y * o->w + x); }

static uint8_t to8(double c, double gamma) { return (uint8_t)floor(rd_display(c, gamma) * 255.0 + 0.5); }

static int is_rgb(const uint8_t *p, rd_rgb c, double gamma)
{
    return p[0] == to8(c.x, gamma) && p[1] == to8(c.y, gamma) && p[2] == to8(c.z, gamma);
}

/* Every position p becomes p·f + t; lengths (radii, area-light edges)
 * scale by f; directions and normals are unchanged. With the eye at the
 * origin and t = 0 this scales the scene about the eye. */
static void xform(rd_scene *s, double f, rd_vec3 t)
{
#define XP(p) (p) = v3_add(v3_scale((p), f), t)
    XP(s->camera.eye);
    XP(s->camera.target);
    for (size_t i = 0; i < s->light_count; i++) {
        rd_light *l = &s->lights[i];
        XP(l->position);
        XP(l->corner);
        l->edge1 = v3_scale(l->edge1, f);
        l->edge2 = v3_scale(l->edge2, f);
    }
    for (size_t i = 0; i < s->object_count; i++) {
        rd_object *o = &s->objects[i];
        XP(o->center);
        o->radius *= f;
        XP(o->point);
        for (int k = 0; k < 3; k++)
            XP(o->v[k]);
    }
    for (size_t i = 0; i < s->mesh_count; i++)
        for (size_t k = 0; k < s->meshes[i].npositions; k++)
            XP(s->meshes[i].positions[k]);
#undef XP
}

/* Drops object i (its strings freed). */
static void drop_object(rd_scene *s, size_t i)
{
    rd_object *o = &s->objects[i];
    free(o->material_name);
    free(o->file);
    free(o->name);
    free(o->where);
    memmove(o, o + 1, (s->object_count - i - 1) * sizeof *o);
    s->object_count--;
}

/* Appends a copy of object i (strings not shared). */
static int dup_object(rd_scene *s, size_t i)
{
    rd_object *n = rd_scene_add_object(s);
    if (!n)
        return 0;
    *n = s->objects[i];
    n->name = n->material_name = n->file = n->where = NULL;
    return 1;
}

/* ---- long-double reference -------------------------------------------------- */

typedef long double ld;
typedef struct {
    ld x, y, z;
} lv;

static lv lv3(ld x, ld y, ld z)
{
    lv r = {x, y, z};
    return r;
}
static lv lvd(rd_vec3 v) { return lv3(v.x, v.y, v.z); }
static lv ladd(lv a, lv b) { return lv3(a.x + b.x, a.y + b.y, a.z + b.z); }
static lv lsub(lv a, lv b) { return lv3(a.x - b.x, a.y - b.y, a.z - b.z); }
static lv lmul(lv a, ld s) { return lv3(a.x * s, a.y * s, a.z * s); }
static ld ldot(lv a, lv b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static lv lcross(lv a, lv b) { return lv3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static ld llen(lv a) { return sqrtl(ldot(a, a)); }
static lv lunit(lv a)
{
    ld n = llen(a);
    return n > 0 ? lmul(a, 1 / n) : lv3(0, 0, 0);
}
static ld lmaxabs(lv a) { return fmaxl(fabsl(a.x), fmaxl(fabsl(a.y), fabsl(a.z))); }

#define EPS ((ld)DBL_EPSILON)
/* The band: what double inputs and double rays can resolve. */
#define BAND 64

typedef struct {
    lv v[3];
    lv n[3];
    int has_n;
    int mat;
    int obj;
    int degenerate; /* the renderer's rule: an exactly zero double cross product */
} ltri;

typedef struct {
    const rd_scene *s;
    lv eye; /* world position; everything below is relative to it */
    lv u, v, w;
    ld h, aspect;
    int W, H;
    ltri *tri;
    size_t ntri;
    int unsupported; /* a material or light the reference does not model */
} lref;

typedef struct {
    int obj; /* scene object index, -1 for none */
    ld t;
    lv p, ng, n; /* n: shading normal facing the ray */
    int mat;
    int tri; /* index into lref.tri, or -1 */
} lhit;

static void lref_free(lref *R) { free(R->tri); }

static int lref_make(lref *R, const rd_scene *s)
{
    memset(R, 0, sizeof *R);
    R->s = s;
    R->eye = lvd(s->camera.eye);
    lv view = lsub(R->eye, lvd(s->camera.target));
    R->w = lunit(view);
    R->u = lunit(lcross(lunit(lvd(s->camera.up)), R->w));
    R->v = lcross(R->w, R->u);
    R->h = tanl((ld)s->camera.fov_deg * 3.14159265358979323846264338327950288L / 360);
    R->W = s->render.width;
    R->H = s->render.height;
    R->aspect = (ld)R->W / (ld)R->H;
    size_t nt = 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->type == RD_OBJ_TRIANGLE)
            nt++;
        else if (o->type == RD_OBJ_MESH)
            nt += s->meshes[o->mesh].nfaces;
    }
    R->tri = calloc(nt + 1, sizeof *R->tri);
    if (!R->tri)
        return 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->type == RD_OBJ_TRIANGLE) {
            ltri *t = &R->tri[R->ntri++];
            for (int k = 0; k < 3; k++) {
                t->v[k] = lsub(lvd(o->v[k]), R->eye);
                t->n[k] = lvd(o->n[k]);
            }
            t->has_n = o->has_normals;
            t->mat = o->material;
            t->obj = (int)i;
            rd_vec3 a = v3_sub(o->v[1], o->v[0]), b = v3_sub(o->v[2], o->v[0]);
            rd_vec3 c = v3_cross(a, b);
            t->degenerate = c.x == 0 && c.y == 0 && c.z == 0;
        } else if (o->type == RD_OBJ_MESH) {
            const rd_mesh *m = &s->meshes[o->mesh];
            for (size_t f = 0; f < m->nfaces; f++) {
                ltri *t = &R->tri[R->ntri++];
                const rd_mesh_face *fc = &m->faces[f];
                rd_vec3 p[3];
                for (int k = 0; k < 3; k++) {
                    p[k] = m->positions[fc->v[k]];
                    t->v[k] = lsub(lvd(p[k]), R->eye);
                }
                t->has_n = fc->n[0] >= 0 && fc->n[1] >= 0 && fc->n[2] >= 0;
                if (t->has_n)
                    for (int k = 0; k < 3; k++)
                        t->n[k] = lunit(lvd(m->normals[fc->n[k]]));
                t->mat = o->material;
                t->obj = (int)i;
                rd_vec3 c = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
                t->degenerate = c.x == 0 && c.y == 0 && c.z == 0;
            }
        }
    }
    return 1;
}

/* Direction of the centre ray of pixel (x, y) (unit). */
static lv lref_dir(const lref *R, ld x, ld y)
{
    ld sx = (2 * x / R->W - 1) * R->aspect * R->h;
    ld sy = (1 - 2 * y / R->H) * R->h;
    return lunit(lsub(ladd(lmul(R->u, sx), lmul(R->v, sy)), R->w));
}

/* All hits of ray o + t·d (d need not be unit) with t in (0, tmax), the
 * closest kept in *h; *amb_t gets the smallest t at which a boundary of
 * some surface passes within the band of the ray. A surface through the
 * ray's origin is not hit there (shading.md: no self-intersection). */
static int lref_closest(const lref *R, lv o, lv d, ld tmax, lhit *h, ld *amb_t)
{
    const rd_scene *s = R->s;
    ld best = tmax;
    int found = 0;
    ld dd = ldot(d, d), dl = sqrtl(dd);
    *amb_t = INFINITY;
    h->obj = -1;
    h->tri = -1;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *ob = &s->objects[i];
        if (ob->type == RD_OBJ_SPHERE) {
            lv c = lsub(lvd(ob->center), R->eye);
            ld r = ob->radius;
            lv f = lsub(o, c);
            ld b = ldot(f, d) / dd;
            lv l = lsub(f, lmul(d, b));
            ld dist = llen(l);
            ld band = BAND * EPS * (llen(c) + llen(o) + r);
            ld tc = -b;
            if (fabsl(dist - r) <= band && tc > 0 && tc < *amb_t)
                *amb_t = tc;
            if (dist >= r)
                continue;
            ld th = sqrtl((r - dist) * (r + dist) / dd);
            ld t0 = tc - th, t1 = tc + th;
            /* a root within the band of the origin is the origin's own surface */
            ld tz = band / dl;
            ld t = t0 > tz ? t0 : (t1 > tz ? t1 : -1);
            if (t > 0 && t < best) {
                best = t;
                found = 1;
                h->obj = (int)i;
                h->tri = -1;
                h->t = t;
                h->mat = ob->material;
            }
        } else if (ob->type == RD_OBJ_PLANE) {
            lv n = lunit(lvd(ob->normal));
            lv q = lsub(lvd(ob->point), R->eye);
            ld dn = ldot(d, n);
            if (dn == 0)
                continue;
            ld num = ldot(lsub(q, o), n);
            ld band = BAND * EPS * (llen(q) + llen(o));
            if (fabsl(num) <= band)
                continue; /* the origin lies on the plane */
            ld t = num / dn;
            if (t > 0 && t < best) {
                best = t;
                found = 1;
                h->obj = (int)i;
                h->tri = -1;
                h->t = t;
                h->mat = ob->material;
            }
        }
    }
    /* Triangles hit near an edge: ambiguous unless a coplanar neighbour of
     * the same material, without vertex normals, meets the ray at the same
     * t, so that either side gives the same colour (a watertight test must
     * hit one of them). */
    enum { NEAR_MAX = 16 };
    struct {
        ld t;
        lv n;
        int mat, has_n;
    } nearby[NEAR_MAX];
    int nnear = 0, near_overflow = 0;
    for (size_t k = 0; k < R->ntri; k++) {
        const ltri *tr = &R->tri[k];
        if (tr->degenerate)
            continue;
        lv e1 = lsub(tr->v[1], tr->v[0]), e2 = lsub(tr->v[2], tr->v[0]);
        lv ng = lcross(e1, e2);
        ld area2 = llen(ng);
        if (!(area2 > 0))
            continue;
        ld dn = ldot(d, ng);
        if (dn == 0)
            continue;
        ld band = BAND * EPS * (fmaxl(lmaxabs(tr->v[0]), fmaxl(lmaxabs(tr->v[1]), lmaxabs(tr->v[2]))) + llen(o));
        ld num = ldot(lsub(tr->v[0], o), ng);
        if (fabsl(num) <= band * area2)
            continue; /* origin in the triangle's plane */
        ld t = num / dn;
        if (!(t > 0 && t < tmax))
            continue;
        lv p = ladd(o, lmul(d, t));
        /* signed distances from p to the three edge lines */
        ld bc[3], dmin = INFINITY;
        for (int e = 0; e < 3; e++) {
            lv a = tr->v[(e + 1) % 3], b = tr->v[(e + 2) % 3];
            lv ab = lsub(b, a);
            /* (ab × (p - a))·ng/|ng| is twice the signed area of (a, b, p):
             * divided by |ab| it is p's distance from the edge line, by
             * |ng| the barycentric weight of the opposite corner */
            ld sub = ldot(lcross(ab, lsub(p, a)), ng) / area2;
            ld len = llen(ab);
            ld dist = len > 0 ? sub / len : 0;
            bc[e] = sub / area2;
            if (fabsl(dist) < dmin)
                dmin = fabsl(dist);
        }
        int inside = bc[0] >= 0 && bc[1] >= 0 && bc[2] >= 0;
        if (dmin <= band) {
            if (nnear < NEAR_MAX) {
                nearby[nnear].t = t;
                nearby[nnear].n = lmul(ng, 1 / area2);
                nearby[nnear].mat = tr->mat;
                nearby[nnear].has_n = tr->has_n;
                nnear++;
            } else {
                near_overflow = 1;
            }
        }
        if (inside && t < best) {
            best = t;
            found = 1;
            h->obj = tr->obj;
            h->tri = (int)k;
            h->t = t;
            h->mat = tr->mat;
        }
    }
    for (int i = 0; i < nnear; i++) {
        const ld tt = nearby[i].t;
        int waived = 0;
        if (found && !near_overflow && fabsl(tt - best) <= 1e-9L * best && h->tri >= 0 && !nearby[i].has_n &&
            nearby[i].mat == h->mat) {
            /* the closest triangle must be coplanar with it, and some other
             * edge-near triangle must share the spot */
            const ltri *ct = &R->tri[h->tri];
            lv cn = lunit(lcross(lsub(ct->v[1], ct->v[0]), lsub(ct->v[2], ct->v[0])));
            int others = 0;
            for (int j = 0; j < nnear; j++)
                if (j != i && fabsl(nearby[j].t - tt) <= 1e-9L * best && nearby[j].mat == h->mat &&
                    fabsl(fabsl(ldot(nearby[j].n, cn)) - 1) <= 1e-12L)
                    others++;
            waived = !ct->has_n && fabsl(fabsl(ldot(nearby[i].n, cn)) - 1) <= 1e-12L && others > 0;
        }
        if (!waived && tt < *amb_t)
            *amb_t = tt;
    }
    if (!found)
        return 0;
    h->p = ladd(o, lmul(d, h->t));
    const rd_object *ob = &s->objects[h->obj];
    if (h->tri >= 0) {
        const ltri *tr = &R->tri[h->tri];
        lv e1 = lsub(tr->v[1], tr->v[0]), e2 = lsub(tr->v[2], tr->v[0]);
        lv ng = lcross(e1, e2);
        ld a2 = ldot(ng, ng);
        h->ng = lunit(ng);
        h->n = h->ng;
        if (tr->has_n) {
            lv p = h->p;
            ld b0 = ldot(lcross(lsub(tr->v[2], tr->v[1]), lsub(p, tr->v[1])), ng) / a2;
            ld b1 = ldot(lcross(lsub(tr->v[0], tr->v[2]), lsub(p, tr->v[2])), ng) / a2;
            ld b2 = 1 - b0 - b1;
            lv n = ladd(ladd(lmul(tr->n[0], b0), lmul(tr->n[1], b1)), lmul(tr->n[2], b2));
            ld nl = llen(n);
            /* Cancelling normals: a near-zero sum is rounding noise in double */
            ld scale = llen(tr->n[0]) + llen(tr->n[1]) + llen(tr->n[2]);
            if (nl <= 1e-9L * scale) {
                if (h->t < *amb_t)
                    *amb_t = h->t;
            } else {
                h->n = lmul(n, 1 / nl);
            }
        }
    } else if (ob->type == RD_OBJ_SPHERE) {
        lv c = lsub(lvd(ob->center), R->eye);
        h->ng = lunit(lsub(h->p, c));
        h->n = h->ng;
    } else {
        h->ng = lunit(lvd(ob->normal));
        h->n = h->ng;
    }
    if (ldot(h->n, d) > 0)
        h->n = lmul(h->n, -1);
    return 1;
}

/* max(a·b, 0)^n for unit a, b, in long double, without cancellation. */
static ld lpow_cos(lv a, lv b, ld n)
{
    if (n == 0)
        return 1;
    if (!(ldot(a, b) > 0))
        return 0;
    lv d = lsub(a, b);
    ld x = ldot(d, d) / 2;
    if (x >= 1)
        return 0;
    return expl(n * log1pl(-x));
}

static ld lbeckmann(ld nh, ld m, lv N, lv H)
{
    if (!(nh > 0))
        return 0;
    lv d = lsub(N, H);
    ld x = ldot(d, d) / 2; /* 1 - nh, exactly for unit N, H */
    ld s2 = x * (2 - x);   /* 1 - nh² */
    ld nh2 = (1 - x) * (1 - x);
    return expl(-s2 / (nh2 * m * m)) / (3.14159265358979323846264338327950288L * m * m * nh2 * nh2);
}

/* calc_reflected_light of shading.md in long double (per unit light). */
static lv lbrdf(const rd_material *m, lv N, lv L, lv V, ld cmax, int *amb)
{
    ld cosa = -ldot(N, L);
    /* At the terminator (|cos α| within 1e-9) the sign of cos α decides,
     * and it matters only when what switches on is at least 1e-3: a
     * specular term, or a diffuse one under a very bright light. */
    int shiny = m->type != RD_MAT_DIFFUSE && (m->ks.x != 0 || m->ks.y != 0 || m->ks.z != 0);
    ld kdm = fmaxl(fabsl(m->kd.x), fmaxl(fabsl(m->kd.y), fabsl(m->kd.z)));
    ld ksm = fmaxl(fabsl(m->ks.x), fmaxl(fabsl(m->ks.y), fabsl(m->ks.z)));
    if (fabsl(cosa) <= 1e-9L &&
        cmax * (kdm * 1e-9L + (shiny ? ksm + 1e200L * (m->type == RD_MAT_COOK_TORRANCE) : 0)) > 1e-3L)
        *amb = 1;
    if (!(cosa > 0))
        return lv3(0, 0, 0);
    lv kd = lvd(m->kd), ks = lvd(m->ks);
    lv c = lmul(kd, cosa);
    switch (m->type) {
    case RD_MAT_DIFFUSE: return c;
    case RD_MAT_PHONG: {
        lv R = lsub(L, lmul(N, 2 * ldot(L, N)));
        return ladd(c, lmul(ks, lpow_cos(lunit(R), V, m->shininess)));
    }
    case RD_MAT_BLINN_PHONG: {
        lv H = lunit(lsub(V, L));
        return ladd(c, lmul(ks, lpow_cos(N, H, m->shininess)));
    }
    case RD_MAT_COOK_TORRANCE: {
        ld nv = ldot(N, V);
        if (fabsl(nv) <= 1e-9L)
            *amb = 1;
        if (!(nv > 0))
            return c;
        lv H = lunit(lsub(V, L));
        ld nh = ldot(N, H), vh = ldot(V, H);
        if (!(nh > 0) || !(vh > 0))
            return c;
        ld D = lbeckmann(nh, m->roughness, N, H);
        ld g_nv = fminl(1 / nv, fminl(2 * nh / vh, 2 * nh * cosa / (vh * nv)));
        ld sh = powl(1 - vh, 5);
        ld spec = fminl(D * g_nv / 4, 1e200L);
        lv F = lv3(ks.x + (1 - ks.x) * sh, ks.y + (1 - ks.y) * sh, ks.z + (1 - ks.z) * sh);
        return ladd(c, lmul(F, spec));
    }
    default: *amb = 2; return lv3(0, 0, 0);
    }
}

/* Radiance of the camera ray through pixel (x, y), direct lighting only.
 * *amb: 1 near a boundary, 2 unsupported. *obj gets the object hit. */
static lv lref_pixel(const lref *R, int x, int y, int *amb, int *obj)
{
    const rd_scene *s = R->s;
    lv o = lv3(0, 0, 0);
    lv d = lref_dir(R, x + 0.5L, y + 0.5L);
    lhit h;
    ld at;
    *amb = 0;
    int hit = lref_closest(R, o, d, INFINITY, &h, &at);
    *obj = hit ? h.obj : -1;
    if (at < (hit ? h.t * (1 + 1e-12L) : (ld)INFINITY))
        *amb = 1;
    if (!hit)
        return lvd(s->render.background);
    const rd_material *m = &s->materials[h.mat];
    if (m->type == RD_MAT_PSEUDO_NORMAL_COLOR)
        return lv3((h.n.x + 1) / 2, (h.n.y + 1) / 2, (h.n.z + 1) / 2);
    if (m->type == RD_MAT_PERFECT_SPECULAR || m->type == RD_MAT_SPECULAR_REFRACTION ||
        m->type == RD_MAT_TEXTURED_PHONG) {
        *amb = 2;
        return lv3(0, 0, 0);
    }
    lv V = lmul(d, -1);
    lv col = lvd(m->ambient);
    for (size_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        if (l->color.x == 0 && l->color.y == 0 && l->color.z == 0)
            continue;
        lv L, to;
        ld tend;
        if (l->type == RD_LIGHT_POINT) {
            to = lsub(lsub(lvd(l->position), R->eye), h.p);
            L = lunit(lmul(to, -1));
            /* a light on a surface: the segment's end is not an occluder */
            tend = 1 - 1e-9L;
        } else if (l->type == RD_LIGHT_DIRECTIONAL) {
            L = lunit(lvd(l->direction));
            to = lmul(L, -1);
            tend = INFINITY;
        } else {
            *amb = 2;
            continue;
        }
        int a2 = 0;
        ld cmax = fmaxl(fabsl((ld)l->color.x), fmaxl(fabsl((ld)l->color.y), fabsl((ld)l->color.z)));
        lv f = lbrdf(m, h.n, L, V, cmax, &a2);
        if (a2 > *amb)
            *amb = a2;
        if (f.x == 0 && f.y == 0 && f.z == 0)
            continue;
        lhit sh;
        ld sat;
        int blocked = lref_closest(R, h.p, to, tend, &sh, &sat);
        if (sat < (blocked ? sh.t : tend) || (l->type == RD_LIGHT_POINT && blocked && sh.t > 1 - 1e-6L))
            *amb = *amb ? *amb : 1;
        if (!blocked)
            col = ladd(col, lv3(l->color.x * f.x, l->color.y * f.y, l->color.z * f.z));
    }
    return col;
}

typedef struct {
    size_t mismatches, boundary, compared;
    int maxlev; /* largest difference among compared pixels */
    int first_x, first_y;
} lcmp;

/* Compares every pixel of o with the reference; |difference| <= tol levels. */
static void lref_compare(const lref *R, const shot *o, int tol, lcmp *c)
{
    memset(c, 0, sizeof *c);
    c->first_x = c->first_y = -1;
    double g = R->s->render.gamma;
    for (int y = 0; y < o->h; y++)
        for (int x = 0; x < o->w; x++) {
            int amb, obj;
            lv e = lref_pixel(R, x, y, &amb, &obj);
            if (amb) {
                c->boundary++;
                continue;
            }
            c->compared++;
            const uint8_t *p = px(o, x, y);
            ld ev[3] = {e.x, e.y, e.z};
            int bad = 0;
            for (int k = 0; k < 3; k++) {
                int want = to8((double)ev[k], g);
                int dl = abs(want - (int)p[k]);
                if (dl > c->maxlev)
                    c->maxlev = dl;
                if (dl > tol)
                    bad = 1;
            }
            if (bad) {
                if (c->mismatches == 0) {
                    c->first_x = x;
                    c->first_y = y;
                }
                c->mismatches++;
            }
        }
}

/* Coverage: whether each pixel differs from the background, against
 * whether its centre ray hits anything in long double. */
static void lref_coverage(const lref *R, const shot *o, lcmp *c)
{
    memset(c, 0, sizeof *c);
    c->first_x = c->first_y = -1;
    rd_rgb bg = R->s->render.background;
    double g = R->s->render.gamma;
    for (int y = 0; y < o->h; y++)
        for (int x = 0; x < o->w; x++) {
            lhit h;
            ld at;
            lv d = lref_dir(R, x + 0.5L, y + 0.5L);
            int hit = lref_closest(R, lv3(0, 0, 0), d, INFINITY, &h, &at);
            if (at < (hit ? h.t * (1 + 1e-12L) : (ld)INFINITY)) {
                c->boundary++;
                continue;
            }
            c->compared++;
            int shown = !is_rgb(px(o, x, y), bg, g);
            if (shown != hit) {
                if (c->mismatches == 0) {
                    c->first_x = x;
                    c->first_y = y;
                }
                c->mismatches++;
            }
        }
}

/* Compares, notes and accumulates: worst gets the mismatch count; a
 * boundary band wider than max_boundary_frac of the image is an extra
 * failure (the comparison would say little). */
static void judge(rd_case_result *r, const char *what, const lcmp *c, size_t npix, double max_boundary_frac)
{
    note(r, "%s: %zu of %zu pixels off (max %d levels)", what, c->mismatches, c->compared, c->maxlev);
    if (c->mismatches)
        note(r, " first at (%d,%d)", c->first_x, c->first_y);
    note(r, ", %zu boundary; ", c->boundary);
    worst(r, (double)c->mismatches);
    if ((double)c->boundary > max_boundary_frac * (double)npix) {
        r->extra_fail = 1;
        note(r, "[too many boundary pixels in %s] ", what);
    }
}

/* Loads, optionally adjusts, renders and compares with the reference. */
static void ref_case(rd_case_result *r, const char *file, void (*adjust)(rd_scene *, int), int variant,
                     const char *what, int coverage_only)
{
    rd_scene s;
    if (!load(r, file, &s)) {
        rd_scene_free(&s);
        return;
    }
    if (adjust)
        adjust(&s, variant);
    shot o;
    if (shoot(r, &s, &o)) {
        lref R;
        if (lref_make(&R, &s)) {
            lcmp c;
            if (coverage_only)
                lref_coverage(&R, &o, &c);
            else
                lref_compare(&R, &o, 1, &c);
            judge(r, what, &c, (size_t)o.w * o.h, 0.1);
            lref_free(&R);
        }
        shot_free(&o);
    }
    rd_scene_free(&s);
}

/* ---- scale and translation -------------------------------------------------- */

/* The powers of two of scale_pow2: every 5 from -40 to 40, and ±1. */
static const int pow2_k[] = {-40, -35, -30, -25, -20, -15, -10, -5, -1, 0, 1, 5, 10, 15, 20, 25, 30, 35, 40};
static const int pow2_wide_k[] = {-300, -250, -200, -150, -100, -60, 60, 100, 150, 200, 250, 300};

/* Renders scale.cfg transformed by p·f + t; 0 on error. */
static int scale_shot(rd_case_result *r, double f, rd_vec3 t, shot *o)
{
    rd_scene s;
    int ok = load(r, "scale.cfg", &s);
    if (ok) {
        xform(&s, f, t);
        ok = shoot(r, &s, o);
    }
    rd_scene_free(&s);
    return ok;
}

static void pow2_sweep(rd_case_result *r, const int *ks, size_t n)
{
    shot base;
    if (!scale_shot(r, 1, v3(0, 0, 0), &base))
        return;
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        shot o;
        if (!scale_shot(r, ldexp(1.0, ks[i]), v3(0, 0, 0), &o))
            break;
        size_t d = diff_bytes(&base, &o);
        worst(r, (double)d);
        if (d) {
            bad++;
            note(r, "2^%d: %zu bytes differ; ", ks[i], d);
        }
        shot_free(&o);
    }
    note(r, "%zu scales, %zu differ from scale 1. ", n, bad);
    shot_free(&base);
}

static void run_scale_pow2(rd_case_result *r) { pow2_sweep(r, pow2_k, sizeof pow2_k / sizeof pow2_k[0]); }

static void run_scale_pow2_wide(rd_case_result *r)
{
    pow2_sweep(r, pow2_wide_k, sizeof pow2_wide_k / sizeof pow2_wide_k[0]);
}

static void decimal_sweep(rd_case_result *r, const double *f, const rd_vec3 *t, size_t n, const char **names)
{
    shot base;
    if (!scale_shot(r, 1, v3(0, 0, 0), &base))
        return;
    for (size_t i = 0; i < n; i++) {
        shot o;
        if (!scale_shot(r, f[i], t[i], &o))
            break;
        int maxlev;
        size_t d = diff_pixels(&base, &o, &maxlev);
        worst(r, (double)d);
        note(r, "%s: %zu pixels differ (max %d levels); ", names[i], d, maxlev);
        shot_free(&o);
    }
    shot_free(&base);
}

static void run_scale_decimal(rd_case_result *r)
{
    const double f[] = {1e-9, 1e9, 0.1, 3};
    const rd_vec3 t[] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    const char *names[] = {"x1e-9", "x1e9", "x0.1", "x3"};
    decimal_sweep(r, f, t, 4, names);
}

static void run_translate_far(rd_case_result *r)
{
    const double f[] = {1, 1, 1};
    const rd_vec3 t[] = {{1e6, 0.5e6, -1e6}, {1e8, 0.5e8, -1e8}, {-1e8, 1e8, 1e8}};
    const char *names[] = {"+(1e6, 5e5, -1e6)", "+(1e8, 5e7, -1e8)", "+(-1e8, 1e8, 1e8)"};
    decimal_sweep(r, f, t, 3, names);
}

/* Floor pixels (the reference's centre ray hits object 0, the floor, and
 * no boundary is near) of scale.cfg at scale 1. */
static unsigned char *floor_mask(rd_case_result *r, int *w, int *h)
{
    rd_scene s;
    unsigned char *m = NULL;
    if (load(r, "scale.cfg", &s)) {
        lref R;
        if (lref_make(&R, &s)) {
            *w = R.W;
            *h = R.H;
            m = calloc((size_t)R.W * R.H, 1);
            for (int y = 0; m && y < R.H; y++)
                for (int x = 0; x < R.W; x++) {
                    lhit hh;
                    ld at;
                    lv d = lref_dir(&R, x + 0.5L, y + 0.5L);
                    int hit = lref_closest(&R, lv3(0, 0, 0), d, INFINITY, &hh, &at);
                    m[(size_t)y * R.W + x] = hit && hh.obj == 0 && !(at < hh.t * (1 + 1e-12L));
                }
            lref_free(&R);
        }
    }
    rd_scene_free(&s);
    return m;
}

/* Acne on the glancing floor: pixels darker than their four floor
 * neighbours by more than 2 levels in every channel (isolated dark
 * pixels), and pixels darker than the scale-1 render by more than 1 level. */
static void run_scale_acne(rd_case_result *r)
{
    int w = 0, h = 0;
    unsigned char *m = floor_mask(r, &w, &h);
    shot base;
    if (!m || !scale_shot(r, 1, v3(0, 0, 0), &base)) {
        free(m);
        return;
    }
    size_t nfloor = 0, isolated = 0;
    for (int y = 1; y + 1 < h; y++)
        for (int x = 1; x + 1 < w; x++) {
            if (!m[(size_t)y * w + x])
                continue;
            nfloor++;
            const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
            int dark = 1;
            for (int k = 0; k < 4 && dark; k++) {
                int xx = x + nb[k][0], yy = y + nb[k][1];
                if (!m[(size_t)yy * w + xx]) {
                    dark = 0;
                    break;
                }
                for (int c = 0; c < 3; c++)
                    if (!(px(&base, x, y)[c] + 2 < px(&base, xx, yy)[c]))
                        dark = 0;
            }
            isolated += dark;
        }
    note(r, "scale 1: %zu floor pixels, %zu isolated dark; ", nfloor, isolated);
    worst(r, (double)isolated);
    double fs[32];
    rd_vec3 ts[32];
    size_t n = 0;
    for (size_t i = 0; i < sizeof pow2_k / sizeof pow2_k[0]; i++, n++) {
        fs[n] = ldexp(1.0, pow2_k[i]);
        ts[n] = v3(0, 0, 0);
    }
    fs[n] = 1e-9, ts[n++] = v3(0, 0, 0);
    fs[n] = 1e9, ts[n++] = v3(0, 0, 0);
    fs[n] = 1, ts[n++] = v3(1e6, 0.5e6, -1e6);
    fs[n] = 1, ts[n++] = v3(1e8, 0.5e8, -1e8);
    size_t darker_all = 0;
    for (size_t i = 0; i < n; i++) {
        shot o;
        if (!scale_shot(r, fs[i], ts[i], &o))
            break;
        size_t darker = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                if (!m[(size_t)y * w + x])
                    continue;
                for (int c = 0; c < 3; c++)
                    if (px(&o, x, y)[c] + 1 < px(&base, x, y)[c]) {
                        darker++;
                        break;
                    }
            }
        if (darker)
            note(r, "render %zu: %zu floor pixels darker; ", i, darker);
        darker_all += darker;
        worst(r, (double)(isolated + darker));
        shot_free(&o);
    }
    note(r, "%zu scaled/translated renders, %zu darker floor pixels in all. ", n, darker_all);
    shot_free(&base);
    free(m);
}

/* ---- tiny, huge, planet -------------------------------------------------------- */

static double fov_scaled(double fov_deg, double k) { return 2 * atan(tan(fov_deg * M_PI / 360) * k) * 360 / M_PI; }

static void tiny_adjust(rd_scene *s, int v)
{
    const double f[] = {1, 1e-4, 1e4};
    for (size_t i = 0; i < s->object_count; i++)
        s->objects[i].center = v3_scale(s->objects[i].center, f[v]);
    s->camera.fov_deg = fov_scaled(s->camera.fov_deg, 1 / f[v]);
}

static void run_tiny_far(rd_case_result *r)
{
    const char *what[] = {"r/d 1e-8", "r/d 1e-4", "r/d 1e-12"};
    for (int v = 0; v < 3; v++)
        ref_case(r, "tiny_far.cfg", tiny_adjust, v, what[v], 1);
}

static void huge_adjust(rd_scene *s, int v)
{
    const double R[] = {1e6, 1e9, 1e12};
    s->objects[0].center = v3(0, -R[v], 0);
    s->objects[0].radius = R[v];
    s->camera.fov_deg = 2 * atan(3 * sqrt(2 / R[v])) * 180 / M_PI;
}

static void run_huge_near(rd_case_result *r)
{
    const char *what[] = {"R 1e6", "R 1e9", "R 1e12"};
    for (int v = 0; v < 3; v++) {
        ref_case(r, "huge_near.cfg", huge_adjust, v, what[v], 1);
        ref_case(r, "huge_near.cfg", huge_adjust, v, "shaded", 0);
    }
}

static void run_planet_plane(rd_case_result *r)
{
    rd_scene s;
    if (!load(r, "planet.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    shot a, b;
    if (shoot(r, &s, &a)) {
        rd_object *o = &s.objects[0];
        o->type = RD_OBJ_PLANE;
        o->point = v3(0, 0, 0);
        o->normal = v3(0, 1, 0);
        if (shoot(r, &s, &b)) {
            int maxlev;
            size_t d = diff_pixels(&a, &b, &maxlev);
            worst(r, maxlev);
            note(r, "sphere r=1e7 against plane y=0: %zu pixels differ, max %d levels. ", d, maxlev);
            shot_free(&b);
        }
        shot_free(&a);
    }
    rd_scene_free(&s);
}

/* ---- grazing light, camera inside and on surfaces, parallel rays -------------- */

static void grazing_adjust(rd_scene *s, int v)
{
    if (v & 1) {
        /* from the shadow side, low and close: the floor next to the
         * contact point (0 0 -4), where the shadow starts, fills the view */
        s->camera.eye = v3(-1.6, 0.12, -3.9);
        s->camera.target = v3(0, 0.02, -4);
        s->camera.fov_deg = 25;
    }
    if (v & 2) {
        /* a point light 100 away at 1 degree elevation */
        rd_light *l = &s->lights[0];
        l->type = RD_LIGHT_POINT;
        l->position = v3(100 * cos(M_PI / 180), 100 * sin(M_PI / 180), -4);
    }
}

/* Floor pixels within 0.3 of the big sphere's contact point (0 0 -4) in
 * the shadow-side views: how many, how many in its shadow (reference), and
 * how many of those the render shows lit (a detached shadow). */
static void contact_check(rd_case_result *r, int v)
{
    rd_scene s;
    if (!load(r, "grazing.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    grazing_adjust(&s, v);
    shot o;
    lref R;
    if (shoot(r, &s, &o) && lref_make(&R, &s)) {
        size_t near = 0, dark = 0, detached = 0;
        lv contact = lsub(lv3(0, 0, -4), R.eye);
        for (int y = 0; y < o.h; y++)
            for (int x = 0; x < o.w; x++) {
                lhit h;
                ld at;
                lv d = lref_dir(&R, x + 0.5L, y + 0.5L);
                if (!lref_closest(&R, lv3(0, 0, 0), d, INFINITY, &h, &at) || h.obj != 0 ||
                    llen(lsub(h.p, contact)) > 0.3L)
                    continue;
                int amb, obj;
                lv e = lref_pixel(&R, x, y, &amb, &obj);
                if (amb)
                    continue;
                near++;
                /* in shadow: only the ambient term */
                if (fabsl(e.x - (ld)s.materials[s.objects[0].material].ambient.x) < 1e-12L) {
                    dark++;
                    if (px(&o, x, y)[0] > to8((double)e.x, 1.0) + 1)
                        detached++;
                }
            }
        note(r,
             "contact point (view %d): %zu floor pixels within 0.3 of it, %zu in the sphere's shadow, %zu of "
             "those lit; ",
             v, near, dark, detached);
        worst(r, (double)detached);
        if (dark == 0) {
            r->extra_fail = 1;
            note(r, "[no shadowed pixel near the contact point: the check says nothing] ");
        }
        lref_free(&R);
    }
    shot_free(&o);
    rd_scene_free(&s);
}

static void run_grazing_light(rd_case_result *r)
{
    const char *what[] = {"directional, front view", "directional, shadow-side view", "point, front view",
                          "point, shadow-side view"};
    for (int v = 0; v < 4; v++)
        ref_case(r, "grazing.cfg", grazing_adjust, v, what[v], 0);
    contact_check(r, 1);
    contact_check(r, 3);
}

static void inside_adjust(rd_scene *s, int v)
{
    const double z[] = {0, 5 - 1e-6, 5 - 1e-12, 0};
    s->camera.eye = v3(0, 0, z[v]);
    if (v == 3)
        s->camera.eye = v3(-1.2, 2.1, 3.3);
}

static void run_camera_inside(rd_case_result *r)
{
    const char *what[] = {"eye at centre", "eye 1e-6 from wall", "eye 1e-12 from wall", "eye off centre"};
    for (int v = 0; v < 4; v++)
        ref_case(r, "inside.cfg", inside_adjust, v, what[v], 0);
}

static void run_camera_on_surface(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "on_surface.cfg", &s)) {
        shot o;
        if (shoot(r, &s, &o)) {
            size_t blue = 0;
            rd_rgb plane = s.materials[s.objects[0].material].ambient;
            for (int y = 0; y < o.h; y++)
                for (int x = 0; x < o.w; x++)
                    blue += is_rgb(px(&o, x, y), plane, s.render.gamma);
            note(r, "eye on plane: %zu pixels show the plane; ", blue);
            worst(r, (double)blue);
            lref R;
            if (lref_make(&R, &s)) {
                lcmp c;
                lref_coverage(&R, &o, &c);
                judge(r, "eye on plane", &c, (size_t)o.w * o.h, 0.1);
                if (c.mismatches + blue > r->worst)
                    r->worst = (double)(c.mismatches + blue);
                lref_free(&R);
            }
            shot_free(&o);
        }
    }
    rd_scene_free(&s);
    ref_case(r, "on_sphere.cfg", NULL, 0, "eye on sphere", 1);
}

static void run_rays_parallel(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "parallel.cfg", &s)) {
        shot o;
        if (shoot(r, &s, &o)) {
            int flat = rd_scene_find_material(&s, "flat");
            size_t shown = 0;
            for (int y = 0; y < o.h; y++)
                for (int x = 0; x < o.w; x++)
                    shown += is_rgb(px(&o, x, y), s.materials[flat].ambient, s.render.gamma);
            note(r, "%zu pixels show the edge-on triangles; ", shown);
            /* the middle row: parallel to the floor */
            size_t bgmid = 0;
            for (int x = 0; x < o.w; x++)
                bgmid += is_rgb(px(&o, x, o.h / 2), s.render.background, s.render.gamma);
            note(r, "middle row: %zu of %d pixels background; ", bgmid, o.w);
            lref R;
            if (lref_make(&R, &s)) {
                lcmp c;
                lref_compare(&R, &o, 1, &c);
                judge(r, "parallel", &c, (size_t)o.w * o.h, 0.1);
                if ((double)(c.mismatches + shown) > r->worst)
                    r->worst = (double)(c.mismatches + shown);
                lref_free(&R);
            }
            shot_free(&o);
        }
    }
    rd_scene_free(&s);
}

/* ---- triangles ----------------------------------------------------------------- */

/* Background pixels of s rendered with the eye at e and the centre ray
 * aimed at t. */
static size_t bg_pixels_view(rd_case_result *r, rd_scene *s, rd_vec3 e, rd_vec3 t)
{
    s->camera.eye = e;
    s->camera.target = t;
    rd_vec3 d = v3_normalize(v3_sub(t, e));
    s->camera.up = fabs(d.y) > 0.9 ? v3(1, 0, 0) : v3(0, 1, 0);
    shot o;
    if (!shoot(r, s, &o))
        return 0;
    size_t n = 0;
    for (int y = 0; y < o.h; y++)
        for (int x = 0; x < o.w; x++)
            n += is_rgb(px(&o, x, y), s->render.background, s->render.gamma);
    shot_free(&o);
    return n;
}

/* Views from inside a closed mesh: centre ray through vertices, edge
 * midpoints and face centres, from several eyes. */
static void watertight_mesh(rd_case_result *r, const char *obj, int stride)
{
    rd_scene s;
    if (!load(r, "watertight.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    if (strcmp(obj, "icosphere.obj") != 0) {
        /* the same scene with the other mesh: reload it through the loader */
        rd_scene_free(&s);
        char path[1024];
        snprintf(path, sizeof path, "%s/watertight.cfg", rd_stability_scene_dir);
        rd_scene_init(&s);
        rd_error err = {0};
        rd_scene_limits lim = rd_scene_limits_default();
        if (rd_scene_load_file(path, &lim, &s, &err) != RD_OK) {
            r->error = 1;
            note(r, "%s. ", err.message);
            rd_scene_free(&s);
            return;
        }
        for (size_t i = 0; i < s.object_count; i++)
            if (s.objects[i].type == RD_OBJ_MESH) {
                free(s.objects[i].file);
                s.objects[i].file = strdup(obj);
            }
        char *dir = rd_dirname(path);
        rd_asset_source src = rd_asset_folder(dir ? dir : ".");
        rd_error_code rc = rd_scene_load_assets(&s, &src, &lim, NULL, &err);
        free(dir);
        if (rc != RD_OK) {
            r->error = 1;
            note(r, "%s. ", err.message);
            rd_scene_free(&s);
            return;
        }
    }
    const rd_mesh *m = &s.meshes[0];
    rd_vec3 eyes[5] = {{0, 0, 0}, {0.3, -0.2, 0.1}, {-0.45, 0.4, 0.35}, {0, 0, 0}, {1e-9, -2e-9, 0}};
    eyes[3] = v3_scale(m->positions[5], 0.999);
    size_t views = 0, bg = 0;
    for (int e = 0; e < 5; e++) {
        for (size_t i = 0; i < m->npositions; i += (size_t)stride) {
            bg += bg_pixels_view(r, &s, eyes[e], m->positions[i]);
            views++;
        }
        for (size_t f = 0; f < m->nfaces; f += (size_t)stride) {
            const rd_mesh_face *fc = &m->faces[f];
            rd_vec3 a = m->positions[fc->v[0]], b = m->positions[fc->v[1]], c = m->positions[fc->v[2]];
            bg += bg_pixels_view(r, &s, eyes[e], v3_scale(v3_add(a, v3_add(b, c)), 1.0 / 3));
            bg += bg_pixels_view(r, &s, eyes[e], v3_scale(v3_add(a, b), 0.5));
            views += 2;
        }
    }
    note(r, "%s: %zu views of %dx%d, %zu background pixels; ", obj, views, s.render.width, s.render.height, bg);
    worst(r, (double)bg);
    rd_scene_free(&s);
}

static void run_tri_watertight(rd_case_result *r)
{
    watertight_mesh(r, "icosphere.obj", 37);
    watertight_mesh(r, "ico0.obj", 1);
}

static void run_tri_degenerate(rd_case_result *r)
{
    rd_scene s, t;
    if (load(r, "tri_degenerate.cfg", &s) && load(r, "tri_degenerate.cfg", &t)) {
        /* drop the zero-area ones (objects 2, 3, 4) and the two copies (10, 11) */
        drop_object(&t, 11);
        drop_object(&t, 10);
        drop_object(&t, 4);
        drop_object(&t, 3);
        drop_object(&t, 2);
        shot a, b;
        if (shoot(r, &s, &a) && shoot(r, &t, &b)) {
            size_t d = diff_bytes(&a, &b);
            note(r, "13 triangles (BVH) against 8 (plain loop) without zero-area ones and copies: %zu bytes differ; ",
                 d);
            worst(r, (double)d);
            lref R;
            if (lref_make(&R, &s)) {
                lcmp c;
                lref_compare(&R, &a, 1, &c);
                judge(r, "against reference", &c, (size_t)a.w * a.h, 0.1);
                if ((double)(c.mismatches + d) > r->worst)
                    r->worst = (double)(c.mismatches + d);
                lref_free(&R);
            }
        }
        shot_free(&a);
        shot_free(&b);
    }
    rd_scene_free(&s);
    rd_scene_free(&t);
}

static void flat_adjust(rd_scene *s, int v)
{
    if (v == 1) {
        /* low and grazing, along the z grid lines */
        s->camera.eye = v3(0, 0.35, 3.9);
        s->camera.target = v3(0, 0, -1);
        s->camera.up = v3(0, 1, 0);
        s->camera.fov_deg = 50;
    }
}

static void run_tri_flat_bvh(rd_case_result *r)
{
    ref_case(r, "flat_bvh.cfg", flat_adjust, 0, "from above", 0);
    ref_case(r, "flat_bvh.cfg", flat_adjust, 1, "grazing", 0);
    rd_scene s;
    if (load(r, "flat_bvh.cfg", &s)) {
        shot a, b;
        if (shoot(r, &s, &a)) {
            rd_object *o = &s.objects[0];
            o->type = RD_OBJ_PLANE;
            o->point = v3(0, 0, 0);
            o->normal = v3(0, 1, 0);
            if (shoot(r, &s, &b)) {
                int maxlev;
                size_t d = diff_pixels(&a, &b, &maxlev);
                size_t bg = 0;
                for (int y = 0; y < a.h; y++)
                    for (int x = 0; x < a.w; x++)
                        bg += is_rgb(px(&a, x, y), s.render.background, s.render.gamma);
                note(r, "grid against plane y=0: %zu pixels differ (max %d levels), %zu background (holes); ", d,
                     maxlev, bg);
                worst(r, (double)(bg + (maxlev > 1 ? d : 0)));
                shot_free(&b);
            }
            shot_free(&a);
        }
    }
    rd_scene_free(&s);
}

static void run_tri_cancel_normals(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "cancel_normals.cfg", &s)) {
        shot o;
        if (shoot(r, &s, &o)) {
            lref R;
            if (lref_make(&R, &s)) {
                lcmp c;
                lref_compare(&R, &o, 1, &c);
                judge(r, "normals against reference", &c, (size_t)o.w * o.h, 0.1);
                lref_free(&R);
            }
            /* centre ray: the bottom edge's midpoint, where the normal is 0 */
            const uint8_t *p = px(&o, o.w / 2, o.h / 2);
            int geo = is_rgb(p, v3(0.5, 0.5, 1), 1.0);
            note(r, "centre pixel (zero normal) %d %d %d: %s; ", p[0], p[1], p[2],
                 geo ? "geometric normal" : "NOT the geometric normal");
            if (!geo)
                worst(r, r->worst + 1);
            shot_free(&o);
        }
    }
    rd_scene_free(&s);
}

/* ---- materials ------------------------------------------------------------------ */

/* Relative error with an absolute floor of 1e-9 (a billionth of white):
 * below it a value cannot matter to any image. */
static double rel_err(double got, ld want)
{
    if (!isfinite(got))
        return INFINITY;
    ld d = fabsl((ld)got - want);
    ld m = fabsl(want) > 1e-9L ? fabsl(want) : 1e-9L;
    return (double)(d / m);
}

static rd_hit hit_with_normal(rd_vec3 n)
{
    rd_hit h;
    memset(&h, 0, sizeof h);
    h.n = n;
    h.ng = n;
    h.front = 1;
    return h;
}

/* Phong and Blinn-Phong at shininess 0, 1, 1e3, 1e6, 1e9: the peak at the
 * mirror direction is kd·cos α + ks, and at angle θ from it the value
 * follows ks·cos(θ)^n (computed in long double from the same double
 * vectors) to a relative 1e-6. */
static void run_shininess_lobe(rd_case_result *r)
{
    const double ns[] = {0, 1, 1e3, 1e6, 1e9};
    const double ks_[] = {0, 0.25, 0.5, 1, 1.5, 2, 3, 4};
    double peak_err = 0, lobe_err = 0;
    int evals = 0;
    for (int type = 0; type < 2; type++)
        for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++) {
            rd_material m;
            memset(&m, 0, sizeof m);
            rd_material_defaults(&m, type ? RD_MAT_BLINN_PHONG : RD_MAT_PHONG);
            m.kd = v3(0.3, 0.2, 0.1);
            m.ks = v3(0.7, 0.6, 0.5);
            m.shininess = ns[i];
            double a = 0.6; /* incidence */
            rd_vec3 N = v3(0, 0, 1);
            rd_vec3 L = v3(sin(a), 0, -cos(a));
            rd_hit h = hit_with_normal(N);
            for (size_t k = 0; k < sizeof ks_ / sizeof ks_[0]; k++) {
                double th = ns[i] > 1 ? ks_[k] / sqrt(ns[i]) : ks_[k] * 0.2;
                /* V at angle th from the mirror direction, tilted out of
                 * the plane of incidence */
                rd_vec3 V = v3_normalize(v3(sin(a) * cos(th), sin(th), cos(a) * cos(th)));
                rd_rgb got = rd_calc_reflected_light(&m, &h, L, V);
                lv lN = lvd(N), lL = lvd(L), lV = lunit(lvd(V));
                ld cosa = -ldot(lN, lL);
                ld spec;
                if (type == 0) {
                    lv R = lunit(lsub(lL, lmul(lN, 2 * ldot(lL, lN))));
                    spec = lpow_cos(R, lV, ns[i]);
                } else {
                    spec = lpow_cos(lN, lunit(lsub(lV, lL)), ns[i]);
                }
                double gv[3] = {got.x, got.y, got.z};
                double kd[3] = {m.kd.x, m.kd.y, m.kd.z}, ks[3] = {m.ks.x, m.ks.y, m.ks.z};
                for (int c = 0; c < 3; c++) {
                    ld want = kd[c] * cosa + ks[c] * spec;
                    double e = rel_err(gv[c], want);
                    if (k == 0 && e > peak_err)
                        peak_err = e;
                    if (e > lobe_err)
                        lobe_err = e;
                    evals++;
                }
            }
        }
    note(r, "%d values: peak (mirror direction) relative error %.3g, lobe %.3g. ", evals, peak_err, lobe_err);
    worst(r, peak_err > lobe_err ? peak_err : lobe_err);
}

static void highlight_adjust(rd_scene *s, int v)
{
    /* v: 0 phong 1e6 (as written), 1 phong 1e3, 2 phong 1e9, 3 blinn 1e6, 4 blinn 1e9, 5 phong 0 */
    const double n[] = {1e6, 1e3, 1e9, 1e6, 1e9, 0};
    rd_material *m = &s->materials[0];
    m->shininess = n[v];
    if (v == 3 || v == 4)
        m->type = RD_MAT_BLINN_PHONG;
    double k = n[v] > 0 ? sqrt(1e6 / n[v]) : 400;
    if (m->type == RD_MAT_BLINN_PHONG)
        k *= 2; /* N·H moves half as fast as R·V */
    s->camera.fov_deg = fov_scaled(s->camera.fov_deg, k);
}

static void run_highlight_disc(rd_case_result *r)
{
    const char *what[] = {"phong 1e6", "phong 1e3", "phong 1e9", "blinn 1e6", "blinn 1e9", "phong 0"};
    for (int v = 0; v < 6; v++) {
        rd_scene s;
        if (!load(r, "highlight.cfg", &s)) {
            rd_scene_free(&s);
            return;
        }
        highlight_adjust(&s, v);
        shot o;
        if (shoot(r, &s, &o)) {
            lref R;
            if (lref_make(&R, &s)) {
                lcmp c;
                lref_compare(&R, &o, 1, &c);
                judge(r, what[v], &c, (size_t)o.w * o.h, 0.1);
                lref_free(&R);
            }
            /* distinct levels of the red channel over the image (the lobe
             * fills it), against those of the long-double lobe */
            int seen[256] = {0}, seen_ref[256] = {0}, distinct = 0, distinct_ref = 0;
            lref R2;
            if (lref_make(&R2, &s)) {
                for (int y = 0; y < o.h; y++)
                    for (int x = 0; x < o.w; x++) {
                        int amb, obj;
                        lv e = lref_pixel(&R2, x, y, &amb, &obj);
                        if (!seen_ref[to8((double)e.x, s.render.gamma)]++)
                            distinct_ref++;
                        if (!seen[px(&o, x, y)[0]]++)
                            distinct++;
                    }
                lref_free(&R2);
            }
            note(r, "%d distinct levels (long double: %d); ", distinct, distinct_ref);
            if (distinct + 1 < distinct_ref) {
                r->extra_fail = 1;
                note(r, "[quantised: fewer levels than the long-double lobe] ");
            }
            shot_free(&o);
        }
        rd_scene_free(&s);
    }
}

/* Cook-Torrance in long double (the formula of shading.md, the renderer's
 * cap of 1e200 on the specular factor). */
static lv lct(const rd_material *m, lv N, lv L, lv V)
{
    int amb = 0;
    return lbrdf(m, N, L, V, 0, &amb);
}

static double ct_check(const rd_material *m, rd_vec3 N, rd_vec3 L, rd_vec3 V, int *bad)
{
    rd_hit h = hit_with_normal(N);
    rd_rgb got = rd_calc_reflected_light(m, &h, L, V);
    /* the formula on exactly these doubles: the renderer takes them as unit */
    lv want = lct(m, lvd(N), lvd(L), lvd(V));
    double g[3] = {got.x, got.y, got.z};
    ld w[3] = {want.x, want.y, want.z};
    double e = 0;
    for (int c = 0; c < 3; c++) {
        if (!isfinite(g[c]) || g[c] < 0)
            (*bad)++;
        double ec = rel_err(g[c], w[c]);
        if (ec > e)
            e = ec;
    }
    return e;
}

/* In-plane V at N·V = nv and L at angle off (radians) from V's mirror. */
static void ct_dirs(double nv, double off, rd_vec3 *L, rd_vec3 *V)
{
    double sv = sqrt((1 - nv) * (1 + nv));
    *V = v3(sv, 0, nv);
    /* the mirror light direction is (sv, 0, -nv); rotate it by off about y,
     * keeping it below the horizon (cos α > 0) */
    double a = atan2(sv, nv) - off; /* angle from the normal */
    *L = v3(sin(a), 0, -cos(a));
}

static void run_cook_torrance_limits(rd_case_result *r)
{
    const double rough[] = {1e-4, 1e-2, 0.3, 1};
    const double nvs[] = {1, 0.5, 1e-3, 1e-8, 1e-16, 1e-300, 0};
    const double offs[] = {0, 0.5, 1, 3};
    double e = 0;
    int bad = 0, n = 0;
    for (size_t i = 0; i < 4; i++)
        for (size_t j = 0; j < 7; j++)
            for (size_t k = 0; k < 4; k++) {
                rd_material m;
                memset(&m, 0, sizeof m);
                rd_material_defaults(&m, RD_MAT_COOK_TORRANCE);
                m.kd = v3(0.1, 0.1, 0.1);
                m.ks = v3(0.9, 0.8, 0.6);
                m.roughness = rough[i];
                rd_vec3 L, V;
                ct_dirs(nvs[j], offs[k] * rough[i], &L, &V);
                double ek = ct_check(&m, v3(0, 0, 1), L, V, &bad);
                if (ek > e)
                    e = ek;
                n++;
            }
    note(r,
         "%d evaluations (roughness 1e-4..1, N.V 1..0, mirror and off-mirror): max relative error %.3g, %d "
         "non-finite or negative. ",
         n, e, bad);
    worst(r, bad ? INFINITY : e);
}

static void run_cook_torrance_lobe(rd_case_result *r)
{
    const double rough[] = {1e-5, 1e-6, 1e-7, 1e-8};
    const double offs[] = {0.5, 1, 2};
    int bad = 0;
    for (size_t i = 0; i < 4; i++) {
        double e = 0;
        for (size_t k = 0; k < 3; k++) {
            rd_material m;
            memset(&m, 0, sizeof m);
            rd_material_defaults(&m, RD_MAT_COOK_TORRANCE);
            m.kd = v3(0, 0, 0);
            m.ks = v3(0.9, 0.8, 0.6);
            m.roughness = rough[i];
            rd_vec3 L, V;
            ct_dirs(0.7, offs[k] * rough[i], &L, &V);
            double ek = ct_check(&m, v3(0, 0, 1), L, V, &bad);
            if (ek > e)
                e = ek;
        }
        note(r, "roughness %g: max relative error %.3g; ", rough[i], e);
        worst(r, e);
    }
    if (bad)
        worst(r, INFINITY);
}

static void ct_adjust(rd_scene *s, int v)
{
    const double m[] = {1e-4, 1e-2, 1};
    s->materials[0].roughness = m[v];
}

static void run_cook_torrance_image(rd_case_result *r)
{
    const char *what[] = {"roughness 1e-4", "roughness 1e-2", "roughness 1"};
    for (int v = 0; v < 3; v++)
        ref_case(r, "ct_grazing.cfg", ct_adjust, v, what[v], 0);
}

/* Blinn-Phong with the light along the view (L = -V, so H = V), and with
 * the light exactly behind (L = V: 0) or nearly so. */
static void run_blinn_degenerate_h(rd_case_result *r)
{
    const double nvs[] = {1, 0.5, 1e-3, 1e-8, 1e-300};
    const double ns[] = {0, 1, 50, 1e6};
    double e = 0;
    int bad = 0;
    for (size_t i = 0; i < 5; i++)
        for (size_t j = 0; j < 4; j++) {
            rd_material m;
            memset(&m, 0, sizeof m);
            rd_material_defaults(&m, RD_MAT_BLINN_PHONG);
            m.kd = v3(0.3, 0.2, 0.1);
            m.ks = v3(0.7, 0.6, 0.5);
            m.shininess = ns[j];
            rd_vec3 N = v3(0, 0, 1);
            double sv = sqrt((1 - nvs[i]) * (1 + nvs[i]));
            rd_vec3 V = v3(sv, 0, nvs[i]);
            rd_hit h = hit_with_normal(N);
            rd_rgb got = rd_calc_reflected_light(&m, &h, v3_neg(V), V);
            lv lV = lunit(lvd(V));
            ld nv = lV.z;
            ld spec = ns[j] == 0 ? 1 : expl(ns[j] * logl(nv));
            double g[3] = {got.x, got.y, got.z};
            double kd[3] = {0.3, 0.2, 0.1}, ks[3] = {0.7, 0.6, 0.5};
            for (int c = 0; c < 3; c++) {
                double ec = rel_err(g[c], kd[c] * nv + ks[c] * spec);
                if (ec > e)
                    e = ec;
            }
            /* light behind, exactly and nearly */
            rd_rgb z = rd_calc_reflected_light(&m, &h, V, V);
            rd_vec3 V2 = v3_normalize(v3(sv, 1e-300, nvs[i]));
            rd_rgb z2 = rd_calc_reflected_light(&m, &h, V2, V);
            if (!(z.x == 0 && z.y == 0 && z.z == 0) || !v3_is_finite(z2) || !v3_is_finite(got))
                bad++;
        }
    note(r, "L = -V: max relative error %.3g; L = V and L ~ V: %d not 0 or not finite. ", e, bad);
    worst(r, bad ? INFINITY : e);
}

/* Fresnel across the critical angle: exact against long double, R + T = 1
 * with T from the transmission amplitudes at the returned cos θt, and
 * R = 1 exactly (cos θt = 0) past the critical angle. */
static void run_fresnel_critical(rd_case_result *r)
{
    const double pairs[][2] = {{1.5, 1}, {2.42, 1}, {1.0001, 1}, {1, 1.5}, {1.333, 1.5}};
    double errF = 0, errRT = 0;
    int tir_bad = 0, range_bad = 0, n = 0;
    for (size_t p = 0; p < sizeof pairs / sizeof pairs[0]; p++) {
        double n1 = pairs[p][0], n2 = pairs[p][1];
        double eta = n1 / n2;
        double cc = eta > 1 ? sqrt(1 - 1 / (eta * eta)) : 0; /* critical cosine */
        for (int i = -4000; i <= 24000; i++) {
            double cosi;
            if (i < 0)
                cosi = cc + ldexp((double)(i + 2000), -60) * cc; /* within ±2000·2^-60 relative of critical */
            else if (i < 4000)
                cosi = cc * (1 + (i - 2000) * 1e-9);
            else
                cosi = (i - 4000) / 20000.0;
            if (cosi < 0 || cosi > 1)
                continue;
            double cost;
            double F = rd_fresnel_dielectric(cosi, n1, n2, &cost);
            n++;
            if (!(F >= 0 && F <= 1) || !(cost >= 0 && cost <= 1))
                range_bad++;
            ld le = (ld)n1 / n2;
            ld c2 = 1 - le * le * (1 - (ld)cosi * cosi);
            if (c2 <= 0) {
                if (F != 1 || cost != 0)
                    tir_bad++;
                continue;
            }
            ld ct = sqrtl(c2), ci = cosi;
            ld rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct), rp = (n1 * ct - n2 * ci) / (n1 * ct + n2 * ci);
            ld FL = (rs * rs + rp * rp) / 2;
            if (ci == 0)
                FL = 1;
            ld e1 = fabsl(F - FL);
            if (e1 > errF)
                errF = (double)e1;
            /* T at the returned cos θt */
            ld rct = cost;
            if (ci > 0 && rct > 0) {
                ld ts = 2 * n1 * ci / (n1 * ci + n2 * rct), tp = 2 * n1 * ci / (n1 * rct + n2 * ci);
                ld T = (n2 * rct) / (n1 * ci) * (ts * ts + tp * tp) / 2;
                ld e2 = fabsl(F + T - 1);
                if (e2 > errRT)
                    errRT = (double)e2;
            }
        }
    }
    note(r,
         "%d incidences over 5 index pairs (dense within 1e-9 and 2^-49 of the critical angle): |F - F_ld| "
         "max %.3g, |R + T - 1| max %.3g; past critical %d not R = 1; %d out of [0,1]. ",
         n, errF, errRT, tir_bad, range_bad);
    worst(r, errF > errRT ? errF : errRT);
    if (tir_bad || range_bad)
        r->extra_fail = 1;
}

static void run_glass_ior1(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "glass_ior1.cfg", &s)) {
        shot a, b;
        if (shoot(r, &s, &a)) {
            drop_object(&s, 1);
            if (shoot(r, &s, &b)) {
                int maxlev;
                size_t d = diff_pixels(&a, &b, &maxlev);
                note(r, "with and without the ior-1 sphere: %zu pixels differ (max %d levels). ", d, maxlev);
                worst(r, (double)d);
                shot_free(&b);
            }
            shot_free(&a);
        }
    }
    rd_scene_free(&s);
}

/* Unit vectors whose dot product rounds above 1. */
static int find_long_unit(rd_vec3 *out)
{
    for (int i = 1; i < 200; i++)
        for (int j = 1; j < 200; j++) {
            rd_vec3 n = v3_normalize(v3(i, j, 0.37 * i + 0.11 * j + 1));
            if (v3_dot(n, n) > 1) {
                *out = n;
                return 1;
            }
        }
    return 0;
}

static void run_cos_above_one(rd_case_result *r)
{
    rd_vec3 N;
    if (!find_long_unit(&N)) {
        r->error = 1;
        note(r, "no vector found. ");
        return;
    }
    double dot = v3_dot(N, N);
    note(r, "N·N = 1 + %.3g; ", dot - 1);
    rd_hit h = hit_with_normal(N);
    double e = 0;
    int bad = 0;
    const rd_material_type types[] = {RD_MAT_DIFFUSE, RD_MAT_PHONG, RD_MAT_BLINN_PHONG, RD_MAT_COOK_TORRANCE};
    for (int t = 0; t < 4; t++) {
        rd_material m;
        memset(&m, 0, sizeof m);
        rd_material_defaults(&m, types[t]);
        m.kd = v3(0.3, 0.2, 0.1);
        m.ks = v3(0.7, 0.6, 0.5);
        m.shininess = 1e9;
        m.roughness = 0.3;
        rd_rgb got = rd_calc_reflected_light(&m, &h, v3_neg(N), N);
        /* the value at cos = 1 exactly: the same material on N = z */
        rd_hit hz = hit_with_normal(v3(0, 0, 1));
        rd_rgb want = rd_calc_reflected_light(&m, &hz, v3(0, 0, -1), v3(0, 0, 1));
        double g[3] = {got.x, got.y, got.z}, w[3] = {want.x, want.y, want.z};
        for (int c = 0; c < 3; c++) {
            if (!isfinite(g[c]))
                bad++;
            double ec = rel_err(g[c], w[c]);
            if (ec > e)
                e = ec;
        }
    }
    double pc = rd_pow_cos(N, N, 1e9);
    if (!(pc <= 1 && pc > 0.999999))
        bad++;
    double cost;
    double F = rd_fresnel_dielectric(dot, 1.5, 1, &cost);
    double F1 = rd_fresnel_dielectric(1, 1.5, 1, &cost);
    if (!(F == F1))
        bad++;
    /* a spot light whose axis is N, seen along N */
    rd_light l;
    memset(&l, 0, sizeof l);
    l.type = RD_LIGHT_SPOT;
    l.color = v3(1, 1, 1);
    l.position = v3_scale(N, 3);
    l.direction = v3_neg(N);
    l.angle_deg = 10;
    l.falloff = 1e9;
    rd_light_prep lp;
    rd_light_prepare(&lp, &l, v3(0, 0, 0));
    rd_light_sample ls;
    if (rd_light_sample_at(&lp, v3(0, 0, 0), 0, 0.5, 0.5, &ls) && (!v3_is_finite(ls.color) || ls.color.x > 1))
        bad++;
    note(r, "materials at cos > 1 against cos = 1: max relative error %.3g; pow_cos %.17g; Fresnel %s; %d bad. ", e, pc,
         F == F1 ? "as at 1" : "differs", bad);
    worst(r, bad ? INFINITY : e);
}

/* ---- lights ------------------------------------------------------------------------ */

/* light_inside.cfg with the lamp at depth·r below the shell's inner
 * surface (depth 1: the centre), against the scene without the lamp. */
static void inside_light(rd_case_result *r, const double *depth, size_t n)
{
    rd_scene s;
    shot dark;
    if (!load(r, "light_inside.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    rd_rgb col = s.lights[0].color;
    s.lights[0].color = v3(0, 0, 0);
    if (!shoot(r, &s, &dark)) {
        rd_scene_free(&s);
        return;
    }
    s.lights[0].color = col;
    for (size_t i = 0; i < n; i++) {
        /* towards the other sphere (+x) and, in a second render, straight up */
        for (int dir = 0; dir < 2; dir++) {
            rd_vec3 u = dir ? v3(0, 1, 0) : v3(1, 0, 0);
            s.lights[0].position = v3_add(v3(0, 1, 0), v3_scale(u, 1 - depth[i]));
            shot o;
            if (!shoot(r, &s, &o))
                break;
            int maxlev;
            size_t d = diff_pixels(&dark, &o, &maxlev);
            note(r, "%g below the shell (%s): %zu pixels lit (max %d levels); ", depth[i], dir ? "up" : "side", d,
                 maxlev);
            worst(r, (double)d);
            shot_free(&o);
        }
    }
    shot_free(&dark);
    rd_scene_free(&s);
}

static void run_light_inside_closed(rd_case_result *r)
{
    const double depth[] = {1, 0.5, 1e-3, 1e-6};
    inside_light(r, depth, 4);
}

static void run_light_inside_near_shell(rd_case_result *r)
{
    /* 1e-12 below a radius-1 shell is about 600 ulps of the coordinates: the
     * limit of what doubles resolve, so the case stops at 1e-10. */
    const double depth[] = {1e-9, 1e-10};
    inside_light(r, depth, 2);
}

static void run_light_on_surface(rd_case_result *r)
{
    ref_case(r, "light_on_surface.cfg", NULL, 0, "lights on a plane and on a sphere", 0);
}

/* far_light.cfg's point light at k times its distance against a
 * directional light along -position. */
static void far_light(rd_case_result *r, const double *k, size_t n)
{
    rd_scene s;
    if (!load(r, "far_light.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    rd_light *l = &s.lights[0];
    rd_vec3 p = l->position;
    l->type = RD_LIGHT_DIRECTIONAL;
    l->direction = v3_neg(p);
    shot dir;
    if (!shoot(r, &s, &dir)) {
        rd_scene_free(&s);
        return;
    }
    l->type = RD_LIGHT_POINT;
    for (size_t i = 0; i < n; i++) {
        l->position = v3_scale(p, k[i]);
        shot o;
        if (!shoot(r, &s, &o))
            break;
        int maxlev;
        size_t d = diff_pixels(&dir, &o, &maxlev);
        double mx = v3_max_abs(l->position);
        note(r, "point at %.3g: %zu pixels differ from directional (max %d levels); ",
             mx * v3_len(v3_scale(l->position, 1 / mx)), d, maxlev);
        worst(r, maxlev);
        shot_free(&o);
    }
    shot_free(&dir);
    rd_scene_free(&s);
}

static void run_light_far_point(rd_case_result *r)
{
    const double k[] = {1};
    far_light(r, k, 1);
}

static void run_light_far_extreme(rd_case_result *r)
{
    const double k[] = {1e85, 1e138, 1e140, 1e145, 1e185, 1e285};
    far_light(r, k, 6);
}

static void run_light_intensity(rd_case_result *r) { ref_case(r, "intense.cfg", NULL, 0, "lights of 1e38", 0); }

static void run_light_overflow(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "overflow.cfg", &s)) {
        shot o;
        if (shoot(r, &s, &o)) {
            note(r, "%llu non-finite samples (replaced by the renderer), %dx%d image. ",
                 (unsigned long long)o.st.nonfinite, o.w, o.h);
            worst(r, (double)o.st.nonfinite);
            shot_free(&o);
        }
    }
    rd_scene_free(&s);
}

static void run_light_zero(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "zero_light.cfg", &s)) {
        shot a, b;
        if (shoot(r, &s, &a)) {
            while (s.light_count) {
                free(s.lights[s.light_count - 1].name);
                s.light_count--;
            }
            if (shoot(r, &s, &b)) {
                size_t d = diff_bytes(&a, &b);
                note(r, "4 zero lights: %llu shadow rays; against no lights: %zu bytes differ. ",
                     (unsigned long long)a.st.shadow_rays, d);
                worst(r, (double)(a.st.shadow_rays + d));
                shot_free(&b);
            }
            shot_free(&a);
        }
    }
    rd_scene_free(&s);
}

static void run_area_zero(rd_case_result *r)
{
    rd_scene s;
    if (load(r, "area_zero.cfg", &s)) {
        shot a, b;
        if (shoot(r, &s, &a)) {
            rd_light *l = &s.lights[0];
            l->type = RD_LIGHT_POINT;
            l->position = l->corner;
            if (shoot(r, &s, &b)) {
                int maxlev;
                size_t d = diff_pixels(&a, &b, &maxlev);
                note(r,
                     "zero-area 4x4 area light against a point light at its corner: %zu pixels differ, max %d "
                     "levels. ",
                     d, maxlev);
                worst(r, maxlev);
                shot_free(&b);
            }
            shot_free(&a);
        }
    }
    rd_scene_free(&s);
}

/* ---- recursion ------------------------------------------------------------------------ */

static void run_mirror_series(rd_case_result *r)
{
    rd_scene s;
    if (!load(r, "mirrors.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    shot o;
    if (shoot(r, &s, &o)) {
        const rd_material *m = &s.materials[0];
        ld a[3] = {m->ambient.x, m->ambient.y, m->ambient.z}, k[3] = {m->ks.x, m->ks.y, m->ks.z}, want[3];
        for (int c = 0; c < 3; c++) {
            /* a·(1 + ks + ... + ks^depth), summed by hand */
            ld sum = 0, p = 1;
            for (int i = 0; i <= s.render.max_depth; i++, p *= k[c])
                sum += p;
            want[c] = a[c] * sum;
        }
        double e = 0;
        int mid_bad = 0;
        for (int y = 0; y < o.h; y++)
            for (int x = 0; x < o.w; x++) {
                const double *v = &o.img.rgb[3 * ((size_t)y * o.w + x)];
                if (x == o.w / 2) {
                    if (!(v[0] == s.render.background.x && v[1] == s.render.background.y &&
                          v[2] == s.render.background.z))
                        mid_bad++;
                    continue;
                }
                for (int c = 0; c < 3; c++) {
                    double ec = (double)(fabsl(v[c] - want[c]) / want[c]);
                    if (!(ec <= e))
                        e = ec;
                }
            }
        note(r,
             "depth %d: every bouncing pixel against a·(1 - ks^%d)/(1 - ks) = %.15Lg %.15Lg %.15Lg: max "
             "relative error %.3g; middle column (parallel): %d not background. ",
             s.render.max_depth, s.render.max_depth + 1, want[0], want[1], want[2], e, mid_bad);
        worst(r, e);
        if (mid_bad)
            r->extra_fail = 1;
        shot_free(&o);
    }
    rd_scene_free(&s);
}

static void run_mirror_rays_linear(rd_case_result *r)
{
    rd_scene s;
    if (!load(r, "mirrors.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    const int depth[] = {0, 1, 2, 4, 8, 16, 32, 64};
    uint64_t bouncing = (uint64_t)(s.render.width - 1) * (uint64_t)s.render.height;
    for (int i = 0; i < 8; i++) {
        s.render.max_depth = depth[i];
        shot o;
        if (!shoot(r, &s, &o))
            break;
        uint64_t want = bouncing * (uint64_t)depth[i];
        double e = fabs((double)o.st.secondary_rays - (double)want) + (double)o.st.shadow_rays;
        note(r, "depth %d: %llu secondary rays (%llu expected); ", depth[i], (unsigned long long)o.st.secondary_rays,
             (unsigned long long)want);
        worst(r, e);
        shot_free(&o);
    }
    rd_scene_free(&s);
}

/* Stack use: the render runs on the calling thread when threads = 1; run
 * it on a thread whose stack we painted, and find the deepest byte used. */
typedef struct {
    const rd_scene *s;
    rd_case_result *r;
    int ok;
} stack_job;

static void *stack_thread(void *arg)
{
    stack_job *j = arg;
    rd_render_options opt = {0};
    opt.threads = 1;
    rd_image img;
    rd_render_stats st;
    rd_error err = {0};
    j->ok = rd_render(j->s, &opt, &img, &st, &err) == RD_OK;
    if (j->ok)
        rd_image_free(&img);
    return NULL;
}

static size_t stack_used(rd_case_result *r, const rd_scene *s)
{
    const size_t size = (size_t)8 << 20;
    unsigned char *mem = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mem == MAP_FAILED) {
        r->error = 1;
        note(r, "mmap failed. ");
        return 0;
    }
    memset(mem, 0xA5, size);
    pthread_attr_t at;
    pthread_attr_init(&at);
    pthread_attr_setstack(&at, mem, size);
    stack_job j = {s, r, 0};
    pthread_t t;
    size_t used = 0;
    if (pthread_create(&t, &at, stack_thread, &j) == 0) {
        pthread_join(t, NULL);
        size_t i = 0;
        while (i < size && mem[i] == 0xA5)
            i++;
        used = size - i;
        r->renders++;
    } else {
        r->error = 1;
        note(r, "pthread_create failed. ");
    }
    pthread_attr_destroy(&at);
    munmap(mem, size);
    return used;
}

static void run_stack_depth(rd_case_result *r)
{
    rd_scene s;
    if (!load(r, "mirrors.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    s.render.width = 3; /* columns 0 and 2 bounce, the middle one is parallel */
    s.render.height = 1;
    s.render.max_depth = 1;
    size_t u1 = stack_used(r, &s);
    s.render.max_depth = 64;
    size_t u64 = stack_used(r, &s);
    double per = ((double)u64 - (double)u1) / 63;
    note(r,
         "stack used: %zu bytes at max_depth 1, %zu at 64 (thread descriptor and TLS included): %.0f bytes "
         "per level of recursion (rd_trace + trace_secondary frames). ",
         u1, u64, per);
    worst(r, per);
    if (u64 > ((size_t)256 << 10)) {
        r->extra_fail = 1;
        note(r, "[more than 256 KiB at depth 64] ");
    }
    rd_scene_free(&s);
}

static void run_glass_rays(rd_case_result *r)
{
    rd_scene s;
    if (!load(r, "glass_sheets.cfg", &s)) {
        rd_scene_free(&s);
        return;
    }
    const int depth[] = {4, 8, 12, 16};
    double per[4] = {0};
    for (int i = 0; i < 4; i++) {
        s.render.max_depth = depth[i];
        shot o;
        if (!shoot(r, &s, &o))
            break;
        per[i] = (double)o.st.secondary_rays / (double)o.st.camera_rays;
        note(r, "depth %d: %.1f secondary rays per camera ray; ", depth[i], per[i]);
        shot_free(&o);
    }
    if (per[1] > 0) {
        double g = per[3] / per[1];
        note(r,
             "from depth 8 to 16 the rays grow x%.2f (x%.3f per level; at that rate depth 64 would need %.2g "
             "rays per camera ray). ",
             g, pow(g, 1.0 / 8), per[3] * pow(g, 48.0 / 8));
        worst(r, g);
    }
    rd_scene_free(&s);
}

/* ---- camera ---------------------------------------------------------------------------- */

static void camera_adjust(rd_scene *s, int v)
{
    switch (v) {
    case 0: { /* fov 1e-6 degrees on the red sphere's silhouette */
        const rd_object *o = &s->objects[1];
        rd_vec3 e = v3_sub(s->camera.eye, o->center);
        double D = v3_len(e), rr = o->radius;
        rd_vec3 eh = v3_scale(e, 1 / D);
        rd_vec3 side = v3_normalize(v3_cross(v3(0.3, 1, 0.2), eh));
        s->camera.target =
            v3_add(o->center, v3_scale(v3_add(v3_scale(eh, rr / D), v3_scale(side, sqrt(1 - rr * rr / (D * D)))), rr));
        s->camera.fov_deg = 1e-6;
        break;
    }
    case 1: s->camera.fov_deg = 179.999; break;
    case 2: s->render.width = s->render.height = 1; break;
    case 3: s->render.width = 1, s->render.height = 4096; break;
    case 4: s->render.width = 4096, s->render.height = 1; break;
    }
}

static void run_camera_fov_tiny(rd_case_result *r) { ref_case(r, "camera.cfg", camera_adjust, 0, "fov 1e-6", 0); }
static void run_camera_fov_wide(rd_case_result *r) { ref_case(r, "camera.cfg", camera_adjust, 1, "fov 179.999", 0); }
static void run_camera_1x1(rd_case_result *r) { ref_case(r, "camera.cfg", camera_adjust, 2, "1x1", 0); }
static void run_camera_strips(rd_case_result *r)
{
    ref_case(r, "camera.cfg", camera_adjust, 3, "1x4096", 0);
    ref_case(r, "camera.cfg", camera_adjust, 4, "4096x1", 0);
}

/* ---- object order -------------------------------------------------------------------- */

static void order_base(rd_case_result *r, int mesh, rd_scene *s, shot *o)
{
    if (!load(r, "order.cfg", s))
        return;
    if (!mesh)
        for (size_t i = s->object_count; i-- > 0;)
            if (s->objects[i].type == RD_OBJ_MESH)
                drop_object(s, i);
    shoot(r, s, o);
}

static void run_same_sphere_twice(rd_case_result *r)
{
    for (int mesh = 1; mesh >= 0; mesh--) {
        rd_scene s;
        shot a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        order_base(r, mesh, &s, &a);
        if (a.rgb8) {
            size_t n = s.object_count;
            for (size_t i = 0; i < n; i++)
                if (s.objects[i].type == RD_OBJ_SPHERE || s.objects[i].type == RD_OBJ_TRIANGLE)
                    dup_object(&s, i);
            if (shoot(r, &s, &b)) {
                size_t d = diff_bytes(&a, &b);
                note(r, "%s mesh, every sphere and triangle twice: %zu bytes differ; ", mesh ? "with" : "without", d);
                worst(r, (double)d);
            }
        }
        shot_free(&a);
        shot_free(&b);
        rd_scene_free(&s);
    }
}

static void run_shuffled_order(rd_case_result *r)
{
    for (int mesh = 1; mesh >= 0; mesh--) {
        rd_scene s;
        shot a;
        memset(&a, 0, sizeof a);
        order_base(r, mesh, &s, &a);
        if (a.rgb8) {
            test_rng g = {0x9e3779b97f4a7c15ULL};
            size_t worst_d = 0;
            for (int perm = 0; perm < 6; perm++) {
                size_t n = s.object_count;
                if (perm == 0) {
                    for (size_t i = 0; i < n / 2; i++) {
                        rd_object t = s.objects[i];
                        s.objects[i] = s.objects[n - 1 - i];
                        s.objects[n - 1 - i] = t;
                    }
                } else {
                    for (size_t i = n - 1; i > 0; i--) {
                        size_t j = (size_t)(rng_u64(&g) % (i + 1));
                        rd_object t = s.objects[i];
                        s.objects[i] = s.objects[j];
                        s.objects[j] = t;
                    }
                }
                shot b;
                if (!shoot(r, &s, &b))
                    break;
                size_t d = diff_bytes(&a, &b);
                if (d > worst_d)
                    worst_d = d;
                worst(r, (double)d);
                shot_free(&b);
            }
            note(r, "%s mesh, reversed and 5 shuffles: at most %zu bytes differ; ", mesh ? "with" : "without", worst_d);
        }
        shot_free(&a);
        rd_scene_free(&s);
    }
}

/* ---- the table ------------------------------------------------------------------------ */

/* AddressSanitizer surrounds every local with redzones: frames grow. */
#if defined(__SANITIZE_ADDRESS__)
#define RD_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RD_ASAN 1
#endif
#endif
#ifdef RD_ASAN
#define STACK_FRAME_MAX 4096
#define STACK_NOTE "4 KiB in this AddressSanitizer build, whose redzones enlarge frames (2 KiB without)"
#else
#define STACK_FRAME_MAX 2048
#define STACK_NOTE "2 KiB (4 KiB under AddressSanitizer, whose redzones enlarge frames)"
#endif

const rd_case rd_cases[] = {
#define RD_CASE(name, group, scenes, property, unit, tolerance, why_tol, analysis, run)                                \
    {#name, group, scenes, property, unit, tolerance, why_tol, analysis, run},
#include "case_list.h"
#undef RD_CASE
};

const size_t rd_case_count = sizeof rd_cases / sizeof rd_cases[0];

const rd_case *rd_case_find(const char *name)
{
    for (size_t i = 0; i < rd_case_count; i++)
        if (strcmp(rd_cases[i].name, name) == 0)
            return &rd_cases[i];
    return NULL;
}

void rd_case_run(const rd_case *c, rd_case_result *r)
{
    memset(r, 0, sizeof *r);
    double t0 = now_ms();
    c->run(r);
    r->ms = now_ms() - t0;
    r->pass = !r->error && !r->extra_fail && r->nonfinite == 0 && r->bad_values == 0 && r->worst <= c->tolerance;
    if (r->nonfinite)
        note(r, "[%llu non-finite samples] ", (unsigned long long)r->nonfinite);
    if (r->bad_values)
        note(r, "[%llu non-finite image values] ", (unsigned long long)r->bad_values);
}
