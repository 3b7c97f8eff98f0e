/* The walks against their definition (tests/oracles/walk_oracle.h): every
 * closest hit, field by field and bit for bit, and every any-hit answer of
 * rd_world_closest, rd_world_any, rd_world_any_hint and the packet walks,
 * with every node test this CPU runs, equals the oracle's. A faster walk
 * (wider nodes, float boxes, another order) must pass this unchanged.
 *
 * Worlds: random soups, exact duplicates (ties decided by id, and against
 * planes), watertight grids of axis-aligned triangles (flat boxes), tiny
 * triangles far from the eye, and the same soups at 1e-120 and 1e120; the
 * bundled scenes. Rays: random, axis-parallel (signed zeros), with tiny
 * (subnormal) and huge components, scaled by 10^±150, along triangle edges
 * and in their planes (grazing), through vertices, from hit points (raw
 * and pushed off), from node box faces, and with a NaN or infinite
 * component (which hit nothing, and once looped a walk through a node's
 * empty slots until its stack overflowed). */
#include <criterion/criterion.h>
#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "oracles/walk_oracle.h"
#include "prim.h"
#include "support/load.h"
#include "support/rng.h"
#include "support/scene_fixture.h"
#include "world.h"

/* ---- worlds ---------------------------------------------------------------------- */

static rd_vec3 scaled(rd_vec3 p, double k) { return v3_scale(p, k); }

static void tri_at(rd_scene *s, test_rng *r, rd_vec3 c, double size, double k)
{
    rd_vec3 a = v3_add(c, v3_scale(rng_unit(r), size)), b = v3_add(c, v3_scale(rng_unit(r), size));
    rd_vec3 d = v3_add(c, v3_scale(rng_unit(r), size));
    add_triangle(s, scaled(a, k), scaled(b, k), scaled(d, k), 0);
}

enum { W_SOUP, W_TIES, W_GRID, W_FAR, W_SMALL, W_LARGE, W_FEW, W_KINDS };
static const char *const world_names[W_KINDS] = {"soup",         "ties",        "grid",        "far",
                                                 "scale 1e-120", "scale 1e120", "few (no BVH)"};

static void soup(rd_scene *s, test_rng *r, double k, int ntris, int nspheres)
{
    for (int i = 0; i < ntris; i++)
        tri_at(s, r, rng_point(r, -5, 5), rng_range(r, 0.05, 1.5), k);
    for (int i = 0; i < nspheres; i++)
        add_sphere(s, scaled(rng_point(r, -5, 5), k), rng_range(r, 0.05, 0.8) * k, 0);
}

/* Each primitive twice, and a plane through some triangles' corners. */
static void ties(rd_scene *s, test_rng *r)
{
    for (int i = 0; i < 40; i++) {
        rd_vec3 c = rng_point(r, -4, 4);
        if (i % 4 == 0)
            c.y = 0; /* on the plane below, up to its triangle's spread */
        tri_at(s, r, c, 1, 1);
        rd_object *o = &s->objects[s->object_count - 1];
        add_triangle(s, o->v[0], o->v[1], o->v[2], 0);
    }
    for (int i = 0; i < 12; i++) {
        rd_vec3 c = rng_point(r, -4, 4);
        double rad = rng_range(r, 0.2, 1);
        add_sphere(s, c, rad, 0);
        add_sphere(s, c, rad, 0);
    }
    add_plane(s, v3(0, 0, 0), v3(0, 1, 0), 0);
}

/* Two watertight grids of right triangles, in z = 0 and in x = 1.5: every
 * box is flat in one axis, and rays through shared edges and corners. */
static void grid(rd_scene *s)
{
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 6; j++) {
            double x = -3 + i, y = -3 + j;
            add_triangle(s, v3(x, y, 0), v3(x + 1, y, 0), v3(x + 1, y + 1, 0), 0);
            add_triangle(s, v3(x, y, 0), v3(x + 1, y + 1, 0), v3(x, y + 1, 0), 0);
            add_triangle(s, v3(1.5, x, y), v3(1.5, x + 1, y), v3(1.5, x + 1, y + 1), 0);
            add_triangle(s, v3(1.5, x, y), v3(1.5, x + 1, y + 1), v3(1.5, x, y + 1), 0);
        }
}

/* Millimetre triangles a million units from the eye. */
static void far_tiny(rd_scene *s, test_rng *r)
{
    rd_vec3 at = v3(1e6, -2e6, 5e5);
    for (int i = 0; i < 150; i++)
        tri_at(s, r, v3_add(at, rng_point(r, -0.05, 0.05)), 1e-3, 1);
    s->camera.eye = v3_add(at, v3(0.01, 0.02, 0.3));
}

/* Below the BVH's minimum: five spheres (one twice, a tie) and two
 * triangles, tested in plain loops (spheres four at a time). */
static void few(rd_scene *s, test_rng *r)
{
    for (int i = 0; i < 4; i++)
        add_sphere(s, rng_point(r, -3, 3), rng_range(r, 0.3, 1.5), 0);
    add_sphere(s, s->objects[1].center, s->objects[1].radius, 0);
    tri_at(s, r, v3(0, 0, 0), 2, 1);
    tri_at(s, r, v3(1, 1, 1), 2, 1);
}

static void make_world(rd_scene *s, rd_world *w, int kind, uint64_t seed)
{
    test_rng r = {seed};
    fixture_scene(s, 32, 24);
    s->camera.eye = v3(0.5, -0.25, 0.125);
    add_material(s, RD_MAT_DIFFUSE);
    double k = kind == W_SMALL ? 1e-120 : kind == W_LARGE ? 1e120 : 1;
    if (kind == W_SOUP || kind == W_SMALL || kind == W_LARGE)
        soup(s, &r, k, 160, 40);
    else if (kind == W_TIES)
        ties(s, &r);
    else if (kind == W_GRID)
        grid(s);
    else if (kind == W_FEW)
        few(s, &r);
    else
        far_tiny(s, &r);
    s->camera.eye = scaled(s->camera.eye, k);
    rd_error err = {0};
    cr_assert_eq(rd_world_build(w, s, &err), RD_OK, "%s: %s", world_names[kind], err.message);
    cr_assert(w->use_bvh == (kind != W_FEW), "%s: a BVH %d", world_names[kind], w->use_bvh);
}

/* ---- rays ------------------------------------------------------------------------ */

/* The world's extent (its primitives' double bounds: float boxes of a world
 * at 1e120 are infinite), for origins and scales. */
static void extent(const rd_world *w, rd_vec3 *lo, rd_vec3 *hi)
{
    *lo = v3(INFINITY, INFINITY, INFINITY);
    *hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t i = 0; i < w->nspheres + w->ntris; i++) {
        rd_vec3 a, b;
        rd_world_bounds_of(w, i, 1, &a, &b);
        *lo = v3(fmin(lo->x, a.x), fmin(lo->y, a.y), fmin(lo->z, a.z));
        *hi = v3(fmax(hi->x, b.x), fmax(hi->y, b.y), fmax(hi->z, b.z));
    }
}

static rd_vec3 in_box(test_rng *r, rd_vec3 lo, rd_vec3 hi, double grow)
{
    rd_vec3 mid = v3_scale(v3_add(lo, hi), 0.5), half = v3_scale(v3_sub(hi, lo), 0.5 * grow);
    double x = rng_range(r, -1, 1), y = rng_range(r, -1, 1), z = rng_range(r, -1, 1);
    return v3(mid.x + half.x * x, mid.y + half.y * y, mid.z + half.z * z);
}

/* Signed zeros in one or two components; a subnormal or tiny one; a huge
 * one. */
static rd_vec3 odd_dir(test_rng *r)
{
    rd_vec3 d = rng_unit(r);
    double c[3] = {d.x, d.y, d.z};
    static const double odd[] = {0.0, -0.0, 0x1p-1074, -0x1p-1074, 1e-300, -1e-300, 1e-30, 1e150, -1e150};
    int k = rng_int(r, 3);
    c[k] = odd[rng_int(r, (int)(sizeof odd / sizeof odd[0]))];
    if (rng_int(r, 3) == 0)
        c[(k + 1) % 3] = rng_int(r, 2) ? 0.0 : -0.0;
    if (c[0] == 0 && c[1] == 0 && c[2] == 0)
        c[(k + 2) % 3] = 1;
    return v3(c[0], c[1], c[2]);
}

/* A random triangle of the world, NULL when it has none. */
static const rd_wtri *some_tri(const rd_world *w, test_rng *r)
{
    return w->ntris ? rd_world_tri(w, (size_t)rng_int(r, (int)w->ntris)) : NULL;
}

static rd_ray grazing(const rd_world *w, test_rng *r, rd_vec3 lo, rd_vec3 hi)
{
    const rd_wtri *t = some_tri(w, r);
    if (!t)
        return (rd_ray){in_box(r, lo, hi, 1.5), rng_unit(r)};
    int a = rng_int(r, 3), b = (a + 1 + rng_int(r, 2)) % 3;
    rd_vec3 e = v3_sub(t->v[b], t->v[a]);
    switch (rng_int(r, 3)) {
    case 0: /* along an edge, from before its start */
        return (rd_ray){v3_sub(t->v[a], v3_scale(e, rng_range(r, 0.01, 2))), e};
    case 1: { /* in the triangle's plane, through a point of the edge */
        int c = 3 - a - b;
        rd_vec3 on = v3_add(t->v[a], v3_scale(e, rng_uniform(r)));
        rd_vec3 d = v3_sub(on, t->v[c]);
        return (rd_ray){v3_sub(t->v[c], d), d};
    }
    default: /* through a corner from anywhere */
    {
        rd_vec3 o = in_box(r, lo, hi, 1.5);
        return (rd_ray){o, v3_sub(t->v[a], o)};
    }
    }
}

/* On a face of a random node box (float bounds, exactly). */
static rd_ray from_face(const rd_world *w, test_rng *r)
{
    if (!w->bvh4.nnodes)
        return (rd_ray){rng_point(r, -3, 3), rng_unit(r)};
    const rd_bvh4_node *n = &w->bvh4.nodes[rng_int(r, (int)w->bvh4.nnodes)];
    int c = rng_int(r, 4);
    while (!(n->lo[0][c] <= n->hi[0][c]))
        c = (c + 1) % 4;
    double o[3];
    for (int a = 0; a < 3; a++)
        o[a] = rng_int(r, 3) == 0 ? n->lo[a][c] : rng_range(r, n->lo[a][c], n->hi[a][c]);
    int k = rng_int(r, 3);
    o[k] = rng_int(r, 2) ? n->lo[k][c] : n->hi[k][c];
    return (rd_ray){v3(o[0], o[1], o[2]), rng_int(r, 2) ? odd_dir(r) : rng_unit(r)};
}

/* From the point a random ray hits, raw or pushed off as shadow rays are. */
static rd_ray from_surface(const rd_world *w, test_rng *r, rd_vec3 lo, rd_vec3 hi)
{
    for (int tries = 0; tries < 8; tries++) {
        rd_ray c = {in_box(r, lo, hi, 2), rng_unit(r)};
        rd_hit h;
        if (walk_oracle_closest(w, c, INFINITY, &h) != 1)
            continue;
        rd_vec3 d = rng_unit(r);
        return (rd_ray){rng_int(r, 2) ? h.p : rd_offset_origin(&h, d), d};
    }
    return (rd_ray){in_box(r, lo, hi, 1), rng_unit(r)};
}

static rd_ray make_ray(const rd_world *w, test_rng *r)
{
    rd_vec3 lo, hi;
    extent(w, &lo, &hi);
    double span = fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z));
    rd_ray ray;
    switch (rng_int(r, 8)) {
    case 0: ray = (rd_ray){in_box(r, lo, hi, 1.5), odd_dir(r)}; break;
    case 1: ray = grazing(w, r, lo, hi); break;
    case 2: ray = from_face(w, r); break;
    case 3: ray = from_surface(w, r, lo, hi); break;
    case 4: ray = (rd_ray){v3(0, 0, 0), v3_sub(in_box(r, lo, hi, 1), v3(0, 0, 0))}; break; /* from the eye */
    default: ray = (rd_ray){in_box(r, lo, hi, 1.5), v3_scale(rng_unit(r), span)};
    }
    if (rng_int(r, 6) == 0)
        ray.d = v3_scale(ray.d, pow(10, rng_range(r, -150, 150)));
    if (rng_int(r, 40) == 0) { /* what an overflowed hit point would give */
        static const double bad[] = {NAN, INFINITY, -INFINITY};
        rd_vec3 *v = rng_int(r, 2) ? &ray.o : &ray.d;
        int k = rng_int(r, 3);
        double x = bad[rng_int(r, 3)];
        *v = v3(k == 0 ? x : v->x, k == 1 ? x : v->y, k == 2 ? x : v->z);
    }
    return ray;
}

static double make_tmax(test_rng *r, rd_ray ray, const rd_world *w)
{
    rd_vec3 lo, hi;
    switch (rng_int(r, 6)) {
    case 0:
        extent(w, &lo, &hi);
        return fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z)) * rng_uniform(r) / v3_max_abs(ray.d);
    case 1: return 1; /* a shadow ray's end */
    case 2: return 1e-300;
    default: return INFINITY;
    }
}

/* ---- the comparison -------------------------------------------------------------- */

typedef int (*closest_fn)(const rd_world *w, rd_ray r, double tmax, rd_hit *h);

typedef struct {
    long rays, hits, blocked, bad;
    int quiet; /* the control below: its differences are expected */
} tally;

static void say(const char *what, const char *variant, rd_ray r, double tmax, const char *msg)
{
    cr_log_error("%s (%s): o = (%a, %a, %a) d = (%a, %a, %a) tmax %a: %s", what, variant, r.o.x, r.o.y, r.o.z, r.d.x,
                 r.d.y, r.d.z, tmax, msg);
}

/* One ray's closest hit by f against the oracle's. */
static int closest_agrees(const rd_world *w, closest_fn f, rd_ray r, double tmax, tally *t, const char *what,
                          const char *variant)
{
    rd_hit want, got;
    memset(&want, 0, sizeof want);
    memset(&got, 0, sizeof got);
    int o = walk_oracle_closest(w, r, tmax, &want), g = f(w, r, tmax, &got);
    cr_assert_neq(o, -1, "%s: the oracle's stack overflowed", what);
    char why[300] = "";
    int ok = o == g && (!o || walk_oracle_same_hit(&got, &want, why, sizeof why));
    if (!ok) {
        if (o != g)
            snprintf(why, sizeof why, "walk %s, oracle %s (oracle t %a prim %d:%zu)", g ? "hits" : "misses",
                     o ? "hits" : "misses", want.t, want.prim_kind, want.prim);
        if (t->bad < 5 && !t->quiet)
            say(what, variant, r, tmax, why);
        t->bad++;
    }
    t->hits += o;
    return ok;
}

static void any_agrees(const rd_world *w, rd_ray r, double tmax, uint32_t *hint, tally *t, const char *what,
                       const char *variant)
{
    int o = walk_oracle_any(w, r, tmax);
    int a = rd_world_any(w, r, tmax), h = rd_world_any_hint(w, r, tmax, hint);
    if (o != a || o != h) {
        char why[120];
        snprintf(why, sizeof why, "any-hit: oracle %d, rd_world_any %d, with the hint %d", o, a, h);
        if (t->bad < 5)
            say(what, variant, r, tmax, why);
        t->bad++;
    }
    t->blocked += o;
}

/* Packets of up to RD_PACKET_MAX consecutive rays, against the oracle. */
static void packets_agree(const rd_world *w, const rd_ray *rays, const double *tmax, int n, tally *t, const char *what,
                          const char *variant)
{
    for (int first = 0; first < n; first += RD_PACKET_MAX) {
        int k = n - first < RD_PACKET_MAX ? n - first : RD_PACKET_MAX;
        rd_hit hp[RD_PACKET_MAX];
        uint32_t last = 0;
        unsigned found = rd_world_closest_packet(w, rays + first, k, tmax[first], hp);
        unsigned blocked = rd_world_any_packet(w, rays + first, tmax + first, k, &last);
        for (int i = 0; i < k; i++) {
            rd_hit want;
            memset(&want, 0, sizeof want);
            int o = walk_oracle_closest(w, rays[first + i], tmax[first], &want);
            char why[300] = "";
            if ((int)(found >> i & 1) != o || (o && !walk_oracle_same_hit(&hp[i], &want, why, sizeof why))) {
                if (!why[0])
                    snprintf(why, sizeof why, "packet closest %u, oracle %d", found >> i & 1, o);
                if (t->bad++ < 5)
                    say(what, variant, rays[first + i], tmax[first], why);
            }
            int a = walk_oracle_any(w, rays[first + i], tmax[first + i]);
            if ((int)(blocked >> i & 1) != a && t->bad++ < 5)
                say(what, variant, rays[first + i], tmax[first + i], "the packet's any-hit differs");
        }
    }
}

/* Every walk variant this CPU runs: the world's flags turned off on
 * shallow copies. */
static void compare_all(const char *what, const rd_world *w, const rd_ray *rays, const double *tmax, int n, tally *t)
{
    rd_world v = *w;
    for (int variant = 0; variant < 3; variant++) {
        if (variant == 1)
            v.avx512 = 0;
        if (variant == 2)
            v.avx2 = 0;
        if ((variant == 1 && !w->avx512) || (variant == 2 && !w->avx2))
            continue;
        const char *name = v.avx512 ? "avx512" : v.avx2 ? "avx2" : "sse2";
        uint32_t hint = 0;
        for (int i = 0; i < n; i++) {
            closest_agrees(&v, rd_world_closest, rays[i], tmax[i], t, what, name);
            any_agrees(&v, rays[i], tmax[i], &hint, t, what, name);
        }
        packets_agree(&v, rays, tmax, n, t, what, name);
    }
    t->rays += n;
}

static void expect_none_bad(const char *what, const tally *t)
{
    cr_assert_eq(t->bad, 0, "%s: %ld answers of %ld rays differ from the oracle's", what, t->bad, t->rays);
    /* Enough hits and misses, blocked and free, for the comparison to
     * mean something. */
    cr_assert_gt(t->hits, t->rays / 20, "%s: only %ld of %ld rays hit", what, t->hits, t->rays);
    cr_assert_gt(t->blocked, t->rays / 20, "%s: only %ld of %ld rays blocked", what, t->blocked, t->rays);
}

enum { NRAYS = 1500 };

Test(walk, random_worlds_and_adversarial_rays_agree_with_the_oracle)
{
    for (int kind = 0; kind < W_KINDS; kind++)
        for (uint64_t seed = 1; seed <= 3; seed++) {
            rd_scene s;
            rd_world w;
            make_world(&s, &w, kind, seed * 7919 + (uint64_t)kind);
            test_rng r = {seed * 104729 + (uint64_t)kind};
            static rd_ray rays[NRAYS];
            static double tmax[NRAYS];
            for (int i = 0; i < NRAYS; i++) {
                rays[i] = make_ray(&w, &r);
                tmax[i] = make_tmax(&r, rays[i], &w);
            }
            tally t = {0, 0, 0, 0, 0};
            char what[64];
            snprintf(what, sizeof what, "%s, seed %llu", world_names[kind], (unsigned long long)seed);
            compare_all(what, &w, rays, tmax, NRAYS, &t);
            expect_none_bad(what, &t);
            rd_world_free(&w);
            rd_scene_free(&s);
        }
}

/* Camera rays through a coarse grid of the scene's own view, and shadow
 * rays from their hits towards every point light and random points. */
static int scene_rays(const rd_scene *s, const rd_world *w, rd_ray *rays, double *tmax, int max)
{
    rd_pinhole cam;
    rd_error err = {0};
    if (rd_pinhole_make(&cam, &s->camera, 48, 36, &err))
        return 0;
    test_rng r = {42};
    int n = 0;
    for (int y = 0; y < 36 && n < max; y++)
        for (int x = 0; x < 48 && n < max; x++) {
            rd_ray c = rd_pinhole_ray(&cam, x + 0.5, y + 0.5);
            rays[n] = c;
            tmax[n++] = INFINITY;
            rd_hit h;
            if (n >= max || walk_oracle_closest(w, c, INFINITY, &h) != 1)
                continue;
            for (size_t l = 0; l < s->light_count && n < max; l++) {
                rd_vec3 to = s->lights[l].type == RD_LIGHT_DIRECTIONAL
                                 ? v3_scale(s->lights[l].direction, -1e3)
                                 : v3_sub(rd_world_local(w, s->lights[l].position), h.p);
                rd_vec3 o = rd_offset_origin(&h, to);
                rays[n] = (rd_ray){o, v3_add(to, v3_sub(h.p, o))};
                tmax[n++] = 1;
            }
            if (n < max) {
                rd_vec3 d = rng_unit(&r);
                rays[n] = (rd_ray){rd_offset_origin(&h, d), d};
                tmax[n++] = INFINITY;
            }
        }
    return n;
}

static int bundled(const char *name)
{
    size_t n = strlen(name);
    return n > 4 && !strcmp(name + n - 4, ".cfg");
}

Test(walk, bundled_scenes_agree_with_the_oracle)
{
    static const char *const dirs[] = {"scenes", "scenes/extreme", "scenes/assignments"};
    enum { MAXR = 6000 };
    static rd_ray rays[MAXR];
    static double tmax[MAXR];
    int with_bvh = 0;
    for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
        DIR *dir = opendir(dirs[d]);
        cr_assert(dir, "%s: run from the repository's root", dirs[d]);
        struct dirent *e;
        while ((e = readdir(dir))) {
            if (!bundled(e->d_name))
                continue;
            char path[512];
            snprintf(path, sizeof path, "%s/%s", dirs[d], e->d_name);
            rd_scene s;
            rd_error err = {0};
            rd_world w;
            if (load_scene(path, &s, NULL, &err) || rd_world_build(&w, &s, &err)) {
                rd_scene_free(&s); /* scenes that are errors on purpose */
                continue;
            }
            tally t = {0, 0, 0, 0, 0};
            int n = scene_rays(&s, &w, rays, tmax, MAXR);
            with_bvh += w.use_bvh;
            compare_all(path, &w, rays, tmax, n, &t);
            cr_assert_eq(t.bad, 0, "%s: %ld answers of %ld rays differ from the oracle's", path, t.bad, t.rays);
            rd_world_free(&w);
            rd_scene_free(&s);
        }
        closedir(dir);
    }
    cr_assert_geq(with_bvh, 4, "only %d bundled scenes have a BVH", with_bvh);
}

/* The comparison has teeth: a search that gives ties to the higher id
 * must be caught on the world of duplicates. */
static int ties_to_the_higher_id(const rd_world *w, rd_ray r, double tmax, rd_hit *h)
{
    rd_best b = rd_best_make(tmax);
    rd_world_planes_closest(w, r, &b);
    rd_tri_ray tr = rd_tri_ray_make(r);
    for (size_t i = w->nspheres + w->ntris; i-- > 0;) {
        uint32_t id = (uint32_t)i;
        double bary[3], t = id < w->nspheres
                                ? rd_sphere_intersect(&w->spheres[id], r, b.limit)
                                : rd_tri_intersect_ray(rd_world_tri(w, id - w->nspheres)->v, &tr, b.limit, bary);
        if (t > 0 && t < b.limit && (t < b.t || b.kind == RD_K_NONE)) {
            rd_best_set(&b, t, id < w->nspheres ? RD_K_SPHERE : RD_K_TRI,
                        id < w->nspheres ? id : rd_world_tri_slot(w, id - w->nspheres), id);
            if (id >= w->nspheres)
                memcpy(b.bary, bary, sizeof bary);
        }
    }
    if (b.kind == RD_K_NONE)
        return 0;
    rd_world_finish_hit(w, r, &b, h);
    return 1;
}

Test(walk, the_comparison_catches_a_wrong_tie_rule)
{
    rd_scene s;
    rd_world w;
    make_world(&s, &w, W_TIES, 5);
    test_rng r = {11};
    tally t = {0, 0, 0, 0, 1};
    for (int i = 0; i < NRAYS; i++) {
        rd_ray ray = {in_box(&r, v3(-6, -6, -6), v3(6, 6, 6), 1), rng_unit(&r)};
        closest_agrees(&w, ties_to_the_higher_id, ray, INFINITY, &t, "ties to the higher id", "brute force");
    }
    cr_assert_gt(t.bad, 20, "a wrong tie rule went unseen: %ld of %ld hits differ", t.bad, t.hits);
    rd_world_free(&w);
    rd_scene_free(&s);
}

/* The leaf order is only a layout: every position of bvh.prims holds the
 * record of the primitive it names, a triangle's with its corners and its
 * object, a sphere's centre and radius, and rd_world_tri finds each scene
 * triangle where it went, in worlds of triangles alone (moved in place)
 * and of both kinds. */
static void check_layout(const rd_scene *s, const rd_world *w, const char *what)
{
    size_t k = 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->type != RD_OBJ_TRIANGLE)
            continue;
        const rd_wtri *t = rd_world_tri(w, k++);
        for (int c = 0; c < 3; c++) {
            rd_vec3 want = rd_world_local(w, o->v[c]);
            cr_assert(memcmp(&t->v[c], &want, sizeof want) == 0 && t->object == (int32_t)i,
                      "%s: triangle %zu: corner %d or object %d", what, k - 1, c, t->object);
        }
    }
    cr_assert_eq(k, w->ntris, "%s", what);
    for (size_t p = 0; p < w->bvh.nprims; p++) {
        uint32_t id = w->bvh.prims[p];
        if (id >= w->nspheres) {
            cr_assert_eq(rd_world_tri_slot(w, id - w->nspheres), p - w->tri_first, "%s: position %zu", what, p);
            continue;
        }
        const double *x = w->sph + (p - w->sph_first);
        const rd_sphere *sp = &w->spheres[id];
        cr_assert(x[0] == sp->c.x && x[w->sph_n] == sp->c.y && x[2 * w->sph_n] == sp->c.z && x[3 * w->sph_n] == sp->r,
                  "%s: sphere at position %zu", what, p);
    }
}

Test(walk, the_leaf_order_keeps_every_record)
{
    const int kinds[] = {W_SOUP, W_TIES, W_GRID, W_FAR};
    for (size_t i = 0; i < sizeof kinds / sizeof *kinds; i++) {
        rd_scene s;
        rd_world w;
        make_world(&s, &w, kinds[i], 3 + i);
        cr_assert(w.tri_pos != NULL, "%s", world_names[kinds[i]]);
        check_layout(&s, &w, world_names[kinds[i]]);
        rd_world_free(&w);
        rd_scene_free(&s);
    }
}
