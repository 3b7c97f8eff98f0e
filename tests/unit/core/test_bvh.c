/* The BVH (core/geometry/bvh.h) as the world uses it (core/geometry/world.h): rd_world_closest
 * and rd_world_any must give exactly what a brute-force loop over the same
 * primitives gives, and the tree must satisfy its invariants.
 *
 * The brute force calls rd_sphere_intersect / rd_tri_intersect on the
 * world's own spheres and tris arrays (camera-relative already), spheres
 * first, keeping the nearest t with the shrinking tmax the world uses. A
 * primitive's t does not depend on tmax, so the BVH must return the same t
 * bit for bit; the same primitive too, except where two primitives hit at
 * exactly the same t (then either is right, and the test checks that the
 * BVH's choice really hits at that t).
 *
 * Rays: random origins and directions, plus rays parallel to the axes
 * (direction components exactly +0 or -0), rays starting exactly on node
 * box faces (float bounds), and rays lying in box face planes. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bvh.h"
#include "prim.h"
#include "rayd/scene.h"
#include "sphere.h"
#include "support/rng.h"
#include "support/scene_fixture.h"
#include "triangle.h"
#include "world.h"

/* ---- scenes -------------------------------------------------------------------- */

/* Every primitive of these scenes uses material 0, the one diffuse material. */
static void bv_scene(rd_scene *s)
{
    fixture_scene(s, 64, 48);
    /* The world is relative to the eye: put it off the origin so the
     * arrays really are moved. Every value stays exact (dyadic). */
    s->camera.eye = v3(0.5, -0.25, 0.125);
    add_material(s, RD_MAT_DIFFUSE);
}

static void random_tri(rd_scene *s, test_rng *r, double extent, double size)
{
    rd_vec3 c = rng_point(r, -extent, extent);
    double sz = size * rng_range(r, 0.05, 1);
    rd_vec3 a = v3_add(c, v3_scale(rng_unit(r), sz));
    rd_vec3 b = v3_add(c, v3_scale(rng_unit(r), sz));
    rd_vec3 d = v3_add(c, v3_scale(rng_unit(r), sz));
    add_triangle(s, a, b, d, 0);
}

/* ---- brute force ----------------------------------------------------------------- */

/* Each primitive tested on its own against the caller's tmax; the nearest
 * wins (the first of equals). A conservative cull skips primitives whose
 * bounding sphere the ray's line misses by more than 1e-9 (or that lie
 * wholly behind the origin): the scenes span ~20 units, where rounding in
 * the intersectors is ~1e-14, so no primitive that could report a hit is
 * skipped. It only makes 100,000 rays x thousands of primitives
 * affordable. */
typedef struct {
    double c[3], r;
} bsphere;

#define CULL_SLACK 1e-9

static bsphere *bounding_spheres(const rd_world *w)
{
    size_t n = w->nspheres + w->ntris;
    bsphere *b = malloc(sizeof *b * (n + 1));
    cr_assert(b);
    for (size_t i = 0; i < w->nspheres; i++) {
        b[i].c[0] = w->spheres[i].c.x;
        b[i].c[1] = w->spheres[i].c.y;
        b[i].c[2] = w->spheres[i].c.z;
        b[i].r = w->spheres[i].r + CULL_SLACK;
    }
    for (size_t i = 0; i < w->ntris; i++) {
        const rd_vec3 *v = rd_world_tri(w, i)->v;
        rd_vec3 lo = v3(fmin(v[0].x, fmin(v[1].x, v[2].x)), fmin(v[0].y, fmin(v[1].y, v[2].y)),
                        fmin(v[0].z, fmin(v[1].z, v[2].z)));
        rd_vec3 hi = v3(fmax(v[0].x, fmax(v[1].x, v[2].x)), fmax(v[0].y, fmax(v[1].y, v[2].y)),
                        fmax(v[0].z, fmax(v[1].z, v[2].z)));
        rd_vec3 c = v3_scale(v3_add(lo, hi), 0.5);
        bsphere *s = &b[w->nspheres + i];
        s->c[0] = c.x;
        s->c[1] = c.y;
        s->c[2] = c.z;
        s->r = 0.5 * v3_len(v3_sub(hi, lo)) * (1 + 1e-12) + CULL_SLACK;
    }
    return b;
}

/* 1 when the ray's line passes within the bounding sphere, ahead of o. */
static inline int may_hit(const bsphere *s, rd_ray r, double dd)
{
    double wx = s->c[0] - r.o.x, wy = s->c[1] - r.o.y, wz = s->c[2] - r.o.z;
    double tc = wx * r.d.x + wy * r.d.y + wz * r.d.z;
    if (tc < 0 && tc * tc > s->r * s->r * dd * (1 + 1e-9) && wx * wx + wy * wy + wz * wz > s->r * s->r)
        return 0; /* wholly behind the origin */
    double cx = wy * r.d.z - wz * r.d.y, cy = wz * r.d.x - wx * r.d.z, cz = wx * r.d.y - wy * r.d.x;
    return cx * cx + cy * cy + cz * cz <= s->r * s->r * dd * (1 + 1e-9);
}

typedef struct {
    double t;
    int kind; /* 0 none, 1 sphere, 2 triangle */
    size_t idx;
} bf_hit;

static bf_hit brute_closest(const rd_world *w, const bsphere *bs, rd_ray r, double tmax)
{
    bf_hit b = {INFINITY, 0, 0};
    double dd = v3_dot(r.d, r.d);
    for (size_t i = 0; i < w->nspheres; i++) {
        if (!may_hit(&bs[i], r, dd))
            continue;
        double t = rd_sphere_intersect(&w->spheres[i], r, tmax);
        if (t > 0 && t < b.t) {
            b.t = t;
            b.kind = 1;
            b.idx = i;
        }
    }
    for (size_t i = 0; i < w->ntris; i++) {
        if (!may_hit(&bs[w->nspheres + i], r, dd))
            continue;
        double bary[3];
        double t = rd_tri_intersect(rd_world_tri(w, i)->v, r, tmax, bary);
        if (t > 0 && t < b.t) {
            b.t = t;
            b.kind = 2;
            b.idx = i;
        }
    }
    return b;
}

static int brute_any(const rd_world *w, const bsphere *bs, rd_ray r, double tmax)
{
    double dd = v3_dot(r.d, r.d);
    for (size_t i = 0; i < w->nspheres; i++)
        if (may_hit(&bs[i], r, dd) && rd_sphere_intersect(&w->spheres[i], r, tmax) > 0)
            return 1;
    for (size_t i = 0; i < w->ntris; i++) {
        double bary[3];
        if (may_hit(&bs[w->nspheres + i], r, dd) && rd_tri_intersect(rd_world_tri(w, i)->v, r, tmax, bary) > 0)
            return 1;
    }
    return 0;
}

/* Which primitive a scene object became. */
typedef struct {
    int kind;
    size_t idx;
} prim_ref;

static prim_ref *object_map(const rd_world *w, size_t nobjects)
{
    prim_ref *m = calloc(nobjects, sizeof *m);
    cr_assert(m);
    for (size_t i = 0; i < w->nspheres; i++)
        m[w->sphere_obj[i]] = (prim_ref){1, i};
    for (size_t i = 0; i < w->ntris; i++)
        m[rd_world_tri(w, i)->object] = (prim_ref){2, i};
    return m;
}

static double prim_t(const rd_world *w, prim_ref p, rd_ray r, double tmax)
{
    double bary[3];
    if (p.kind == 1)
        return rd_sphere_intersect(&w->spheres[p.idx], r, tmax);
    return rd_tri_intersect(rd_world_tri(w, p.idx)->v, r, tmax, bary);
}

/* ---- BVH invariants ---------------------------------------------------------------- */

static void prim_bounds(const rd_world *w, uint32_t id, double lo[3], double hi[3])
{
    if (id < w->nspheres) {
        const rd_sphere *s = &w->spheres[id];
        double c[3] = {s->c.x, s->c.y, s->c.z};
        for (int k = 0; k < 3; k++) {
            lo[k] = c[k] - s->r;
            hi[k] = c[k] + s->r;
        }
        return;
    }
    const rd_vec3 *v = rd_world_tri(w, id - w->nspheres)->v;
    double p[3][3] = {{v[0].x, v[0].y, v[0].z}, {v[1].x, v[1].y, v[1].z}, {v[2].x, v[2].y, v[2].z}};
    for (int k = 0; k < 3; k++) {
        lo[k] = fmin(p[0][k], fmin(p[1][k], p[2][k]));
        hi[k] = fmax(p[0][k], fmax(p[1][k], p[2][k]));
    }
}

static int box_contains(const rd_bvh_node *outer, const float lo[3], const float hi[3])
{
    for (int k = 0; k < 3; k++)
        if (!(outer->lo[k] <= lo[k] && hi[k] <= outer->hi[k]))
            return 0;
    return 1;
}

/* Walks the tree from the root: every node reached once, children inside
 * their parent, primitives inside their leaf, leaves partitioning prims,
 * prims a permutation of the primitive ids. Returns the depth. */
static int check_tree(const rd_world *w, const rd_bvh *b);

/* The world keeps only the binary tree's primitive order: the tree is built
 * again here from the world's bounds, on one thread and on four, which
 * must give the same tree and the world's order. */
static int check_invariants(const rd_world *w)
{
    size_t n = w->nspheres + w->ntris;
    rd_vec3 *lo = malloc(n * sizeof *lo), *hi = malloc(n * sizeof *hi);
    cr_assert(lo && hi);
    rd_world_bounds(w, lo, hi);
    rd_bvh one, four;
    rd_error err = {0};
    cr_assert_eq(rd_bvh_build(&one, lo, hi, n, &err), RD_OK, "%s", err.message);
    cr_assert_eq(rd_bvh_build_threads(&four, lo, hi, n, 4, &err), RD_OK, "%s", err.message);
    cr_assert(one.nnodes == four.nnodes && memcmp(one.nodes, four.nodes, one.nnodes * sizeof *one.nodes) == 0 &&
                  memcmp(one.prims, four.prims, n * sizeof *one.prims) == 0,
              "four threads built another tree than one");
    cr_assert(memcmp(one.prims, w->bvh.prims, n * sizeof *one.prims) == 0, "the world's primitive order differs");
    int depth = check_tree(w, &one);
    rd_bvh_free(&one);
    rd_bvh_free(&four);
    free(lo);
    free(hi);
    return depth;
}

static int check_tree(const rd_world *w, const rd_bvh *b)
{
    size_t n = w->nspheres + w->ntris;
    cr_assert(w->use_bvh, "a world of %zu primitives should use its BVH", n);
    cr_assert_eq(b->nprims, n);
    cr_assert_gt(b->nnodes, 0);
    /* prims is a permutation. */
    unsigned char *seen = calloc(n, 1), *covered = calloc(n, 1), *visited = calloc(b->nnodes, 1);
    cr_assert(seen && covered && visited);
    for (size_t i = 0; i < n; i++) {
        cr_assert_lt(b->prims[i], n, "prims[%zu] = %u out of range", i, b->prims[i]);
        cr_assert_eq(seen[b->prims[i]], 0, "primitive %u appears twice in prims", b->prims[i]);
        seen[b->prims[i]] = 1;
    }
    /* Depth-first walk with an explicit stack. */
    typedef struct {
        uint32_t node;
        int depth;
    } item;
    item *stack = malloc(sizeof *stack * (b->nnodes + 1));
    cr_assert(stack);
    size_t sp = 0;
    int maxdepth = 0;
    stack[sp++] = (item){0, 0};
    while (sp > 0) {
        item it = stack[--sp];
        cr_assert_lt(it.node, b->nnodes);
        cr_assert_eq(visited[it.node], 0, "node %u reached twice", it.node);
        visited[it.node] = 1;
        if (it.depth > maxdepth)
            maxdepth = it.depth;
        const rd_bvh_node *nd = &b->nodes[it.node];
        for (int k = 0; k < 3; k++)
            cr_assert(nd->lo[k] <= nd->hi[k], "node %u has an inverted box on axis %d", it.node, k);
        if (nd->count) {
            cr_assert_leq((size_t)nd->offset + nd->count, n, "leaf %u range past the end", it.node);
            for (uint32_t i = nd->offset; i < nd->offset + nd->count; i++) {
                cr_assert_eq(covered[i], 0, "prims slot %u in two leaves", i);
                covered[i] = 1;
                double lo[3], hi[3];
                prim_bounds(w, b->prims[i], lo, hi);
                for (int k = 0; k < 3; k++)
                    cr_assert((double)nd->lo[k] <= lo[k] && hi[k] <= (double)nd->hi[k],
                              "leaf %u axis %d box [%.9g, %.9g] does not hold primitive %u [%.17g, %.17g]", it.node, k,
                              nd->lo[k], nd->hi[k], b->prims[i], lo[k], hi[k]);
            }
        } else {
            uint32_t l = it.node + 1, r = nd->offset;
            cr_assert(l < b->nnodes && r < b->nnodes && r > it.node, "node %u: children %u, %u of %zu", it.node, l, r,
                      b->nnodes);
            cr_assert(box_contains(nd, b->nodes[l].lo, b->nodes[l].hi), "left child %u outside parent %u", l, it.node);
            cr_assert(box_contains(nd, b->nodes[r].lo, b->nodes[r].hi), "right child %u outside parent %u", r, it.node);
            stack[sp++] = (item){r, it.depth + 1};
            stack[sp++] = (item){l, it.depth + 1};
        }
    }
    for (size_t i = 0; i < b->nnodes; i++)
        cr_assert(visited[i], "node %zu unreachable", i);
    for (size_t i = 0; i < n; i++)
        cr_assert(covered[i], "prims slot %zu in no leaf", i);
    /* Traversal uses a stack of 128 entries, near-first: depth must stay
     * well below that. */
    cr_assert_lt(maxdepth, 120, "BVH depth %d", maxdepth);
    free(seen);
    free(covered);
    free(visited);
    free(stack);
    return maxdepth;
}

/* ---- ray generation ----------------------------------------------------------------- */

static const rd_vec3 axis_dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

/* A direction with some components exactly zero (of either sign). */
static rd_vec3 zeroed_dir(test_rng *r)
{
    int kind = rng_int(r, 3);
    if (kind == 0)
        return axis_dirs[rng_int(r, 6)];
    rd_vec3 d = rng_unit(r);
    double c[3] = {d.x, d.y, d.z};
    int k = rng_int(r, 3);
    c[k] = rng_int(r, 2) ? 0.0 : -0.0;
    if (kind == 2) /* two zeros, but not a unit axis: a scaled axis */
        c[(k + 1) % 3] = rng_int(r, 2) ? 0.0 : -0.0;
    if (c[0] == 0 && c[1] == 0 && c[2] == 0)
        c[(k + 2) % 3] = 1;
    return v3_normalize(v3(c[0], c[1], c[2]));
}

typedef struct {
    double lo, hi;  /* origin range */
    int face_share; /* percent of rays started on node box faces */
    int axis_share; /* percent with zero direction components */
} ray_mix;

static rd_ray make_ray(const rd_world *w, test_rng *r, const ray_mix *mix)
{
    rd_ray ray;
    int roll = rng_int(r, 100);
    if (roll < mix->face_share && w->bvh4.nnodes > 0) {
        /* On a face of a random node's box: one coordinate exactly lo or hi
         * of the float bounds, the others inside (or on) the box. */
        const rd_bvh4_node *n4 = &w->bvh4.nodes[rng_int(r, (int)w->bvh4.nnodes)];
        int slot = rng_int(r, 4);
        while (!(n4->lo[0][slot] <= n4->hi[0][slot]))
            slot = (slot + 1) % 4;
        rd_bvh_node box;
        for (int a = 0; a < 3; a++) {
            box.lo[a] = n4->lo[a][slot];
            box.hi[a] = n4->hi[a][slot];
        }
        const rd_bvh_node *nd = &box;
        int k = rng_int(r, 3);
        double o[3];
        for (int j = 0; j < 3; j++) {
            int edge = rng_int(r, 8);
            o[j] = edge == 0 ? nd->lo[j] : (edge == 1 ? nd->hi[j] : rng_range(r, nd->lo[j], nd->hi[j]));
        }
        o[k] = rng_int(r, 2) ? nd->lo[k] : nd->hi[k];
        ray.o = v3(o[0], o[1], o[2]);
        ray.d = rng_int(r, 2) ? zeroed_dir(r) : rng_unit(r);
    } else {
        ray.o = rng_point(r, mix->lo, mix->hi);
        ray.d = roll < mix->face_share + mix->axis_share ? zeroed_dir(r) : rng_unit(r);
    }
    return ray;
}

/* ---- the comparison ----------------------------------------------------------------- */

typedef struct {
    long rays, hits, ulp_order, closest_bad, any_bad;
} cmp_stats;

static void report(const char *what, long i, rd_ray r, const char *msg)
{
    cr_log_error("%s: ray %ld o = (%a, %a, %a) d = (%a, %a, %a): %s", what, i, r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z,
                 msg);
}

/* Compares rd_world_closest / rd_world_any against brute force on nrays
 * rays; logs the first mismatches and returns the counts.
 *
 * The one tolerance: rd_tri_intersect decides t < tmax as T < tmax·det
 * without dividing, and returns t = T·(1/det) rounded twice, so a
 * triangle whose own t is up to ~2 ulps below tmax can be turned away. A
 * closest-hit search that has already accepted a hit at t1 may thus keep
 * t1 over another triangle at t0 < t1 within a few ulps (coplanar,
 * overlapping triangles: a tie in exact arithmetic). Such a result is
 * accepted only when t1 <= t0 + 4 ulps and that triangle, tested with
 * tmax = t1, really is refused. Everything else must match exactly. */
static cmp_stats compare(const char *what, const rd_scene *s, const rd_world *w, test_rng *rng, long nrays,
                         const ray_mix *mix, rd_ray (*custom)(const rd_world *, test_rng *, long))
{
    cmp_stats st = {0, 0, 0, 0, 0};
    prim_ref *map = object_map(w, s->object_count);
    bsphere *bs = bounding_spheres(w);
    char msg[400];
    for (long i = 0; i < nrays; i++) {
        rd_ray r = custom ? custom(w, rng, i) : make_ray(w, rng, mix);
        double tmax = rng_int(rng, 4) == 0 ? rng_range(rng, 0.5, 30) : INFINITY;
        st.rays++;
        bf_hit bf = brute_closest(w, bs, r, tmax);
        rd_hit h;
        memset(&h, 0, sizeof h);
        int hit = rd_world_closest(w, r, tmax, &h);
        int bad = 0;
        if (hit != (bf.kind != 0)) {
            snprintf(msg, sizeof msg, "world %s, brute force %s (t = %.17g, %s %zu)", hit ? "hits" : "misses",
                     bf.kind ? "hits" : "misses", bf.t, bf.kind == 1 ? "sphere" : "triangle", bf.idx);
            bad = 1;
        } else if (hit) {
            st.hits++;
            prim_ref got = map[h.object];
            double own = prim_t(w, got, r, tmax);
            if (own != h.t) {
                snprintf(msg, sizeof msg, "world reports t = %.17g for primitive %d:%zu, which hits at %.17g", h.t,
                         got.kind, got.idx, own);
                bad = 1;
            } else if (h.t != bf.t) {
                prim_ref best = {bf.kind, bf.idx};
                int explained = bf.kind == 2 && h.t > bf.t && h.t <= bf.t + 4 * (nextafter(bf.t, INFINITY) - bf.t) &&
                                prim_t(w, best, r, h.t) == 0;
                if (explained) {
                    st.ulp_order++;
                } else {
                    snprintf(msg, sizeof msg, "t = %.17g (primitive %d:%zu), brute force %.17g (primitive %d:%zu)", h.t,
                             got.kind, got.idx, bf.t, bf.kind, bf.idx);
                    bad = 1;
                }
            } else if (got.kind != bf.kind || got.idx != bf.idx) {
                snprintf(msg, sizeof msg, "a tie at t = %.17g went to primitive %d:%zu, not the first %d:%zu", h.t,
                         got.kind, got.idx, bf.kind, bf.idx);
                bad = 1;
            }
        }
        if (bad && st.closest_bad++ < 5)
            report(what, i, r, msg);
        int any = rd_world_any(w, r, tmax), bany = brute_any(w, bs, r, tmax);
        if (any != bany && st.any_bad++ < 5) {
            snprintf(msg, sizeof msg, "rd_world_any = %d, brute force %d (tmax %.17g)", any, bany, tmax);
            report(what, i, r, msg);
        }
    }
    if (st.ulp_order)
        cr_log_info("%s: %ld hits within rounding of another (of %ld hits)", what, st.ulp_order, st.hits);
    free(bs);
    free(map);
    return st;
}

static void expect_agreement(const char *what, cmp_stats st, long min_hits)
{
    cr_assert_eq(st.closest_bad, 0, "%s: rd_world_closest disagrees with brute force on %ld of %ld rays", what,
                 st.closest_bad, st.rays);
    cr_assert_eq(st.any_bad, 0, "%s: rd_world_any disagrees with brute force on %ld of %ld rays", what, st.any_bad,
                 st.rays);
    /* Enough rays hit for the comparison to mean something. */
    cr_assert_geq(st.hits, min_hits, "%s: only %ld of %ld rays hit", what, st.hits, st.rays);
}

/* ---- packets ------------------------------------------------------------------------- */

static int same_hit(const rd_hit *a, const rd_hit *b)
{
    return a->t == b->t && a->object == b->object && a->prim == b->prim && a->prim_kind == b->prim_kind &&
           a->material == b->material && a->front == b->front && a->perr == b->perr &&
           !memcmp(&a->p, &b->p, sizeof a->p) && !memcmp(&a->n, &b->n, sizeof a->n) &&
           !memcmp(&a->ng, &b->ng, sizeof a->ng) &&
           (a->prim_kind != RD_K_TRI || !memcmp(a->bary, b->bary, sizeof a->bary));
}

/* A packet of n rays: kind 0 from one origin within a cone (camera rays;
 * some cones cross an axis, so directions differ in sign), kind 1 from the
 * hits of such a packet (or points along it) towards one point, ending
 * there (shadow rays), kind 2 unrelated rays. */
static int make_packet(const rd_world *w, test_rng *r, const ray_mix *mix, int kind, rd_ray *rays, double *tmax)
{
    int n = 1 + rng_int(r, RD_PACKET_MAX);
    rd_vec3 o = rng_point(r, mix->lo, mix->hi), axis = rng_unit(r);
    double spread = pow(10, rng_range(r, -4, 0));
    rd_vec3 to = rng_point(r, mix->lo, mix->hi);
    for (int i = 0; i < n; i++) {
        tmax[i] = INFINITY;
        if (kind == 2) {
            rays[i] = make_ray(w, r, mix);
            continue;
        }
        rd_ray c = {o, v3_normalize(v3_add(axis, v3_scale(rng_point(r, -1, 1), spread)))};
        if (rng_int(r, 8) == 0)
            c.d = v3_normalize(v3(c.d.x, rng_int(r, 2) ? 0.0 : -0.0, c.d.z));
        if (kind == 0) {
            rays[i] = c;
            continue;
        }
        rd_hit h;
        rd_vec3 p = rd_world_closest(w, c, INFINITY, &h) ? h.p : rd_ray_at(c, rng_range(r, 0, 10));
        rays[i] = (rd_ray){p, v3_sub(to, p)};
        tmax[i] = 1;
    }
    return n;
}

/* npackets of each kind, walked with every node test this CPU runs
 * (AVX-512, AVX2, SSE2: the world's flags, turned off on shallow copies);
 * returns how many rays hit, and fails on the first ray whose packet
 * answer differs from its own. */
static long expect_packets_with(const char *what, const rd_world *w, test_rng *r, int npackets, const ray_mix *mix);

static long expect_packets(const char *what, const rd_world *w, test_rng *r, int npackets, const ray_mix *mix)
{
    rd_world v = *w;
    long hits = expect_packets_with(what, &v, r, npackets, mix);
    v.avx512 = 0;
    hits += expect_packets_with(what, &v, r, npackets / 4, mix);
    v.avx2 = 0;
    return hits + expect_packets_with(what, &v, r, npackets / 4, mix);
}

static long expect_packets_with(const char *what, const rd_world *w, test_rng *r, int npackets, const ray_mix *mix)
{
    static const ray_mix whole = {-12, 12, 10, 10};
    long hits = 0;
    for (int p = 0; p < 3 * npackets; p++) {
        rd_ray rays[RD_PACKET_MAX];
        double tmax[RD_PACKET_MAX];
        int kind = p % 3, n = make_packet(w, r, mix ? mix : &whole, kind, rays, tmax);
        rd_hit hp[RD_PACKET_MAX];
        double limit = kind == 1 ? 1 : (rng_int(r, 4) == 0 ? rng_range(r, 0.5, 30) : INFINITY);
        unsigned found = rd_world_closest_packet(w, rays, n, limit, hp);
        uint32_t last_p = 0, last_s = 0;
        unsigned blocked = rd_world_any_packet(w, rays, tmax, n, rng_int(r, 2) ? &last_p : NULL);
        for (int i = 0; i < n; i++) {
            rd_hit h;
            int hit = rd_world_closest(w, rays[i], limit, &h);
            hits += hit;
            if ((found >> i & 1) != (unsigned)hit || (hit && !same_hit(&hp[i], &h))) {
                report(what, p, rays[i], "the packet's closest hit differs from the ray's own");
                cr_assert_fail("%s (avx512 %d, avx2 %d): packet kind %d, ray %d of %d: closest %s, alone %s (t %.17g / "
                               "%.17g)",
                               what, w->avx512, w->avx2, kind, i, n, found >> i & 1 ? "hit" : "missed",
                               hit ? "hit" : "missed", hp[i].t, h.t);
            }
            int any = rd_world_any_hint(w, rays[i], tmax[i], &last_s);
            if ((blocked >> i & 1) != (unsigned)any) {
                report(what, p, rays[i], "the packet's any-hit differs from the ray's own");
                cr_assert_fail("%s (avx512 %d, avx2 %d): packet kind %d, ray %d of %d: blocked %u, alone %d", what,
                               w->avx512, w->avx2, kind, i, n, blocked >> i & 1, any);
            }
        }
    }
    return hits;
}

static void build(rd_world *w, const rd_scene *s)
{
    rd_error err = {0};
    cr_assert_eq(rd_world_build(w, s, &err), RD_OK, "%s", err.message);
}

/* ---- tests ---------------------------------------------------------------------------- */

Test(bvh, random_triangle_soup)
{
    test_rng rng = {12345};
    rd_scene s;
    bv_scene(&s);
    for (int i = 0; i < 3000; i++)
        random_tri(&s, &rng, 10, 1.5);
    rd_world w;
    build(&w, &s);
    check_invariants(&w);
    ray_mix mix = {-12, 12, 10, 10};
    cmp_stats st = compare("triangle soup", &s, &w, &rng, 100000, &mix, NULL);
    expect_agreement("triangle soup", st, 20000);
    cr_assert_gt(expect_packets("triangle soup", &w, &rng, 2000, &mix), 1000, "too few packet rays hit");
    rd_world_free(&w);
    rd_scene_free(&s);
}

Test(bvh, random_spheres)
{
    test_rng rng = {777};
    rd_scene s;
    bv_scene(&s);
    for (int i = 0; i < 2500; i++)
        add_sphere(&s, rng_point(&rng, -10, 10), rng_range(&rng, 0.02, 0.6), 0);
    /* Some overlapping clusters and one big sphere enclosing many. */
    for (int i = 0; i < 200; i++)
        add_sphere(&s, v3_add(v3(3, 3, 3), v3_scale(rng_unit(&rng), 0.1)), rng_range(&rng, 0.1, 0.3), 0);
    add_sphere(&s, v3(-4, 2, 1), 3, 0);
    rd_world w;
    build(&w, &s);
    check_invariants(&w);
    ray_mix mix = {-12, 12, 10, 10};
    cmp_stats st = compare("spheres", &s, &w, &rng, 100000, &mix, NULL);
    expect_agreement("spheres", st, 20000);
    cr_assert_gt(expect_packets("spheres", &w, &rng, 2000, &mix), 1000, "too few packet rays hit");
    rd_world_free(&w);
    rd_scene_free(&s);
}

Test(bvh, degenerate_and_flat_triangles_with_spheres)
{
    test_rng rng = {4242};
    rd_scene s;
    bv_scene(&s);
    for (int i = 0; i < 800; i++)
        random_tri(&s, &rng, 8, 1.0);
    for (int i = 0; i < 300; i++) {
        /* Zero area: collinear corners, two equal, all three equal. */
        rd_vec3 a = rng_point(&rng, -8, 8), d = v3_scale(rng_unit(&rng), rng_range(&rng, 0.1, 2));
        switch (i % 3) {
        case 0: add_triangle(&s, a, v3_add(a, d), v3_add(a, v3_scale(d, 2)), 0); break;
        case 1: add_triangle(&s, a, a, v3_add(a, d), 0); break;
        default: add_triangle(&s, a, a, a, 0); break;
        }
    }
    for (int i = 0; i < 300; i++) {
        /* Needles: long, and 1e-9 .. 1e-4 wide. */
        rd_vec3 a = rng_point(&rng, -8, 8), d = v3_scale(rng_unit(&rng), rng_range(&rng, 2, 8));
        rd_vec3 e = v3_scale(rng_unit(&rng), pow(10, rng_range(&rng, -9, -4)));
        add_triangle(&s, a, v3_add(a, d), v3_add(v3_add(a, d), e), 0);
    }
    for (int i = 0; i < 600; i++) {
        /* Axis-aligned flat: all z equal (a few shared planes), and some
         * with all x equal. */
        double z = (double)(rng_int(&rng, 9) - 4);
        rd_vec3 c = rng_point(&rng, -8, 8);
        double q[6];
        for (int k = 0; k < 6; k++)
            q[k] = rng_range(&rng, -1, 1);
        if (i % 4 == 3)
            add_triangle(&s, v3(z, c.y + q[0], c.z + q[1]), v3(z, c.y + q[2], c.z + q[3]),
                         v3(z, c.y + q[4], c.z + q[5]), 0);
        else
            add_triangle(&s, v3(c.x + q[0], c.y + q[1], z), v3(c.x + q[2], c.y + q[3], z),
                         v3(c.x + q[4], c.y + q[5], z), 0);
    }
    for (int i = 0; i < 500; i++)
        add_sphere(&s, rng_point(&rng, -8, 8), rng_range(&rng, 0.05, 0.5), 0);
    rd_world w;
    build(&w, &s);
    check_invariants(&w);
    /* More axis-parallel and face-start rays here. */
    ray_mix mix = {-10, 10, 25, 25};
    cmp_stats st = compare("degenerate/flat mix", &s, &w, &rng, 100000, &mix, NULL);
    expect_agreement("degenerate/flat mix", st, 20000);
    cr_assert_gt(expect_packets("degenerate/flat mix", &w, &rng, 2000, &mix), 1000, "too few packet rays hit");
    rd_world_free(&w);
    rd_scene_free(&s);
}

/* Rays through the cluster of identical-centroid triangles. */
static rd_ray cluster_ray(const rd_world *w, test_rng *r, long i)
{
    (void)i;
    rd_vec3 c = rd_world_local(w, v3(1, 2, 3));
    rd_vec3 target = v3_add(c, v3_scale(rng_point(r, -1, 1), 0.5));
    rd_ray ray;
    ray.o = v3_add(c, v3_scale(rng_unit(r), rng_range(r, 0.2, 5)));
    ray.d = rng_int(r, 5) == 0 ? zeroed_dir(r) : v3_normalize(v3_sub(target, ray.o));
    return ray;
}

Test(bvh, ten_thousand_identical_centroids)
{
    /* Triangles c + a, c - a, c + b with |b| <= |a| per component: every
     * bounding box is centred on c = (1,2,3) exactly (dyadic values), so no
     * SAH split can separate them. */
    test_rng rng = {99};
    rd_scene s;
    bv_scene(&s);
    rd_vec3 c = v3(1, 2, 3);
    for (int i = 0; i < 10000; i++) {
        double a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = (double)(rng_int(&rng, 2048) + 1) / 1024.0; /* (0, 2] in steps of 2^-10 */
            b[k] = a[k] * (double)(rng_int(&rng, 257) - 128) / 128.0;
        }
        rd_vec3 A = v3(a[0], a[1], a[2]), B = v3(b[0], b[1], b[2]);
        add_triangle(&s, v3_add(c, A), v3_sub(c, A), v3_add(c, B), 0);
    }
    rd_world w;
    build(&w, &s);
    check_invariants(&w);
    /* Fewer rays: each brute-force query tests 10,000 triangles. */
    cmp_stats st = compare("identical centroids", &s, &w, &rng, 5000, NULL, cluster_ray);
    expect_agreement("identical centroids", st, 2500);
    cr_assert_gt(expect_packets("identical centroids", &w, &rng, 2000, NULL), 1000, "too few packet rays hit");
    /* And leaves stay small although SAH cannot split: no leaf of
     * thousands. */
    size_t biggest = 0;
    for (size_t i = 0; i < w.bvh4.nnodes; i++)
        for (int q = 0; q < 4; q++)
            if (w.bvh4.nodes[i].count[q] > biggest)
                biggest = w.bvh4.nodes[i].count[q];
    cr_assert_leq(biggest, 16, "a leaf holds %zu triangles", biggest);
    rd_world_free(&w);
    rd_scene_free(&s);
}

/* Grid-aligned geometry: corners on multiples of 1/4 (exact in float, so
 * box faces lie exactly on the triangles' edges), and axis-parallel rays
 * whose origins lie on grid planes, i.e. in box faces. This is the common
 * case of modelled meshes (cubes, voxels, floors) seen by axis-aligned
 * camera rays. */
static rd_ray grid_ray(const rd_world *w, test_rng *r, long i)
{
    (void)w;
    (void)i;
    rd_ray ray;
    double o[3];
    for (int k = 0; k < 3; k++)
        o[k] = rng_int(r, 2) ? (double)(rng_int(r, 81) - 40) / 4.0 : rng_range(r, -10, 10);
    ray.o = v3(o[0], o[1], o[2]);
    ray.d = zeroed_dir(r);
    return ray;
}

Test(bvh, grid_aligned_triangles_and_axis_rays)
{
    test_rng rng = {2024};
    rd_scene s;
    bv_scene(&s);
    s.camera.eye = v3(0, 0, 0); /* keep the grid on exact values in the world's frame */
    for (int i = 0; i < 2000; i++) {
        rd_vec3 p[3];
        double base[3];
        for (int k = 0; k < 3; k++)
            base[k] = (double)(rng_int(&rng, 73) - 36) / 4.0;
        for (int c = 0; c < 3; c++)
            p[c] = v3(base[0] + (double)rng_int(&rng, 9) / 4.0, base[1] + (double)rng_int(&rng, 9) / 4.0,
                      base[2] + (double)rng_int(&rng, 9) / 4.0);
        add_triangle(&s, p[0], p[1], p[2], 0);
    }
    rd_world w;
    build(&w, &s);
    check_invariants(&w);
    cmp_stats st = compare("grid", &s, &w, &rng, 100000, NULL, grid_ray);
    expect_agreement("grid", st, 5000);
    cr_assert_gt(expect_packets("grid", &w, &rng, 2000, NULL), 1000, "too few packet rays hit");
    rd_world_free(&w);
    rd_scene_free(&s);
}

/* The smallest cases of a ray lying in the face plane of a box: a sphere's
 * tangent ray (tangent rays count as hits, core/geometry/sphere.h) and a ray across
 * a triangle's edge, both along an axis, in worlds big enough for a BVH.
 * bvh.h: "a ray lying in a box's face counts as inside it". */
Test(bvh, ray_in_a_box_face_plane)
{
    rd_scene s;
    bv_scene(&s);
    s.camera.eye = v3(0, 0, 0);
    for (int i = 0; i < 12; i++)
        add_sphere(&s, v3(4.0 * i, 0, 0), 1, 0);
    rd_world w;
    build(&w, &s);
    bsphere *bs = bounding_spheres(&w);
    /* Tangent to the first sphere along its box face x = 1 (and x = -1). */
    double xs[] = {1, -1, 4 + 1, 8 - 1};
    for (int k = 0; k < 4; k++)
        for (int sgn = 0; sgn < 2; sgn++) {
            rd_ray r = {v3(xs[k], 0, 5), v3(sgn ? -0.0 : 0.0, 0.0, -1)};
            bf_hit bf = brute_closest(&w, bs, r, INFINITY);
            cr_assert_eq(bf.kind, 1, "the tangent ray must hit the sphere (brute force)");
            cr_assert_eq(bf.t, 5.0);
            rd_hit h;
            int hit = rd_world_closest(&w, r, INFINITY, &h);
            cr_expect(hit && h.t == 5.0, "tangent ray at x = %g, d.x = %s0: rd_world_closest %s", xs[k],
                      sgn ? "-" : "+", hit ? "hit elsewhere" : "missed");
            cr_expect_eq(rd_world_any(&w, r, INFINITY), 1, "tangent ray at x = %g, d.x = %s0: rd_world_any missed",
                         xs[k], sgn ? "-" : "+");
        }
    free(bs);
    rd_world_free(&w);
    rd_scene_free(&s);

    /* Ten unit right triangles in z = 0, side by side along y; each has an
     * edge on x = 1, the boxes' common face. A ray down -z through that
     * edge crosses the triangle (the watertight test counts edges). */
    bv_scene(&s);
    s.camera.eye = v3(0, 0, 0);
    for (int i = 0; i < 10; i++)
        add_triangle(&s, v3(0, 2.0 * i, 0), v3(1, 2.0 * i, 0), v3(1, 2.0 * i + 1, 0), 0);
    build(&w, &s);
    bs = bounding_spheres(&w);
    for (int sgn = 0; sgn < 2; sgn++) {
        rd_ray r = {v3(1, 0.25, 5), v3(sgn ? -0.0 : 0.0, 0.0, -1)};
        bf_hit bf = brute_closest(&w, bs, r, INFINITY);
        cr_assert_eq(bf.kind, 2, "the ray must cross the triangle's edge (brute force)");
        rd_hit h;
        int hit = rd_world_closest(&w, r, INFINITY, &h);
        cr_expect(hit && h.t == bf.t, "edge ray at x = 1, d.x = %s0: rd_world_closest %s", sgn ? "-" : "+",
                  hit ? "hit elsewhere" : "missed");
        cr_expect_eq(rd_world_any(&w, r, INFINITY), 1, "edge ray, d.x = %s0: rd_world_any missed", sgn ? "-" : "+");
    }
    free(bs);
    rd_world_free(&w);
    rd_scene_free(&s);
}
