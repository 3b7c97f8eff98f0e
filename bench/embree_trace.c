/* embree_trace: the rays of a rayd render traced by Embree 3, for the
 * bench's embree and primitives sections (bench/README.md).
 *
 *   embree_trace SCENE [--width W] [--height H] [--threads N[,N]] [--modes single,packet]
 *                [--quality low|medium|high] [--tile 8x2|4x4] [--repeat N] [--build-threads N]
 *                [--robust] [--limit-NAME N]
 *
 * The scene is read as `rayd render SCENE` reads it (rd_scene_open: the same
 * parser, overrides, limits and OBJ loader), moved into rayd's
 * camera-relative coordinates (the eye at the origin) and given to Embree:
 * spheres as RTC_GEOMETRY_TYPE_SPHERE_POINT, triangles and meshes as one
 * RTC_GEOMETRY_TYPE_TRIANGLE, an infinite plane as two triangles 10^4 scene
 * sizes across (the bench's scenes have none: their floors are triangles).
 *
 * The rays are those of `rayd render --samples 1` on a scene without mirrors
 * or glass: one camera ray per pixel through the pixel centre (rayd's own
 * pinhole camera, core/render/camera.c), and for each hit one shadow ray
 * per point, spot or directional light whose colour is not black, when
 * rayd would trace it: the light in front of the shading normal turned to
 * face the ray (and inside a spot's cone), none for pseudo_normal_color.
 * Which lights get a shadow ray is decided in double precision on the hit
 * point recomputed from the primitive Embree reports, as rayd computes it,
 * so that the decision does not depend on Embree's float t; only the rays
 * themselves are float, as Embree takes them.
 *
 * Each mode traces every ray of the frame: `single`, one ray at a time
 * (rtcIntersect1, rtcOccluded1); `packet`, 16-wide packets of 8x2 (or 4x4)
 * pixel tiles (rtcIntersect16, then one rtcOccluded16 per light with the
 * lanes that have a shadow ray for it). N threads (pthreads) take bands of
 * tile rows from a shared counter. The time covers the whole frame: camera
 * rays, traversal, the hit points, setting up the shadow rays and tracing
 * them; not the build, which is timed apart (rtcCommitScene, on one thread
 * unless --build-threads; Embree's default, not watertight triangle test
 * unless --robust).
 *
 * Prints one JSON object on stdout: the scene's primitives, the build time,
 * and for each mode and thread count the camera and shadow rays, the hits,
 * the occluded shadow rays, a checksum of every hit's object and every
 * shadow ray's answer (equal in every mode when they trace the same), the
 * seconds and Mrays/s. Exit 0; 1 usage; 2 a scene it cannot trace as rayd
 * does (area lights, mirrors, glass) or that does not load; 3 Embree failed. */
#include <embree3/rtcore.h>

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__SSE2__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

#include "camera.h"
#include "rayd/scene.h"
#include "rayd/vec3.h"
#include "scene_open.h"

enum { GEOM_SPHERES = 0, GEOM_TRIANGLES = 1 };
enum { MODE_SINGLE, MODE_PACKET };
#define MAX_THREADS 64

/* A light as rayd prepares it (core/shading/light.c), camera-relative. */
typedef struct {
    rd_light_type type;
    rd_vec3 pos, dir; /* dir unit, the way the light travels */
    double cos_cutoff;
} light;

/* Where a triangle of the Embree geometry came from: a [triangle] object
 * (face 0), a mesh object's face, or half of a plane (obj = -1 - plane). */
typedef struct {
    int32_t obj;
    uint32_t face;
} tri_ref;

typedef struct {
    const rd_scene *s;
    rd_pinhole cam;
    int width, height;
    rd_vec3 origin; /* world position of the camera-relative origin: the eye */
    light *lights;
    int nlights;
    uint32_t *sphere_obj;
    size_t nspheres;
    tri_ref *tris;
    size_t ntris, nplanes;
    rd_vec3 *plane_v;      /* 4 corners per plane, camera-relative */
    uint32_t *plane_obj;   /* the plane's object */
    unsigned char *pseudo; /* per object: pseudo_normal_color, no shadow rays */
    RTCScene scene;
    int tile_w, tile_h;
} world;

/* One float shadow ray, ready for Embree. */
typedef struct {
    float o[3], d[3], tfar;
    int light;
} sray;

typedef struct {
    _Alignas(128) uint64_t camera, shadow, hits, occluded, checksum;
} counts;

static void die(int code, const char *fmt, const char *arg)
{
    fprintf(stderr, "embree_trace: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n");
    exit(code);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static uint64_t mix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

static void on_embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    fprintf(stderr, "embree_trace: Embree error %d: %s\n", (int)code, str ? str : "");
    exit(3);
}

/* ------------------------------------------------------------ the scene */

static rd_vec3 local(const world *w, rd_vec3 p) { return v3_sub(p, w->origin); }

/* A triangle's corners in rayd's camera-relative doubles. */
static void tri_corners(const world *w, const tri_ref *t, rd_vec3 v[3])
{
    if (t->obj < 0) {
        const rd_vec3 *q = &w->plane_v[4 * (size_t)(-1 - t->obj)];
        int idx[2][3] = {{0, 1, 2}, {0, 2, 3}};
        for (int c = 0; c < 3; c++)
            v[c] = q[idx[t->face][c]];
        return;
    }
    const rd_object *o = &w->s->objects[t->obj];
    if (o->type == RD_OBJ_TRIANGLE) {
        for (int c = 0; c < 3; c++)
            v[c] = local(w, o->v[c]);
        return;
    }
    const rd_mesh *m = &w->s->meshes[o->mesh];
    for (int c = 0; c < 3; c++)
        v[c] = local(w, m->positions[m->faces[t->face].v[c]]);
}

static void prepare_lights(world *w)
{
    const rd_scene *s = w->s;
    w->lights = calloc(s->light_count + 1, sizeof *w->lights);
    if (!w->lights)
        die(3, "%s", "out of memory");
    for (size_t i = 0; i < s->light_count; i++) {
        const rd_light *l = &s->lights[i];
        if (l->type == RD_LIGHT_AREA)
            die(2, "%s",
                "an area light: rayd samples it stochastically, this harness traces point, spot and "
                "directional lights only");
        /* rayd drops a light that gives nothing. */
        if (l->color.x == 0 && l->color.y == 0 && l->color.z == 0)
            continue;
        light *lp = &w->lights[w->nlights++];
        lp->type = l->type;
        lp->pos = local(w, l->position);
        lp->dir = v3_normalize(l->direction);
        lp->cos_cutoff = cos(l->angle_deg * M_PI / 180.0);
    }
}

/* A plane as two triangles across 10^4 times the scene's extent. */
static void plane_quad(const world *w, const rd_object *o, double extent, rd_vec3 q[4])
{
    rd_vec3 n = v3_normalize(o->normal), p = local(w, o->point);
    rd_vec3 a = fabs(n.x) < 0.9 ? v3(1, 0, 0) : v3(0, 1, 0);
    rd_vec3 u = v3_normalize(v3_cross(n, a)), v = v3_cross(n, u);
    double S = 1e4 * extent;
    /* Counter-clockwise seen from the normal's side. */
    q[0] = v3_add(p, v3_add(v3_scale(u, -S), v3_scale(v, -S)));
    q[1] = v3_add(p, v3_add(v3_scale(u, S), v3_scale(v, -S)));
    q[2] = v3_add(p, v3_add(v3_scale(u, S), v3_scale(v, S)));
    q[3] = v3_add(p, v3_add(v3_scale(u, -S), v3_scale(v, S)));
    if (v3_dot(v3_cross(v3_sub(q[1], q[0]), v3_sub(q[2], q[0])), n) < 0) {
        rd_vec3 t = q[1];
        q[1] = q[3];
        q[3] = t;
    }
}

static double build_embree(world *w, RTCDevice dev, enum RTCBuildQuality quality, int robust)
{
    const rd_scene *s = w->s;
    size_t ns = 0, nt = 0, np = 0, nverts = 0;
    double extent = 1;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        const rd_material *m = &s->materials[o->material];
        if (m->type == RD_MAT_PERFECT_SPECULAR || m->type == RD_MAT_SPECULAR_REFRACTION)
            die(2, "material '%s' is a mirror or glass: rayd traces secondary rays this harness does not",
                m->name ? m->name : "?");
        if (o->type == RD_OBJ_SPHERE) {
            ns++;
            extent = fmax(extent, v3_max_abs(local(w, o->center)) + o->radius);
        } else if (o->type == RD_OBJ_PLANE) {
            np++;
            nt += 2;
            nverts += 4;
            extent = fmax(extent, v3_max_abs(local(w, o->point)));
        } else if (o->type == RD_OBJ_TRIANGLE) {
            nt++;
            nverts += 3;
            for (int c = 0; c < 3; c++)
                extent = fmax(extent, v3_max_abs(local(w, o->v[c])));
        } else {
            const rd_mesh *me = &s->meshes[o->mesh];
            nt += me->nfaces;
            nverts += me->npositions;
            for (size_t k = 0; k < me->npositions; k++)
                extent = fmax(extent, v3_max_abs(local(w, me->positions[k])));
        }
    }
    w->pseudo = calloc(s->object_count + 1, 1);
    w->sphere_obj = malloc((ns + 1) * sizeof *w->sphere_obj);
    w->tris = malloc((nt + 1) * sizeof *w->tris);
    w->plane_v = malloc((4 * np + 1) * sizeof *w->plane_v);
    w->plane_obj = malloc((np + 1) * sizeof *w->plane_obj);
    if (!w->pseudo || !w->sphere_obj || !w->tris || !w->plane_v || !w->plane_obj)
        die(3, "%s", "out of memory");
    for (size_t i = 0; i < s->object_count; i++)
        w->pseudo[i] = s->materials[s->objects[i].material].type == RD_MAT_PSEUDO_NORMAL_COLOR;

    w->scene = rtcNewScene(dev);
    rtcSetSceneBuildQuality(w->scene, quality);
    if (robust)
        rtcSetSceneFlags(w->scene, RTC_SCENE_FLAG_ROBUST);
    if (ns) {
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        float *p = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), ns);
        for (size_t i = 0; i < s->object_count; i++) {
            const rd_object *o = &s->objects[i];
            if (o->type != RD_OBJ_SPHERE)
                continue;
            rd_vec3 c = local(w, o->center);
            float *q = &p[4 * w->nspheres];
            q[0] = (float)c.x;
            q[1] = (float)c.y;
            q[2] = (float)c.z;
            q[3] = (float)o->radius;
            w->sphere_obj[w->nspheres++] = (uint32_t)i;
        }
        rtcSetGeometryBuildQuality(g, quality);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(w->scene, g, GEOM_SPHERES);
        rtcReleaseGeometry(g);
    }
    if (nt) {
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nverts);
        unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt);
        size_t nv = 0;
#define PUTV(P)                                                                                                        \
    do {                                                                                                               \
        rd_vec3 P_ = (P);                                                                                              \
        vb[3 * nv] = (float)P_.x;                                                                                      \
        vb[3 * nv + 1] = (float)P_.y;                                                                                  \
        vb[3 * nv + 2] = (float)P_.z;                                                                                  \
        nv++;                                                                                                          \
    } while (0)
        for (size_t i = 0; i < s->object_count; i++) {
            const rd_object *o = &s->objects[i];
            if (o->type == RD_OBJ_SPHERE)
                continue;
            size_t base = nv;
            if (o->type == RD_OBJ_PLANE) {
                rd_vec3 *q = &w->plane_v[4 * w->nplanes];
                plane_quad(w, o, extent, q);
                for (int c = 0; c < 4; c++)
                    PUTV(q[c]);
                unsigned idx[2][3] = {{0, 1, 2}, {0, 2, 3}};
                for (int k = 0; k < 2; k++) {
                    for (int c = 0; c < 3; c++)
                        ib[3 * w->ntris + c] = (unsigned)base + idx[k][c];
                    w->tris[w->ntris++] = (tri_ref){-1 - (int32_t)w->nplanes, (uint32_t)k};
                }
                w->plane_obj[w->nplanes++] = (uint32_t)i;
            } else if (o->type == RD_OBJ_TRIANGLE) {
                for (int c = 0; c < 3; c++) {
                    PUTV(local(w, o->v[c]));
                    ib[3 * w->ntris + c] = (unsigned)(base + c);
                }
                w->tris[w->ntris++] = (tri_ref){(int32_t)i, 0};
            } else {
                const rd_mesh *me = &s->meshes[o->mesh];
                for (size_t k = 0; k < me->npositions; k++)
                    PUTV(local(w, me->positions[k]));
                for (size_t f = 0; f < me->nfaces; f++) {
                    for (int c = 0; c < 3; c++)
                        ib[3 * w->ntris + c] = (unsigned)(base + me->faces[f].v[c]);
                    w->tris[w->ntris++] = (tri_ref){(int32_t)i, (uint32_t)f};
                }
            }
        }
#undef PUTV
        rtcSetGeometryBuildQuality(g, quality);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(w->scene, g, GEOM_TRIANGLES);
        rtcReleaseGeometry(g);
    }
    double t0 = now_s();
    rtcCommitScene(w->scene);
    return now_s() - t0;
}

/* ------------------------------------------------------------ the rays */

/* rayd's sphere test (core/geometry/sphere.c) for a ray from the origin:
 * the nearest t > 0, or 0. */
static double sphere_t(rd_vec3 c, double r, rd_vec3 d)
{
    rd_vec3 f = v3_neg(c);
    double a = v3_dot(d, d), b = v3_dot(f, d);
    rd_vec3 l = v3_sub(f, v3_scale(d, b / a));
    double disc = a * (r - v3_len(l)) * (r + v3_len(l));
    if (!(disc >= 0))
        return 0;
    double q = -b - copysign(sqrt(disc), b);
    if (q == 0)
        return 0;
    double t0 = (v3_dot(f, f) - r * r) / q, t1 = q / a;
    if (t0 > t1) {
        double t = t0;
        t0 = t1;
        t1 = t;
    }
    return t0 > 0 ? t0 : (t1 > 0 ? t1 : 0);
}

/* The shadow rays rayd traces from camera ray d's hit on (geom, prim),
 * whose distance Embree found to be tf: into out[], their number returned. */
static int shadow_rays(const world *w, rd_vec3 d, unsigned geom, unsigned prim, float tf, sray *out)
{
    rd_vec3 p, ng, n;
    double scale;
    int obj;
    if (geom == GEOM_SPHERES) {
        obj = (int)w->sphere_obj[prim];
        const rd_object *o = &w->s->objects[obj];
        rd_vec3 c = local(w, o->center);
        double t = sphere_t(c, o->radius, d);
        if (!(t > 0))
            t = tf;
        ng = v3_normalize(v3_sub(v3_scale(d, t), c));
        p = v3_add(c, v3_scale(ng, o->radius));
        n = ng;
        scale = v3_max_abs(c) + o->radius;
    } else {
        const tri_ref *tr = &w->tris[prim];
        rd_vec3 v[3];
        tri_corners(w, tr, v);
        rd_vec3 e1 = v3_sub(v[1], v[0]), e2 = v3_sub(v[2], v[0]);
        /* Barycentrics in double (Moller-Trumbore), for the hit point and
         * interpolated normals; Embree's t where the ray is parallel. */
        rd_vec3 pv = v3_cross(d, e2);
        double det = v3_dot(e1, pv), b1, b2;
        if (det != 0) {
            rd_vec3 tv = v3_neg(v[0]), qv = v3_cross(tv, e1);
            b1 = v3_dot(tv, pv) / det;
            b2 = v3_dot(d, qv) / det;
            p = v3_add(v3_add(v3_scale(v[0], 1 - b1 - b2), v3_scale(v[1], b1)), v3_scale(v[2], b2));
        } else {
            b1 = b2 = 1.0 / 3;
            p = v3_scale(d, tf);
        }
        ng = v3_normalize(v3_cross(e1, e2));
        n = ng;
        if (tr->obj >= 0) {
            obj = tr->obj;
            const rd_object *o = &w->s->objects[obj];
            rd_vec3 n0, n1, n2;
            int normals = 0;
            if (o->type == RD_OBJ_TRIANGLE && o->has_normals) {
                n0 = v3_normalize(o->n[0]);
                n1 = v3_normalize(o->n[1]);
                n2 = v3_normalize(o->n[2]);
                normals = 1;
            } else if (o->type == RD_OBJ_MESH) {
                const rd_mesh *me = &w->s->meshes[o->mesh];
                const rd_mesh_face *f = &me->faces[tr->face];
                if (f->n[0] >= 0 && f->n[1] >= 0 && f->n[2] >= 0) {
                    n0 = v3_normalize(me->normals[f->n[0]]);
                    n1 = v3_normalize(me->normals[f->n[1]]);
                    n2 = v3_normalize(me->normals[f->n[2]]);
                    normals = 1;
                }
            }
            if (normals) {
                rd_vec3 ni =
                    v3_normalize(v3_add(v3_add(v3_scale(n0, 1 - b1 - b2), v3_scale(n1, b1)), v3_scale(n2, b2)));
                if (v3_max_abs(ni) > 0)
                    n = ni;
            }
        } else {
            obj = (int)w->plane_obj[-1 - tr->obj];
        }
        scale = fmax(v3_max_abs(v[0]), fmax(v3_max_abs(v[1]), v3_max_abs(v[2])));
    }
    if (w->pseudo[obj])
        return 0;
    if (v3_dot(n, d) > 0)
        n = v3_neg(n);
    /* Off the surface along the geometric normal, toward the light: far
     * enough for Embree's float tests on a primitive of this size. */
    double eps = 1e-6 * (1 + scale + v3_max_abs(p));
    int k = 0;
    for (int i = 0; i < w->nlights; i++) {
        const light *lp = &w->lights[i];
        rd_vec3 to_light;
        int infinite = lp->type == RD_LIGHT_DIRECTIONAL;
        to_light = infinite ? v3_neg(lp->dir) : v3_sub(lp->pos, p);
        rd_vec3 L = infinite ? lp->dir : v3_normalize(v3_neg(to_light));
        if (!(v3_max_abs(L) > 0))
            continue;
        if (lp->type == RD_LIGHT_SPOT) {
            double c = v3_dot(L, lp->dir);
            if (!(c >= lp->cos_cutoff) || !(c > 0))
                continue;
        }
        if (!(-v3_dot(n, L) > 0))
            continue;
        rd_vec3 o = v3_add(p, v3_scale(ng, v3_dot(ng, to_light) < 0 ? -eps : eps));
        rd_vec3 dir = infinite ? to_light : v3_sub(lp->pos, o);
        sray *r = &out[k++];
        r->o[0] = (float)o.x;
        r->o[1] = (float)o.y;
        r->o[2] = (float)o.z;
        r->d[0] = (float)dir.x;
        r->d[1] = (float)dir.y;
        r->d[2] = (float)dir.z;
        /* Short of the light by a relative 1e-4, as rayd stops short of it. */
        r->tfar = infinite ? INFINITY : 1.0f - 1e-4f;
        r->light = i;
    }
    return k;
}

/* The scene object a primitive belongs to: the checksum is of objects, as
 * a ray through an edge that two triangles of one mesh (or of a plane)
 * share may report either of them, depending on the traversal order. */
static uint32_t object_of(const world *w, unsigned geom, unsigned prim)
{
    if (geom == GEOM_SPHERES)
        return w->sphere_obj[prim];
    const tri_ref *t = &w->tris[prim];
    return t->obj >= 0 ? (uint32_t)t->obj : w->plane_obj[-1 - t->obj];
}

static void count_hit(const world *w, counts *c, uint64_t pixel, unsigned geom, unsigned prim)
{
    c->hits++;
    c->checksum += mix64(pixel * 0x100000001b3ULL ^ ((uint64_t)object_of(w, geom, prim) << 40));
}

static void count_shadow(counts *c, uint64_t pixel, int li, int occluded)
{
    c->shadow++;
    c->occluded += (uint64_t)occluded;
    c->checksum += mix64(~pixel * 0x9e3779b97f4a7c15ULL + (uint64_t)li * 2 + (uint64_t)occluded);
}

static void camera_dir(const world *w, int x, int y, rd_vec3 *d)
{
    rd_ray r = rd_pinhole_ray(&w->cam, x + 0.5, y + 0.5);
    *d = r.d;
}

static void trace_single_band(const world *w, int y0, int y1, counts *c, sray *sr)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < w->width; x++) {
            rd_vec3 d;
            camera_dir(w, x, y, &d);
            struct RTCRayHit rh;
            rh.ray.org_x = rh.ray.org_y = rh.ray.org_z = 0;
            rh.ray.dir_x = (float)d.x;
            rh.ray.dir_y = (float)d.y;
            rh.ray.dir_z = (float)d.z;
            rh.ray.tnear = 0;
            rh.ray.tfar = INFINITY;
            rh.ray.time = 0;
            rh.ray.mask = 0xffffffffu;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(w->scene, &ctx, &rh);
            c->camera++;
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
                continue;
            uint64_t pixel = (uint64_t)y * (uint64_t)w->width + (uint64_t)x;
            count_hit(w, c, pixel, rh.hit.geomID, rh.hit.primID);
            int ns = shadow_rays(w, d, rh.hit.geomID, rh.hit.primID, rh.ray.tfar, sr);
            for (int k = 0; k < ns; k++) {
                struct RTCRay r;
                r.org_x = sr[k].o[0];
                r.org_y = sr[k].o[1];
                r.org_z = sr[k].o[2];
                r.dir_x = sr[k].d[0];
                r.dir_y = sr[k].d[1];
                r.dir_z = sr[k].d[2];
                r.tnear = 0;
                r.tfar = sr[k].tfar;
                r.time = 0;
                r.mask = 0xffffffffu;
                r.id = 0;
                r.flags = 0;
                rtcOccluded1(w->scene, &ctx, &r);
                count_shadow(c, pixel, sr[k].light, r.tfar == -INFINITY);
            }
        }
}

static void trace_packet_band(const world *w, int y0, int y1, counts *c, sray *sr)
{
    struct RTCIntersectContext ctx, sctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcInitIntersectContext(&sctx);
    struct RTCRayHit16 rh;
    struct RTCRay16 r16;
    _Alignas(64) int valid[16], svalid[16];
    rd_vec3 dirs[16];
    int nsr[16];
    uint64_t pix[16];
    int tw = w->tile_w, th = w->tile_h;
    for (int ty = y0; ty < y1; ty += th)
        for (int tx = 0; tx < w->width; tx += tw) {
            for (int i = 0; i < 16; i++) {
                int x = tx + i % tw, y = ty + i / tw;
                valid[i] = x < w->width && y < y1 ? -1 : 0;
                rd_vec3 d = v3(0, 0, -1);
                if (valid[i]) {
                    camera_dir(w, x, y, &d);
                    pix[i] = (uint64_t)y * (uint64_t)w->width + (uint64_t)x;
                }
                dirs[i] = d;
                rh.ray.org_x[i] = rh.ray.org_y[i] = rh.ray.org_z[i] = 0;
                rh.ray.dir_x[i] = (float)d.x;
                rh.ray.dir_y[i] = (float)d.y;
                rh.ray.dir_z[i] = (float)d.z;
                rh.ray.tnear[i] = 0;
                rh.ray.tfar[i] = INFINITY;
                rh.ray.time[i] = 0;
                rh.ray.mask[i] = 0xffffffffu;
                rh.ray.id[i] = (unsigned)i;
                rh.ray.flags[i] = 0;
                rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect16(valid, w->scene, &ctx, &rh);
            for (int i = 0; i < 16; i++) {
                nsr[i] = 0;
                if (!valid[i])
                    continue;
                c->camera++;
                if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID)
                    continue;
                count_hit(w, c, pix[i], rh.hit.geomID[i], rh.hit.primID[i]);
                nsr[i] = shadow_rays(w, dirs[i], rh.hit.geomID[i], rh.hit.primID[i], rh.ray.tfar[i],
                                     &sr[(size_t)i * (size_t)w->nlights]);
            }
            /* One packet per light: the lanes with a shadow ray toward it. */
            for (int l = 0; l < w->nlights; l++) {
                int any = 0;
                for (int i = 0; i < 16; i++) {
                    svalid[i] = 0;
                    const sray *s = NULL;
                    for (int k = 0; k < nsr[i]; k++)
                        if (sr[(size_t)i * (size_t)w->nlights + (size_t)k].light == l)
                            s = &sr[(size_t)i * (size_t)w->nlights + (size_t)k];
                    r16.tnear[i] = 0;
                    r16.time[i] = 0;
                    r16.mask[i] = 0xffffffffu;
                    r16.id[i] = (unsigned)i;
                    r16.flags[i] = 0;
                    if (!s) {
                        r16.org_x[i] = r16.org_y[i] = r16.org_z[i] = 0;
                        r16.dir_x[i] = r16.dir_y[i] = 0;
                        r16.dir_z[i] = -1;
                        r16.tfar[i] = 0;
                        continue;
                    }
                    svalid[i] = -1;
                    any = 1;
                    r16.org_x[i] = s->o[0];
                    r16.org_y[i] = s->o[1];
                    r16.org_z[i] = s->o[2];
                    r16.dir_x[i] = s->d[0];
                    r16.dir_y[i] = s->d[1];
                    r16.dir_z[i] = s->d[2];
                    r16.tfar[i] = s->tfar;
                }
                if (!any)
                    continue;
                rtcOccluded16(svalid, w->scene, &sctx, &r16);
                for (int i = 0; i < 16; i++)
                    if (svalid[i])
                        count_shadow(c, pix[i], l, r16.tfar[i] == -INFINITY);
            }
        }
}

typedef struct {
    const world *w;
    int mode;
    atomic_int *next;
    counts c;
} job;

static void *worker(void *arg)
{
    job *j = arg;
#if defined(__SSE2__)
    /* What Embree asks of every thread that traces. */
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    const world *w = j->w;
    sray *sr = malloc(((size_t)w->nlights + 1) * 16 * sizeof *sr);
    if (!sr)
        die(3, "%s", "out of memory");
    int band = w->tile_h;
    for (;;) {
        int y0 = atomic_fetch_add(j->next, 1) * band;
        if (y0 >= w->height)
            break;
        int y1 = y0 + band < w->height ? y0 + band : w->height;
        if (j->mode == MODE_SINGLE)
            trace_single_band(w, y0, y1, &j->c, sr);
        else
            trace_packet_band(w, y0, y1, &j->c, sr);
    }
    free(sr);
    return NULL;
}

static double trace_frame(const world *w, int mode, int threads, counts *total)
{
    static job jobs[MAX_THREADS];
    pthread_t tid[MAX_THREADS];
    atomic_int next;
    atomic_init(&next, 0);
    memset(total, 0, sizeof *total);
    double t0 = now_s();
    for (int i = 0; i < threads; i++) {
        memset(&jobs[i], 0, sizeof jobs[i]);
        jobs[i].w = w;
        jobs[i].mode = mode;
        jobs[i].next = &next;
        if (i > 0 && pthread_create(&tid[i], NULL, worker, &jobs[i]) != 0)
            die(3, "%s", "cannot start a thread");
    }
    worker(&jobs[0]);
    for (int i = 1; i < threads; i++)
        pthread_join(tid[i], NULL);
    double secs = now_s() - t0;
    for (int i = 0; i < threads; i++) {
        total->camera += jobs[i].c.camera;
        total->shadow += jobs[i].c.shadow;
        total->hits += jobs[i].c.hits;
        total->occluded += jobs[i].c.occluded;
        total->checksum += jobs[i].c.checksum;
    }
    return secs;
}

/* ------------------------------------------------------------ main */

static void usage(void)
{
    fprintf(stderr, "usage: embree_trace SCENE [--width W] [--height H] [--threads N[,N]] [--modes single,packet]\n"
                    "                    [--quality low|medium|high] [--tile 8x2|4x4] [--repeat N]\n"
                    "                    [--build-threads N] [--robust] [--limit-NAME N]\n");
    exit(1);
}

static long number(const char *text, long lo, long hi, const char *what)
{
    char *end;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi)
        die(1, "%s: expected a number in range", what);
    return v;
}

static void json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        if (*s == '"' || *s == '\\')
            printf("\\%c", *s);
        else if ((unsigned char)*s < 0x20)
            printf("\\u%04x", (unsigned char)*s);
        else
            putchar(*s);
    }
    putchar('"');
}

int main(int argc, char **argv)
{
    const char *path = NULL, *width = NULL, *height = NULL, *quality_name = "high";
    int threads[MAX_THREADS], nthreads = 0, modes[2], nmodes = 0, repeat = 1, build_threads = 1;
    int tile_w = 8, tile_h = 2, robust = 0;
    rd_scene_limits lim = rd_scene_limits_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (path)
                usage();
            path = a;
            continue;
        }
        if (!strcmp(a, "--robust")) {
            robust = 1;
            continue;
        }
        if (i + 1 >= argc)
            usage();
        const char *v = argv[++i];
        if (!strcmp(a, "--width")) {
            width = v;
        } else if (!strcmp(a, "--height")) {
            height = v;
        } else if (!strcmp(a, "--threads")) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v);
            for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ","))
                if (nthreads < MAX_THREADS)
                    threads[nthreads++] = (int)number(tok, 1, MAX_THREADS, "--threads");
        } else if (!strcmp(a, "--modes")) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v);
            for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
                if (nmodes >= 2)
                    usage();
                if (!strcmp(tok, "single"))
                    modes[nmodes++] = MODE_SINGLE;
                else if (!strcmp(tok, "packet"))
                    modes[nmodes++] = MODE_PACKET;
                else
                    die(1, "--modes: '%s' is not single or packet", tok);
            }
        } else if (!strcmp(a, "--quality")) {
            quality_name = v;
        } else if (!strcmp(a, "--tile")) {
            if (!strcmp(v, "8x2")) {
                tile_w = 8;
                tile_h = 2;
            } else if (!strcmp(v, "4x4")) {
                tile_w = tile_h = 4;
            } else {
                die(1, "--tile: '%s' is not 8x2 or 4x4", v);
            }
        } else if (!strcmp(a, "--repeat")) {
            repeat = (int)number(v, 1, 1000, "--repeat");
        } else if (!strcmp(a, "--build-threads")) {
            build_threads = (int)number(v, 0, 1024, "--build-threads");
        } else if (!strncmp(a, "--limit-", 8)) {
            size_t n;
            const rd_limit_info *info = rd_limits_info(&n), *hit = NULL;
            for (size_t k = 0; k < n; k++)
                if (!strcmp(info[k].flag, a))
                    hit = &info[k];
            if (!hit)
                die(1, "unknown limit %s", a);
            *(size_t *)((char *)&lim + hit->offset) = (size_t)number(v, 1, 0x7fffffffffffL, a);
        } else {
            usage();
        }
    }
    if (!path)
        usage();
    if (!nthreads)
        threads[nthreads++] = 1;
    if (!nmodes) {
        modes[nmodes++] = MODE_SINGLE;
        modes[nmodes++] = MODE_PACKET;
    }
    enum RTCBuildQuality quality = RTC_BUILD_QUALITY_HIGH;
    if (!strcmp(quality_name, "low"))
        quality = RTC_BUILD_QUALITY_LOW;
    else if (!strcmp(quality_name, "medium"))
        quality = RTC_BUILD_QUALITY_MEDIUM;
    else if (strcmp(quality_name, "high"))
        die(1, "--quality: '%s' is not low, medium or high", quality_name);

    /* The scene exactly as `rayd render SCENE --width W --height H
     * --samples 1` opens it. */
    rd_scene_overrides ov = {0};
    rd_error err = {0};
    if ((width && rd_override_set(&ov, "width", width, "--width", &err)) ||
        (height && rd_override_set(&ov, "height", height, "--height", &err)) ||
        rd_override_set(&ov, "samples", "1", "samples", &err))
        die(1, "%s", err.message);
    rd_scene s;
    rd_scene_init(&s);
    rd_scene_source src = {.path = path};
    rd_warnings warn = {0};
    if (rd_scene_open(&src, &ov, &lim, &s, &warn, &err) != RD_OK)
        die(2, "%s", err.message);

    world w;
    memset(&w, 0, sizeof w);
    w.s = &s;
    w.width = s.render.width;
    w.height = s.render.height;
    w.origin = s.camera.eye;
    w.tile_w = tile_w;
    w.tile_h = tile_h;
    if (rd_pinhole_make(&w.cam, &s.camera, w.width, w.height, &err) != RD_OK)
        die(2, "%s", err.message);
    prepare_lights(&w);

#if defined(__SSE2__)
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    char config[64] = "";
    if (build_threads > 0)
        snprintf(config, sizeof config, "threads=%d", build_threads);
    RTCDevice dev = rtcNewDevice(config);
    if (!dev)
        die(3, "%s", "rtcNewDevice failed");
    rtcSetDeviceErrorFunction(dev, on_embree_error, NULL);
    double build_s = build_embree(&w, dev, quality, robust);

    printf(
        "{\"embree\": \"%ld.%ld.%ld\", \"scene\": ", (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
        (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_MINOR),
        (long)rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_VERSION_PATCH));
    json_string(path);
    size_t rayd_prims = w.nspheres + w.ntris - w.nplanes; /* a plane is 1 primitive in rayd, 2 triangles here */
    printf(", \"width\": %d, \"height\": %d, \"spheres\": %zu, \"triangles\": %zu, \"planes_as_triangles\": %zu, "
           "\"rayd_primitives\": %zu, \"lights\": %d, \"quality\": \"%s\", \"robust\": %s, \"build_threads\": %d, "
           "\"native_ray16\": %s, \"tile\": \"%dx%d\", \"build_ms\": %.3f, \"runs\": [",
           w.width, w.height, w.nspheres, w.ntris, w.nplanes, rayd_prims, w.nlights, quality_name,
           robust ? "true" : "false", build_threads,
           rtcGetDeviceProperty(dev, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) ? "true" : "false", tile_w, tile_h,
           build_s * 1000.0);
    int first = 1;
    for (int rep = 0; rep < repeat; rep++)
        for (int t = 0; t < nthreads; t++)
            for (int m = 0; m < nmodes; m++) {
                counts c;
                double secs = trace_frame(&w, modes[m], threads[t], &c);
                uint64_t rays = c.camera + c.shadow;
                printf("%s{\"mode\": \"%s\", \"threads\": %d, \"camera_rays\": %llu, \"shadow_rays\": %llu, "
                       "\"rays\": %llu, \"hits\": %llu, \"occluded\": %llu, \"checksum\": \"%016llx\", "
                       "\"seconds\": %.6f, \"mrays_per_s\": %.4f}",
                       first ? "" : ", ", modes[m] == MODE_SINGLE ? "single" : "packet", threads[t],
                       (unsigned long long)c.camera, (unsigned long long)c.shadow, (unsigned long long)rays,
                       (unsigned long long)c.hits, (unsigned long long)c.occluded, (unsigned long long)c.checksum, secs,
                       secs > 0 ? (double)rays / secs / 1e6 : 0.0);
                first = 0;
                fflush(stdout);
            }
    printf("]}\n");
    rtcReleaseScene(w.scene);
    rtcReleaseDevice(dev);
    free(w.lights);
    free(w.sphere_obj);
    free(w.tris);
    free(w.plane_v);
    free(w.plane_obj);
    free(w.pseudo);
    rd_scene_free(&s);
    return 0;
}
