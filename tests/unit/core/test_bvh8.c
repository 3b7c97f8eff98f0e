/* The eight-wide float box test (core/geometry/bvh8.h) against the robust
 * double slab test (rd_bvh_box_hit) it filters for: every box the double
 * test accepts, the float test accepts, with an entry at or before the
 * double one; empty slots never. Rays and boxes are adversarial: boxes
 * touching the origin, flat, a point, tiny and far away, origins of
 * magnitude 1e6, grazing rays along box faces, directions with tiny and
 * huge components. Rays the float test cannot cover must say so. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "bvh4.h"
#include "bvh8.h"
#include "support/rng.h"

static double coord(test_rng *r, double scale, double at)
{
    switch (rng_int(r, 6)) {
    case 0: return at;
    case 1: return at + (float)rng_range(r, -scale, scale);
    default: return at + rng_range(r, -scale, scale);
    }
}

/* A node of eight boxes around `at`, of size about scale, with its R. */
static void random_node(test_rng *r, rd_bvh8_node *n, rd_bvh8 *t, double scale, rd_vec3 at)
{
    memset(n, 0, sizeof *n);
    const double c[3] = {at.x, at.y, at.z};
    for (int i = 0; i < 8; i++) {
        int kind = rng_int(r, 8);
        for (int a = 0; a < 3; a++) {
            float x = (float)coord(r, scale, c[a]), y = (float)coord(r, scale, c[a]);
            n->lo[a][i] = fminf(x, y);
            n->hi[a][i] = kind == 1 ? n->lo[a][i] : fmaxf(x, y); /* a point */
            if (kind == 2 && a == 1)
                n->hi[a][i] = n->lo[a][i]; /* flat in y */
            if (kind == 3 && a == 0)
                n->lo[a][i] = fminf(0, n->hi[a][i]); /* reaching the origin's plane */
            if (kind == 4) {
                n->lo[a][i] = INFINITY; /* unused */
                n->hi[a][i] = -INFINITY;
            }
        }
    }
    for (int a = 0; a < 3; a++) {
        t->r[a] = 0;
        for (int i = 0; i < 8; i++)
            if (n->lo[a][i] <= n->hi[a][i])
                t->r[a] = fmax(t->r[a], fmax(fabs((double)n->lo[a][i]), fabs((double)n->hi[a][i])));
    }
}

static rd_ray random_ray(test_rng *r, const rd_bvh8_node *n, double scale, rd_vec3 at)
{
    rd_ray ray = {v3_add(at, v3_scale(rng_point(r, -2, 2), scale)), rng_unit(r)};
    int i = rng_int(r, 8), roll = rng_int(r, 6);
    if (roll == 0 && n->lo[0][i] <= n->hi[0][i]) { /* on a face of box i */
        double o[3];
        for (int a = 0; a < 3; a++)
            o[a] = rng_range(r, n->lo[a][i], n->hi[a][i]);
        int k = rng_int(r, 3);
        o[k] = rng_int(r, 2) ? n->lo[k][i] : n->hi[k][i];
        ray.o = v3(o[0], o[1], o[2]);
    } else if (roll == 1 && n->lo[0][i] <= n->hi[0][i]) { /* at a corner of box i, grazing */
        ray.o = v3(n->lo[0][i], n->lo[1][i], n->lo[2][i]);
        ray.d = v3(0x1p-40, 1, rng_range(r, -1e-9, 1e-9));
        ray.o = v3_sub(ray.o, v3_scale(ray.d, rng_range(r, 0, 2 * scale)));
    } else if (roll == 2) {
        double k = pow(2, rng_range(r, -90, 90));
        ray.d = v3(ray.d.x * k, ray.d.y, ray.d.z / k);
    }
    return ray;
}

/* Compiled for AVX2, as the walks that use the test are. */
__attribute__((target("avx2"))) static void float_against_double(void);

Test(bvh8, the_float_test_accepts_what_the_double_test_accepts)
{
    if (!rd_bvh4_cpu_has_avx2())
        cr_skip_test("this CPU has no AVX2: its walks never run the float test");
    float_against_double();
}

__attribute__((target("avx2"))) static void float_against_double(void)
{
    static const double scales[] = {1, 1e-3, 1e3, 1e-30};
    static const rd_vec3 ats[] = {{0, 0, 0}, {1e6, -1e6, 3e5}, {0.5, 0.25, -0.125}};
    test_rng r = {8};
    long covered = 0, accepted = 0, total = 0;
    for (int round = 0; round < 4000; round++) {
        double scale = scales[rng_int(&r, 4)];
        rd_vec3 at = ats[rng_int(&r, 3)];
        rd_bvh8_node n;
        rd_bvh8 t = {NULL, 0, {0, 0, 0}};
        random_node(&r, &n, &t, scale, at);
        for (int k = 0; k < 25; k++) {
            rd_ray ray = random_ray(&r, &n, scale, at);
            rd_bvh_ray br = rd_bvh_ray_make(ray);
            rd_bvh8_ray q;
            total++;
            if (!rd_bvh8_ray_make(&t, &br, &q)) {
                cr_assert(br.flat[0] || br.flat[1] || br.flat[2] || fabs(br.inv.x) > 0x1p100 ||
                              fabs(br.inv.y) > 0x1p100 || fabs(br.inv.z) > 0x1p100 || fabs(br.inv.x) < 0x1p-100 ||
                              fabs(br.inv.y) < 0x1p-100 || fabs(br.inv.z) < 0x1p-100,
                          "round %d: a ray the float test could take was turned away", round);
                continue;
            }
            covered++;
            double tmax = rng_int(&r, 3) ? INFINITY : rng_range(&r, 0, 4 * scale);
            float tn[8];
            unsigned m = rd_bvh8_test(&n, &q, rd_float_out(tmax, 1), tn);
            for (int i = 0; i < 8; i++) {
                double t0;
                rd_bvh_node box;
                for (int a = 0; a < 3; a++) {
                    box.lo[a] = n.lo[a][i];
                    box.hi[a] = n.hi[a][i];
                }
                int empty = n.lo[0][i] == INFINITY;
                int d = !empty && rd_bvh_box_hit(&box, &br, tmax, &t0);
                accepted += d;
                cr_assert(!(empty && (m >> i & 1)), "round %d: the empty slot %d was accepted", round, i);
                cr_assert(
                    !d || (m >> i & 1),
                    "round %d, box %d: the double test accepts (t0 %a), the float test does not; o = (%a, %a, %a) "
                    "d = (%a, %a, %a) tmax %a",
                    round, i, t0, ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, tmax);
                cr_assert(!d || (double)tn[i] <= t0, "round %d, box %d: float entry %a after the double one %a", round,
                          i, (double)tn[i], t0);
            }
        }
    }
    /* Most rays are the float test's, and it was asked about many boxes
     * the double test accepts. */
    cr_assert_gt(covered, total * 8 / 10, "only %ld of %ld rays covered", covered, total);
    cr_assert_gt(accepted, total / 2, "only %ld accepted boxes in %ld rays", accepted, total);
}

/* rd_float_out rounds outward: the float below (or above) x, or x itself. */
Test(bvh8, outward_rounding)
{
    test_rng r = {3};
    for (int i = 0; i < 100000; i++) {
        double x = rng_range(&r, -1, 1) * pow(2, rng_range(&r, -140, 120));
        if (i % 7 == 0)
            x = (float)x;
        float lo = rd_float_out(x, 0), hi = rd_float_out(x, 1);
        cr_assert((double)lo <= x && (double)hi >= x, "%a: %a, %a", x, (double)lo, (double)hi);
        cr_assert(nextafterf(lo, INFINITY) > x || (double)lo == x, "%a: %a is not the float below", x, (double)lo);
        cr_assert(nextafterf(hi, -INFINITY) < x || (double)hi == x, "%a: %a is not the float above", x, (double)hi);
    }
}
