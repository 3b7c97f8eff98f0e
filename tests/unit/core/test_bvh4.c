/* The four-wide BVH (core/geometry/bvh4.h): its SIMD box tests accept
 * exactly the boxes the binary robust slab test (rd_bvh_box_hit) accepts,
 * with the same entry distance to the bit, in SSE2 and in AVX2; collapsing
 * keeps every primitive exactly once under boxes that contain it; the
 * occluder hint of rd_world_any_hint never changes an answer. (That the
 * world's walks find what brute force finds is test_bvh.c's.) */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bvh.h"
#include "bvh4.h"
#include "support/rng.h"
#include "support/scene_fixture.h"
#include "world.h"

/* A coordinate that is often exactly a box face, zero, or a float. */
static double coord(test_rng *r, const float *faces, int nfaces)
{
    int k = rng_int(r, 6);
    if (k == 0 && nfaces)
        return faces[rng_int(r, nfaces)];
    if (k == 1)
        return 0;
    if (k == 2)
        return (float)rng_range(r, -4, 4);
    return rng_range(r, -4, 4);
}

static void random_node(test_rng *r, rd_bvh4_node *n)
{
    memset(n, 0, sizeof *n);
    for (int i = 0; i < 4; i++) {
        int kind = rng_int(r, 8);
        for (int a = 0; a < 3; a++) {
            float x = (float)rng_range(r, -3, 3), y = (float)rng_range(r, -3, 3);
            n->lo[a][i] = fminf(x, y);
            n->hi[a][i] = kind == 1 ? n->lo[a][i] : fmaxf(x, y); /* kind 1: a point */
            if (kind == 2 && a == 1)
                n->hi[a][i] = n->lo[a][i]; /* flat in y */
            if (kind == 3) {
                n->lo[a][i] = INFINITY; /* an unused slot */
                n->hi[a][i] = -INFINITY;
            }
        }
    }
}

static double dir_comp(test_rng *r)
{
    int k = rng_int(r, 8);
    if (k == 0)
        return 0.0;
    if (k == 1)
        return -0.0;
    if (k == 2)
        return copysign(DBL_MIN / 8, rng_range(r, -1, 1)); /* subnormal: 1/d overflows */
    return rng_range(r, -1, 1);
}

static rd_bvh_ray random_ray(test_rng *r, const rd_bvh4_node *n)
{
    float faces[24];
    int nf = 0;
    for (int a = 0; a < 3; a++)
        for (int i = 0; i < 4; i++)
            if (isfinite(n->lo[a][i])) {
                faces[nf++] = n->lo[a][i];
                faces[nf++] = n->hi[a][i];
            }
    rd_ray ray;
    double ox = coord(r, faces, nf), oy = coord(r, faces, nf), oz = coord(r, faces, nf);
    ray.o = v3(ox, oy, oz);
    double dx = dir_comp(r), dy = dir_comp(r), dz = dir_comp(r);
    ray.d = v3(dx, dy, dz);
    int i = rng_int(r, 4);
    if (rng_int(r, 2) && n->lo[0][i] <= n->hi[0][i]) {
        /* Aimed at a point of a box, so that about half the boxes are hit. */
        double px = rng_range(r, n->lo[0][i], n->hi[0][i]), py = rng_range(r, n->lo[1][i], n->hi[1][i]);
        double pz = rng_range(r, n->lo[2][i], n->hi[2][i]);
        ray.d = v3_sub(v3(px, py, pz), ray.o);
    }
    return rd_bvh_ray_make(ray);
}

static double random_tmax(test_rng *r)
{
    int k = rng_int(r, 4);
    return k == 0 ? INFINITY : (k == 1 ? rng_range(r, 0, 1e-3) : rng_range(r, 0, 20));
}

/* One child of a four-wide node as the binary node rd_bvh_box_hit takes. */
static rd_bvh_node child_box(const rd_bvh4_node *n, int i)
{
    rd_bvh_node b;
    memset(&b, 0, sizeof b);
    for (int a = 0; a < 3; a++) {
        b.lo[a] = n->lo[a][i];
        b.hi[a] = n->hi[a][i];
    }
    return b;
}

typedef unsigned (*test_fn)(const rd_bvh4_node *, const rd_bvh_ray *, double, double[4]);

static unsigned call_sse2(const rd_bvh4_node *n, const rd_bvh_ray *r, double tmax, double tn[4])
{
    return rd_bvh4_test_sse2(n, r, tmax, tn);
}

__attribute__((target("avx2"))) static unsigned call_avx2(const rd_bvh4_node *n, const rd_bvh_ray *r, double tmax,
                                                          double tn[4])
{
    return rd_bvh4_test_avx2(n, r, tmax, tn);
}

static void same_as_binary(test_fn fn, const char *name)
{
    test_rng r = {0xb4b4};
    long hits = 0, misses = 0;
    for (long k = 0; k < 200000; k++) {
        rd_bvh4_node n;
        random_node(&r, &n);
        rd_bvh_ray ray = random_ray(&r, &n);
        double tmax = random_tmax(&r), tn[4];
        unsigned m = fn(&n, &ray, tmax, tn);
        for (int i = 0; i < 4; i++) {
            rd_bvh_node b = child_box(&n, i);
            double t;
            int want = rd_bvh_box_hit(&b, &ray, tmax, &t);
            cr_assert_eq((m >> i) & 1, (unsigned)want, "%s: case %ld child %d: %u, the binary test %d", name, k, i,
                         (m >> i) & 1, want);
            if (want) {
                cr_assert(memcmp(&t, &tn[i], sizeof t) == 0, "%s: case %ld child %d: entry %.17g, binary %.17g", name,
                          k, i, tn[i], t);
                hits++;
            } else {
                misses++;
            }
        }
    }
    cr_assert(hits > 80000 && misses > 80000, "%s: the cases hit %ld and miss %ld boxes", name, hits, misses);
}

Test(bvh4, sse2_test_accepts_what_the_binary_test_accepts) { same_as_binary(call_sse2, "sse2"); }

Test(bvh4, avx2_test_accepts_what_the_binary_test_accepts)
{
    if (!rd_bvh4_cpu_has_avx2()) {
        cr_log_warn("this CPU has no AVX2: the AVX2 test is not exercised");
        return;
    }
    same_as_binary(call_avx2, "avx2");
}

static void soup(rd_scene *s, int ntris, uint64_t seed)
{
    fixture_scene(s, 16, 16);
    add_material(s, RD_MAT_DIFFUSE);
    test_rng r = {seed};
    for (int i = 0; i < ntris; i++) {
        rd_vec3 c = rng_point(&r, -10, 10);
        rd_vec3 a = v3_add(c, rng_unit(&r)), b = v3_add(c, rng_unit(&r)), d = v3_add(c, rng_unit(&r));
        add_triangle(s, a, b, d, 0);
    }
    for (int i = 0; i < ntris / 10; i++)
        add_sphere(s, rng_point(&r, -10, 10), rng_range(&r, 0.01, 0.5), 0);
}

/* Walks the subtree of node, checking its boxes hold their primitives'
 * boxes, and counting how often each primitive index is reached. */
static void walk(const rd_world *w, uint32_t node, int *seen, int depth)
{
    cr_assert(depth < RD_BVH_STACK, "the four-wide tree is deeper than the binary one may be");
    const rd_bvh4_node *n = &w->bvh4.nodes[node];
    int used = 0;
    for (int i = 0; i < 4; i++) {
        if (!(n->lo[0][i] <= n->hi[0][i]))
            continue; /* unused slot */
        used++;
        if (!n->count[i]) {
            cr_assert(n->child[i] < w->bvh4.nnodes, "a child index past the nodes");
            const rd_bvh4_node *c = &w->bvh4.nodes[n->child[i]];
            for (int j = 0; j < 4; j++)
                for (int a = 0; a < 3; a++)
                    if (c->lo[a][j] <= c->hi[a][j])
                        cr_assert(c->lo[a][j] >= n->lo[a][i] && c->hi[a][j] <= n->hi[a][i],
                                  "a child's box is not inside its parent's");
            walk(w, n->child[i], seen, depth + 1);
            continue;
        }
        for (uint32_t k = 0; k < n->count[i]; k++) {
            uint32_t at = n->child[i] + k;
            cr_assert(at < w->bvh.nprims, "a leaf past the primitives");
            seen[at]++;
        }
    }
    cr_assert(used >= 1, "a node without children");
}

Test(bvh4, collapse_keeps_every_primitive_once)
{
    for (int ntris = 9; ntris <= 20000; ntris *= 7) {
        rd_scene s;
        soup(&s, ntris, (uint64_t)ntris);
        rd_world w;
        rd_error err = {0};
        cr_assert_eq(rd_world_build(&w, &s, &err), RD_OK, "%s", err.message);
        cr_assert(w.use_bvh && w.bvh4.nnodes > 0);
        int *seen = calloc(w.bvh.nprims, sizeof *seen);
        walk(&w, 0, seen, 0);
        for (size_t i = 0; i < w.bvh.nprims; i++)
            cr_assert_eq(seen[i], 1, "%d prims: leaf index %zu reached %d times", ntris, i, seen[i]);
        /* Four children a node, leaves of up to four primitives. */
        cr_assert(w.bvh4.nnodes * 4 <= w.bvh.nprims, "%zu four-wide nodes for %zu primitives", w.bvh4.nnodes,
                  w.bvh.nprims);
        free(seen);
        rd_world_free(&w);
        rd_scene_free(&s);
    }
}

Test(bvh4, occluder_hint_never_changes_the_answer)
{
    rd_scene s;
    soup(&s, 3000, 7);
    rd_world w;
    rd_error err = {0};
    cr_assert_eq(rd_world_build(&w, &s, &err), RD_OK, "%s", err.message);
    test_rng r = {99};
    uint32_t last = 0;
    long blocked = 0, hinted = 0;
    rd_ray ray = {v3(0, 0, 0), v3(1, 0, 0)};
    for (long k = 0; k < 20000; k++) {
        if (k % 8 == 0) {
            ray.o = rng_point(&r, -12, 12);
            ray.d = v3_scale(rng_unit(&r), rng_range(&r, 0.5, 8));
        } else {
            /* Neighbours, as the shadow rays of nearby pixels are. */
            ray.o = v3_add(ray.o, v3_scale(rng_unit(&r), 0.01));
        }
        double tmax = rng_range(&r, 0.5, 3);
        /* Sometimes a stale or arbitrary hint, as after another ray: any
         * leaf, any slot (inner or unused), or no node at all. */
        if (rng_int(&r, 4) == 0)
            last = rng_int(&r, 8) ? rd_world_hint((uint32_t)rng_int(&r, (int)w.bvh4.nnodes), rng_int(&r, 4))
                                  : (uint32_t)rng_u64(&r);
        uint32_t before = last;
        int want = rd_world_any(&w, ray, tmax);
        int got = rd_world_any_hint(&w, ray, tmax, &last);
        cr_assert_eq(got, want, "ray %ld: with the hint %d, without %d", k, got, want);
        if (got) {
            blocked++;
            hinted += last == before;
            /* What the hint now names blocks this ray. */
            uint32_t again = last, node = (last - 1) >> 2;
            cr_assert(last >= 1 && node < w.bvh4.nnodes && w.bvh4.nodes[node].count[(last - 1) & 3],
                      "the hint is no leaf");
            cr_assert_eq(rd_world_any_hint(&w, ray, tmax, &again), 1);
            cr_assert_eq(again, last, "a blocking hint was replaced");
        }
    }
    cr_assert(blocked > 1000 && hinted > 0, "blocked %ld rays, %ld by the hint", blocked, hinted);
    rd_world_free(&w);
    rd_scene_free(&s);
}

/* Big enough that the build splits over threads (bvh.c: PARALLEL_MIN):
 * two, three and four threads make the one-thread tree, node for node. */
Test(bvh4, threads_build_the_same_tree)
{
    rd_scene s;
    soup(&s, 60000, 5);
    rd_world w;
    rd_error err = {0};
    cr_assert_eq(rd_world_build(&w, &s, &err), RD_OK, "%s", err.message);
    size_t n = w.nspheres + w.ntris;
    rd_vec3 *lo = malloc(n * sizeof *lo), *hi = malloc(n * sizeof *hi);
    rd_world_bounds(&w, lo, hi);
    rd_bvh one;
    cr_assert_eq(rd_bvh_build(&one, lo, hi, n, &err), RD_OK);
    for (int t = 2; t <= 4; t++) {
        rd_bvh many;
        cr_assert_eq(rd_bvh_build_threads(&many, lo, hi, n, t, &err), RD_OK);
        cr_assert_eq(many.nnodes, one.nnodes, "%d threads: %zu nodes, one thread %zu", t, many.nnodes, one.nnodes);
        cr_assert(memcmp(many.nodes, one.nodes, one.nnodes * sizeof *one.nodes) == 0, "%d threads: other nodes", t);
        cr_assert(memcmp(many.prims, one.prims, n * sizeof *one.prims) == 0, "%d threads: another order", t);
        rd_bvh_free(&many);
    }
    rd_world w2;
    cr_assert_eq(rd_world_build_threads(&w2, &s, 2, &err), RD_OK);
    cr_assert(w2.bvh4.nnodes == w.bvh4.nnodes &&
                  memcmp(w2.bvh4.nodes, w.bvh4.nodes, w.bvh4.nnodes * sizeof *w.bvh4.nodes) == 0,
              "the world built on two threads walks another tree");
    rd_bvh_free(&one);
    free(lo);
    free(hi);
    rd_world_free(&w2);
    rd_world_free(&w);
    rd_scene_free(&s);
}
