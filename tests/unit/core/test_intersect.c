/* Unit tests for ray-primitive intersection: spheres and planes
 * (core/geometry/sphere.h, plane.h) with their fill_hit and uv functions,
 * triangles through the world the renderer traces (world.h:
 * rd_world_closest, rd_world_hit_uv, rd_world_any), and rd_offset_origin
 * (ray.h).
 *
 * Exact t values come from geometry chosen so that the arithmetic is exact
 * (integers, halves, Pythagorean triples). The randomized tests draw from
 * the fixed-seed generator of tests/support/rng.h, so they are reproducible
 * and do not depend on the core's sampler. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "plane.h"
#include "ray.h"
#include "sphere.h"
#include "support/assert.h"
#include "support/rng.h"
#include "support/scene_fixture.h"
#include "world.h"

/* A unit direction d with d·n = sign·c (c in (0, 1]), otherwise random. */
static rd_vec3 dir_with_cos(test_rng *g, rd_vec3 n, double c)
{
    rd_vec3 t;
    do {
        rd_vec3 r = rng_unit(g);
        t = v3_sub(r, v3_scale(n, v3_dot(r, n)));
    } while (v3_len(t) < 1e-3);
    t = v3_normalize(t);
    return v3_normalize(v3_add(v3_scale(n, c), v3_scale(t, sqrt(fmax(0, 1 - c * c)))));
}

/* A random direction on the side of n: mostly uniform, one in four grazing
 * with cos down to 1e-16 (the hard case for self-intersection). */
static rd_vec3 outward_dir(test_rng *g, rd_vec3 n)
{
    if (rng_uniform(g) < 0.25)
        return dir_with_cos(g, n, pow(10, rng_range(g, -16, -1)));
    rd_vec3 d = rng_unit(g);
    double dn = v3_dot(d, n);
    if (dn == 0)
        return n;
    return dn > 0 ? d : v3_neg(d);
}

static rd_ray ray_of(rd_vec3 o, rd_vec3 d)
{
    rd_ray r;
    r.o = o;
    r.d = d;
    return r;
}

/* ======================================================================= */
/* Sphere                                                                  */
/* ======================================================================= */

Test(intersect, sphere_head_on_exact_t)
{
    /* Unit sphere at (0,0,-5), ray from the origin along -z: enters at z=-4. */
    rd_sphere s = {v3(0, 0, -5), 1};
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 0, -1)), INFINITY), 4.0);
    /* A non-unit direction scales t: |d| = 2 gives t = 2. */
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 0, -2)), INFINITY), 2.0);
    /* Off axis at x = 0.6: z = -5 + sqrt(1 - 0.36) = -4.2, t = 4.2 (rounding of 0.6, 0.8 only). */
    assert_near(rd_sphere_intersect(&s, ray_of(v3(0.6, 0, 0), v3(0, 0, -1)), INFINITY), 4.2, 8 * DBL_EPSILON * 4.2);
    /* Radius 3 at (4, 0, 0) seen along +x from the origin: t = 1. */
    rd_sphere s3 = {v3(4, 0, 0), 3};
    cr_assert_eq(rd_sphere_intersect(&s3, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 1.0);
}

Test(intersect, sphere_fill_hit_values)
{
    rd_sphere s = {v3(0, 0, -5), 1};
    rd_ray r = ray_of(v3(0.6, 0, 0), v3(0, 0, -1));
    rd_hit h = {0};
    h.t = rd_sphere_intersect(&s, r, INFINITY);
    rd_sphere_fill_hit(&s, r, &h);
    rd_sphere_uv(&s, &h);
    /* Hit (0.6, 0, -4.2), outward normal (0.6, 0, 0.8). */
    assert_vec_near(h.p, 0.6, 0, -4.2, 1e-14);
    assert_vec_near(h.ng, 0.6, 0, 0.8, 1e-14);
    cr_assert(h.perr > 0 && h.perr < 1e-13, "perr = %g: should be a few ulps of |c| + r = 6", h.perr);
    /* u = 0.5 + atan2(n.z, n.x)/(2π), v = acos(n.y)/π (shading.md). */
    assert_near(h.u, 0.5 + atan2(0.8, 0.6) / (2 * M_PI), 1e-14);
    assert_near(h.v, 0.5, 1e-14);
    /* Head-on: n = (0,0,1): u = 0.5 + (π/2)/(2π) = 0.75, v = acos(0)/π = 0.5. */
    r = ray_of(v3(0, 0, 0), v3(0, 0, -1));
    h.t = rd_sphere_intersect(&s, r, INFINITY);
    rd_sphere_fill_hit(&s, r, &h);
    rd_sphere_uv(&s, &h);
    assert_vec_near(h.p, 0, 0, -4, 0);
    assert_vec_near(h.ng, 0, 0, 1, 0);
    assert_near(h.u, 0.75, 1e-15);
    assert_near(h.v, 0.5, 1e-15);
    /* Top pole from above: n = (0,1,0), v = acos(1)/π = 0. */
    r = ray_of(v3(0, 5, -5), v3(0, -1, 0));
    h.t = rd_sphere_intersect(&s, r, INFINITY);
    cr_assert_eq(h.t, 4.0);
    rd_sphere_fill_hit(&s, r, &h);
    rd_sphere_uv(&s, &h);
    assert_vec_near(h.ng, 0, 1, 0, 0);
    assert_near(h.v, 0, 0);
}

Test(intersect, sphere_tangent_ray_counts_as_hit)
{
    /* The line x = 1 touches the unit sphere at (1, 0, -5): one hit at t = 5. */
    rd_sphere s = {v3(0, 0, -5), 1};
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(1, 0, 0), v3(0, 0, -1)), INFINITY), 5.0);
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, -1, 0), v3(0, 0, -1)), INFINITY), 5.0);
    /* Radius 0.5 (exact), tangent along -x at y = 0.5. */
    rd_sphere h = {v3(-3, 0, 0), 0.5};
    cr_assert_eq(rd_sphere_intersect(&h, ray_of(v3(0, 0.5, 0), v3(-1, 0, 0)), INFINITY), 3.0);
    /* One ulp further out misses, one ulp in hits. */
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(nextafter(1, 2), 0, 0), v3(0, 0, -1)), INFINITY), 0.0);
    cr_assert(rd_sphere_intersect(&s, ray_of(v3(nextafter(1, 0), 0, 0), v3(0, 0, -1)), INFINITY) > 0);
}

Test(intersect, sphere_ray_inside_returns_exit)
{
    /* From the centre of a radius-2 sphere: exit at t = 2 in any direction. */
    rd_sphere s = {v3(0, 0, 0), 2};
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 1, 0)), INFINITY), 2.0);
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 0, -1)), INFINITY), 2.0);
    /* Off centre at x = 1: exit forward at x = 2 (t = 1), backward at x = -2 (t = 3). */
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(1, 0, 0), v3(1, 0, 0)), INFINITY), 1.0);
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(1, 0, 0), v3(-1, 0, 0)), INFINITY), 3.0);
    /* Sideways from (1,0,0) along y: exit at y = sqrt(4 - 1) = sqrt(3). */
    assert_near(rd_sphere_intersect(&s, ray_of(v3(1, 0, 0), v3(0, 1, 0)), INFINITY), sqrt(3.0), 4 * DBL_EPSILON);
}

Test(intersect, sphere_behind_ray_misses)
{
    rd_sphere s = {v3(0, 0, 5), 1};
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 0, -1)), INFINITY), 0.0);
    /* Both roots negative even though the line crosses the sphere. */
    rd_sphere s2 = {v3(-3, 0, 0), 2};
    cr_assert_eq(rd_sphere_intersect(&s2, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 0.0);
    /* Plain miss beside the sphere. */
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 0.0);
}

Test(intersect, sphere_tmax_is_respected)
{
    rd_sphere s = {v3(0, 0, -5), 1};
    rd_ray r = ray_of(v3(0, 0, 0), v3(0, 0, -1));
    /* t must lie in the open interval (0, tmax). */
    cr_assert_eq(rd_sphere_intersect(&s, r, 4.0), 0.0);
    cr_assert_eq(rd_sphere_intersect(&s, r, 3.0), 0.0);
    cr_assert_eq(rd_sphere_intersect(&s, r, nextafter(4.0, 5)), 4.0);
    /* tmax between entry (4) and exit (6) keeps the entry. */
    cr_assert_eq(rd_sphere_intersect(&s, r, 5.0), 4.0);
    /* From inside, the exit at 2 is cut off by tmax = 1.5. */
    rd_sphere b = {v3(0, 0, 0), 2};
    cr_assert_eq(rd_sphere_intersect(&b, ray_of(v3(0, 0, 0), v3(1, 0, 0)), 1.5), 0.0);
}

Test(intersect, sphere_tiny_sphere_far_away)
{
    /* r = 1e-6 at distance 1e6: b² and a·c are both ~1e12 and differ by
     * 1e-12, far below their rounding (~1e-4), so the textbook
     * discriminant cannot see this sphere. ulp(1e6) = 1.16e-10. */
    const double D = 1e6, R = 1e-6;
    rd_sphere s = {v3(0, 0, -D), R};
    double t = rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), v3(0, 0, -1)), INFINITY);
    assert_near(t, D - R, 2.4e-10);
    /* Aimed at a point 0.5 r off-centre: passes at distance 0.5e-6 from c,
     * t = D - sqrt(r² - (0.5 r)²) = D - 0.8660254e-6. */
    rd_vec3 d = v3_normalize(v3(0.5 * R, 0, -D));
    t = rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), d), INFINITY);
    assert_near(t, D - sqrt(0.75) * R, 1e-9);
    /* 0.99 r off: t = D - sqrt(1 - 0.9801) r = D - 0.14107e-6. */
    d = v3_normalize(v3(0.99 * R, 0, -D));
    t = rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), d), INFINITY);
    assert_near(t, D - sqrt(1 - 0.9801) * R, 1e-9);
    /* 1.01 r off: misses. */
    d = v3_normalize(v3(1.01 * R, 0, -D));
    cr_assert_eq(rd_sphere_intersect(&s, ray_of(v3(0, 0, 0), d), INFINITY), 0.0);
    /* The hit point lies on the sphere, to the precision of its position. */
    rd_hit h = {0};
    rd_ray r = ray_of(v3(0, 0, 0), v3(0, 0, -1));
    h.t = rd_sphere_intersect(&s, r, INFINITY);
    rd_sphere_fill_hit(&s, r, &h);
    assert_vec_near(h.ng, 0, 0, 1, 0);
    assert_near(h.p.z, -D + R, 1.2e-10);
}

/* ======================================================================= */
/* Plane                                                                   */
/* ======================================================================= */

static rd_plane plane_of(rd_vec3 q, rd_vec3 n)
{
    rd_plane p;
    rd_plane_make(&p, q, n);
    return p;
}

Test(intersect, plane_make_basis)
{
    rd_plane p = plane_of(v3(1, 2, 3), v3(0, 0, 7));
    assert_vec_near(p.n, 0, 0, 1, 0);
    /* tu, tv, n orthonormal. */
    assert_near(v3_len(p.tu), 1, 4 * DBL_EPSILON);
    assert_near(v3_len(p.tv), 1, 4 * DBL_EPSILON);
    assert_near(v3_dot(p.tu, p.n), 0, 4 * DBL_EPSILON);
    assert_near(v3_dot(p.tv, p.n), 0, 4 * DBL_EPSILON);
    assert_near(v3_dot(p.tu, p.tv), 0, 4 * DBL_EPSILON);
}

Test(intersect, plane_head_on_and_oblique)
{
    /* y = -1, normal +y. Straight down from the origin: t = 1. */
    rd_plane p = plane_of(v3(0, -1, 0), v3(0, 1, 0));
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, 0, 0), v3(0, -1, 0)), INFINITY), 1.0);
    /* 45° down: t = sqrt(2) for a unit direction. */
    rd_vec3 d = v3_normalize(v3(1, -1, 0));
    assert_near(rd_plane_intersect(&p, ray_of(v3(0, 0, 0), d), INFINITY), sqrt(2.0), 4 * DBL_EPSILON);
    /* Tilted plane x + y + z = 3 (through (1,1,1)), ray along +x from the origin: t = 3. */
    rd_plane q = plane_of(v3(1, 1, 1), v3(1, 1, 1));
    assert_near(rd_plane_intersect(&q, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 3.0, 8 * DBL_EPSILON);
}

Test(intersect, plane_two_sided)
{
    /* Same plane hit from below (against the normal's side) at t = 2. */
    rd_plane p = plane_of(v3(0, -1, 0), v3(0, 1, 0));
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, -3, 0), v3(0, 1, 0)), INFINITY), 2.0);
    /* Flipping the normal changes nothing. */
    rd_plane f = plane_of(v3(0, -1, 0), v3(0, -1, 0));
    cr_assert_eq(rd_plane_intersect(&f, ray_of(v3(0, 0, 0), v3(0, -1, 0)), INFINITY), 1.0);
    cr_assert_eq(rd_plane_intersect(&f, ray_of(v3(0, -3, 0), v3(0, 1, 0)), INFINITY), 2.0);
}

Test(intersect, plane_parallel_ray_misses)
{
    rd_plane p = plane_of(v3(0, -1, 0), v3(0, 1, 0));
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 0.0);
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, 0, 0), v3(0.6, 0, 0.8)), INFINITY), 0.0);
    /* A ray lying in the plane misses too (no division by zero, no NaN). */
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, -1, 0), v3(0, 0, 1)), INFINITY), 0.0);
    /* Oblique plane, exactly parallel direction: n = (1,1,1)/√3 has equal
     * components, so (1,-1,0)·n and (1,1,-2)·n are exactly 0. */
    rd_plane q = plane_of(v3(1, 1, 1), v3(1, 1, 1));
    cr_assert_eq(rd_plane_intersect(&q, ray_of(v3(0, 0, 0), v3(1, -1, 0)), INFINITY), 0.0);
    cr_assert_eq(rd_plane_intersect(&q, ray_of(v3(0, 0, 0), v3(1, 1, -2)), INFINITY), 0.0);
}

Test(intersect, plane_behind_and_tmax)
{
    rd_plane p = plane_of(v3(0, -1, 0), v3(0, 1, 0));
    /* Moving away from the plane. */
    cr_assert_eq(rd_plane_intersect(&p, ray_of(v3(0, 0, 0), v3(0, 1, 0)), INFINITY), 0.0);
    /* t = 1 is not inside (0, 1), nor (0, 0.5). */
    rd_ray r = ray_of(v3(0, 0, 0), v3(0, -1, 0));
    cr_assert_eq(rd_plane_intersect(&p, r, 1.0), 0.0);
    cr_assert_eq(rd_plane_intersect(&p, r, 0.5), 0.0);
    cr_assert_eq(rd_plane_intersect(&p, r, nextafter(1.0, 2)), 1.0);
}

Test(intersect, plane_fill_hit_values)
{
    rd_plane p = plane_of(v3(2, -1, 3), v3(0, 1, 0));
    rd_ray r = ray_of(v3(5, 4, -1), v3(0, -1, 0));
    rd_hit h = {0};
    h.t = rd_plane_intersect(&p, r, INFINITY);
    cr_assert_eq(h.t, 5.0);
    rd_plane_fill_hit(&p, r, &h);
    assert_vec_near(h.p, 5, -1, -1, 0);
    /* ng is the plane's own normal (not turned toward the ray). */
    assert_vec_near(h.ng, 0, 1, 0, 0);
    cr_assert(h.perr > 0 && h.perr < 1e-13);
    /* u, v: the offset (3, 0, -4) of the hit from the plane's point, along tu and tv. */
    rd_plane_uv(&p, &h);
    rd_vec3 rel = v3(3, 0, -4);
    assert_near(h.u, v3_dot(rel, p.tu), 1e-14);
    assert_near(h.v, v3_dot(rel, p.tv), 1e-14);
    assert_near(h.u * h.u + h.v * h.v, 25, 1e-13); /* |rel|² */
    /* From below the normal is still +y. */
    r = ray_of(v3(5, -6, -1), v3(0, 1, 0));
    h.t = rd_plane_intersect(&p, r, INFINITY);
    rd_plane_fill_hit(&p, r, &h);
    assert_vec_near(h.ng, 0, 1, 0, 0);
}

/* rd_plane_blocks, the shadow rays' plane test, must answer exactly as
 * rd_plane_intersect(...) > 0 does, for every input: its sign pre-test may
 * only reject what the division would reject anyway. */

/* Values where a sign test and a quotient can part: signed zeros,
 * subnormals, the ends of the normal range, infinities, NaN. */
static const double plane_special[] = {0.0,    -0.0,    0x1p-1074, -0x1p-1074, 0x1p-1060, -0x1p-1060, DBL_MIN, -DBL_MIN,
                                       1e-300, -1e-300, 0.5,       -0.5,       1.0,       -1.0,       3.0,     -3.0,
                                       1e300,  -1e300,  DBL_MAX,   -DBL_MAX,   INFINITY,  -INFINITY,  NAN,     -NAN};
#define PLANE_NSPECIAL (sizeof plane_special / sizeof plane_special[0])

/* A double of any kind: special, of any exponent and sign, or ordinary. */
static double any_double(test_rng *g)
{
    double u = rng_uniform(g);
    if (u < 0.3)
        return plane_special[rng_int(g, (int)PLANE_NSPECIAL)];
    if (u < 0.6)
        return (rng_uniform(g) < 0.5 ? -1 : 1) * ldexp(1 + rng_uniform(g), rng_int(g, 2100) - 1075);
    return rng_range(g, -10, 10);
}

static rd_vec3 any_vec(test_rng *g)
{
    double x = any_double(g);
    double y = any_double(g);
    double z = any_double(g);
    return v3(x, y, z);
}

/* The planes' point, normal and the ray as given (no normalizing), so that
 * every input of the two tests can be reached. */
static rd_plane raw_plane(rd_vec3 q, rd_vec3 n)
{
    rd_plane pl;
    memset(&pl, 0, sizeof pl);
    pl.q = q;
    pl.n = n;
    return pl;
}

static int blocks_as_intersect(const rd_plane *pl, rd_ray r, double tmax, char *why, size_t len)
{
    int old = rd_plane_intersect(pl, r, tmax) > 0;
    int got = rd_plane_blocks(pl, r, tmax);
    if (old != got)
        snprintf(why, len, "q=(%a,%a,%a) n=(%a,%a,%a) o=(%a,%a,%a) d=(%a,%a,%a) tmax=%a: intersect says %d, blocks %d",
                 pl->q.x, pl->q.y, pl->q.z, pl->n.x, pl->n.y, pl->n.z, r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, tmax,
                 old, got);
    return old == got;
}

static const double plane_tmax[] = {INFINITY, DBL_MAX, 2.0, 1.0, 0x1p-1074, 0.0, -1.0, NAN};

Test(intersect, plane_blocks_every_sign_pair)
{
    /* n = +x and o = 0, so that num and dn are exactly the chosen values,
     * signed zeros included (-0 + -0 stays -0). */
    int hits = 0, misses = 0;
    char why[400];
    for (size_t a = 0; a < PLANE_NSPECIAL; a++)
        for (size_t b = 0; b < PLANE_NSPECIAL; b++)
            for (size_t c = 0; c < sizeof plane_tmax / sizeof plane_tmax[0]; c++) {
                double num = plane_special[a], dn = plane_special[b];
                double zq = copysign(0.0, num), zd = copysign(0.0, dn);
                rd_plane pl = raw_plane(v3(num, zq, zq), v3(1, 0, 0));
                rd_ray r = ray_of(v3(0, 0, 0), v3(dn, zd, zd));
                cr_assert(blocks_as_intersect(&pl, r, plane_tmax[c], why, sizeof why), "%s", why);
                if (rd_plane_blocks(&pl, r, plane_tmax[c]))
                    hits++;
                else
                    misses++;
            }
    cr_assert(hits > 100 && misses > 100, "%d hits, %d misses", hits, misses);
}

Test(intersect, plane_blocks_edge_cases)
{
    rd_plane pl = raw_plane(v3(0, 0, 0), v3(1, 0, 0));
    /* Tiny quotients of one sign: 2^-1000 / 2^1000 underflows to 0 (no hit),
     * 2^-1000 / 2^-1000 is 1 (a hit a product of the signs would miss, as
     * num·dn underflows to 0). */
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-0x1p-1000, 0, 0), v3(0x1p1000, 0, 0)), INFINITY), 0);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-0x1p-1000, 0, 0), v3(0x1p-1000, 0, 0)), INFINITY), 1);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(0x1p-1074, 0, 0), v3(-0x1p-1074, 0, 0)), 2.0), 1);
    /* The origin on the plane (num = 0 of either sign) never blocks. */
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(0, 0, 0), v3(1, 0, 0)), INFINITY), 0);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-0.0, 0, 0), v3(-1, 0, 0)), INFINITY), 0);
    /* An infinite dn gives t = 0 for any finite num, NaN for infinite. */
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-1, 0, 0), v3(INFINITY, 0, 0)), INFINITY), 0);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-INFINITY, 0, 0), v3(INFINITY, 0, 0)), INFINITY), 0);
    /* Same signs, the division decides against tmax. */
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-2, 0, 0), v3(1, 0, 0)), 2.0), 0);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(-2, 0, 0), v3(1, 0, 0)), nextafter(2.0, 3)), 1);
    cr_assert_eq(rd_plane_blocks(&pl, ray_of(v3(2, 0, 0), v3(-1, 0, 0)), INFINITY), 1);
}

Test(intersect, plane_blocks_as_intersect_random)
{
    test_rng g = {77};
    int hits = 0, rejected = 0;
    char why[400];
    for (int i = 0; i < 1000000; i++) {
        rd_plane pl = raw_plane(any_vec(&g), any_vec(&g));
        rd_vec3 o = any_vec(&g);
        rd_ray r = ray_of(o, any_vec(&g));
        double tmax = rng_uniform(&g) < 0.5 ? INFINITY : any_double(&g);
        cr_assert(blocks_as_intersect(&pl, r, tmax, why, sizeof why), "case %d: %s", i, why);
        hits += rd_plane_blocks(&pl, r, tmax);
        rejected += !rd_plane_blocks(&pl, r, tmax);
    }
    /* Ordinary planes and rays from either side, most of them hit or missed
     * by the signs alone. */
    for (int i = 0; i < 200000; i++) {
        rd_plane pl = plane_of(rng_point(&g, -50, 50), rng_unit(&g));
        rd_vec3 o = rng_point(&g, -50, 50);
        rd_ray r = ray_of(o, v3_scale(rng_unit(&g), exp(rng_range(&g, -30, 30))));
        double tmax = rng_uniform(&g) < 0.5 ? INFINITY : exp(rng_range(&g, -30, 30));
        cr_assert(blocks_as_intersect(&pl, r, tmax, why, sizeof why), "ordinary case %d: %s", i, why);
        hits += rd_plane_blocks(&pl, r, tmax);
    }
    cr_assert(hits > 100000 && rejected > 100000, "%d hits, %d misses of the raw cases", hits, rejected);
}

/* ======================================================================= */
/* Triangle, through the world                                             */
/* ======================================================================= */

/* Triangles reach the tracer only through the world (core/geometry/world.h):
 * rd_plan_build prepares the scene with rd_world_build, rd_trace asks
 * rd_world_closest for the nearest hit (which fills it with fill_tri) and
 * rd_world_hit_uv for its texture coordinates, and shadow rays ask
 * rd_world_any. The tests below build scenes, let rd_world_build prepare
 * them and look at what those functions return, for mesh faces (as
 * rd_scene_load_assets leaves an OBJ file in the scene) and for [triangle]
 * objects. The eye sits at the origin: the world is camera-relative, so its
 * coordinates are then the scene's. */

typedef struct {
    rd_scene s;
    rd_world w;
} tri_world;

static void tri_world_build(tri_world *tw)
{
    rd_error err = {0};
    cr_assert_eq(rd_world_build(&tw->w, &tw->s, &err), RD_OK, "rd_world_build: %s", err.message);
}

static void tri_world_scene(tri_world *tw)
{
    fixture_scene(&tw->s, 1, 1);
    tw->s.camera.eye = v3(0, 0, 0);
    tw->s.camera.target = v3(0, 0, -1);
    add_material(&tw->s, RD_MAT_DIFFUSE);
}

/* A world of one mesh: corners pos[0 .. npos-1], faces of three corner
 * indices. Normals and uvs, when given, are per corner (a face's corner k
 * uses normal and uv k), as an OBJ "f a/a/a" line gives them. */
static void mesh_world(tri_world *tw, const rd_vec3 *pos, size_t npos, const uint32_t (*faces)[3], size_t nfaces,
                       const rd_vec3 *normals, const double (*uvs)[2])
{
    tri_world_scene(tw);
    rd_mesh *m = calloc(1, sizeof *m);
    cr_assert(m);
    m->positions = malloc(npos * sizeof *m->positions);
    m->faces = malloc(nfaces * sizeof *m->faces);
    cr_assert(m->positions && m->faces);
    memcpy(m->positions, pos, npos * sizeof *pos);
    m->npositions = npos;
    if (normals) {
        m->normals = malloc(npos * sizeof *m->normals);
        cr_assert(m->normals);
        memcpy(m->normals, normals, npos * sizeof *normals);
        m->nnormals = npos;
    }
    if (uvs) {
        m->uvs = malloc(npos * sizeof *m->uvs);
        cr_assert(m->uvs);
        memcpy(m->uvs, uvs, npos * sizeof *uvs);
        m->nuvs = npos;
    }
    for (size_t f = 0; f < nfaces; f++)
        for (int c = 0; c < 3; c++) {
            m->faces[f].v[c] = faces[f][c];
            m->faces[f].n[c] = normals ? (int32_t)faces[f][c] : -1;
            m->faces[f].t[c] = uvs ? (int32_t)faces[f][c] : -1;
        }
    m->nfaces = nfaces;
    tw->s.meshes = m;
    tw->s.mesh_count = 1;
    rd_object *o = rd_scene_add_object(&tw->s);
    cr_assert(o);
    o->type = RD_OBJ_MESH;
    o->mesh = 0;
    o->material = 0;
    tri_world_build(tw);
}

/* A world of the one-triangle mesh (a, b, c). */
static void tri_mesh_world(tri_world *tw, rd_vec3 a, rd_vec3 b, rd_vec3 c, const rd_vec3 *normals,
                           const double (*uvs)[2])
{
    rd_vec3 pos[3] = {a, b, c};
    static const uint32_t face[1][3] = {{0, 1, 2}};
    mesh_world(tw, pos, 3, face, 1, normals, uvs);
}

/* A world of the [triangle] object (a, b, c). */
static void tri_object_world(tri_world *tw, rd_vec3 a, rd_vec3 b, rd_vec3 c, const rd_vec3 *normals,
                             const double (*uvs)[2])
{
    tri_world_scene(tw);
    rd_object *o = add_triangle(&tw->s, a, b, c, 0);
    if (normals) {
        o->has_normals = 1;
        memcpy(o->n, normals, sizeof o->n);
    }
    if (uvs) {
        o->has_uv = 1;
        memcpy(o->uv, uvs, sizeof o->uv);
    }
    tri_world_build(tw);
}

static void tri_world_free(tri_world *tw)
{
    rd_world_free(&tw->w);
    rd_scene_free(&tw->s);
}

/* The nearest hit's t, or 0 on a miss; h (may be NULL) as the tracer sees
 * it, texture coordinates included. rd_world_any must agree on whether
 * there is a hit. */
static double world_hit(const tri_world *tw, rd_ray r, double tmax, rd_hit *h)
{
    rd_hit local;
    if (!h)
        h = &local;
    memset(h, 0, sizeof *h);
    int hit = rd_world_closest(&tw->w, r, tmax, h);
    int any = rd_world_any(&tw->w, r, tmax);
    cr_assert_eq(any, hit, "rd_world_any says %d, rd_world_closest %d", any, hit);
    if (!hit)
        return 0;
    rd_world_hit_uv(&tw->w, h);
    return h->t;
}

Test(intersect, triangle_head_on_exact_t_and_barycentrics)
{
    /* v0 = (0,0,-2), v1 = (1,0,-2), v2 = (0,1,-2). The point (0.25, 0.5) is
     * 0.25·v0 + 0.25·v1 + 0.5·v2 (b1 = x, b2 = y, b0 = 1 - x - y). */
    tri_world tw;
    tri_mesh_world(&tw, v3(0, 0, -2), v3(1, 0, -2), v3(0, 1, -2), NULL, NULL);
    rd_hit h;
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, 0), v3(0, 0, -1)), INFINITY, &h), 2.0);
    assert_near(h.bary[0], 0.25, 1e-15);
    assert_near(h.bary[1], 0.25, 1e-15);
    assert_near(h.bary[2], 0.5, 1e-15);
    /* An oblique ray to the centroid from (1,1,0): t = |(1,1,0) - (1/3,1/3,-2)|. */
    rd_vec3 cen = v3(1.0 / 3, 1.0 / 3, -2);
    rd_vec3 o = v3(1, 1, 0);
    rd_vec3 d = v3_normalize(v3_sub(cen, o));
    assert_near(world_hit(&tw, ray_of(o, d), INFINITY, &h), v3_len(v3_sub(cen, o)), 1e-14);
    assert_near(h.bary[0], 1.0 / 3, 1e-14);
    assert_near(h.bary[1], 1.0 / 3, 1e-14);
    assert_near(h.bary[2], 1.0 / 3, 1e-14);
    tri_world_free(&tw);
}

Test(intersect, triangle_both_sides_outside_behind_tmax)
{
    tri_world tw;
    tri_mesh_world(&tw, v3(0, 0, -2), v3(1, 0, -2), v3(0, 1, -2), NULL, NULL);
    rd_hit h;
    /* From behind (the other face): same point, t = 3. The geometric normal
     * stays the triangle's own (+z, against the ray: not the front), the
     * shading normal turns to face the ray. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, -5), v3(0, 0, 1)), INFINITY, &h), 3.0);
    cr_assert_eq(h.front, 0);
    assert_vec_near(h.ng, 0, 0, 1, 0);
    assert_vec_near(h.n, 0, 0, -1, 0);
    /* From the front: the front, both normals +z. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, 0), v3(0, 0, -1)), INFINITY, &h), 2.0);
    cr_assert_eq(h.front, 1);
    assert_vec_near(h.n, 0, 0, 1, 0);
    /* x + y = 1.2 > 1: outside. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.6, 0.6, 0), v3(0, 0, -1)), INFINITY, NULL), 0.0);
    cr_assert_eq(world_hit(&tw, ray_of(v3(-0.1, 0.5, 0), v3(0, 0, -1)), INFINITY, NULL), 0.0);
    /* Behind the origin. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, 0), v3(0, 0, 1)), INFINITY, NULL), 0.0);
    /* tmax: open interval. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, 0), v3(0, 0, -1)), 2.0, NULL), 0.0);
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, 0), v3(0, 0, -1)), 2.5, NULL), 2.0);
    /* Parallel to the triangle's plane. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(-1, 0.2, -2), v3(1, 0, 0)), INFINITY, NULL), 0.0);
    tri_world_free(&tw);
}

typedef void (*tri_world_maker)(tri_world *, rd_vec3, rd_vec3, rd_vec3, const rd_vec3 *, const double (*)[2]);

static void check_fill_hit(tri_world_maker make, const char *kind)
{
    rd_vec3 a = v3(0, 0, -2), b = v3(1, 0, -2), c = v3(0, 1, -2);
    rd_ray r = ray_of(v3(0.25, 0.5, 0), v3(0, 0, -1));
    tri_world tw;
    make(&tw, a, b, c, NULL, NULL);
    rd_hit h;
    cr_assert_eq(world_hit(&tw, r, INFINITY, &h), 2.0, "%s", kind);
    assert_vec_near(h.p, 0.25, 0.5, -2, 1e-15);
    /* ng = normalize((v1-v0)×(v2-v0)) = x×y = +z. */
    assert_vec_near(h.ng, 0, 0, 1, 0);
    assert_vec_near(h.n, 0, 0, 1, 0);
    /* Without uv the coordinates are (b1, b2). */
    assert_near(h.u, 0.25, 1e-15);
    assert_near(h.v, 0.5, 1e-15);
    cr_assert(h.perr > 0 && h.perr < 1e-14, "%s: perr %g", kind, h.perr);
    cr_assert_eq(h.material, 0, "%s", kind);
    cr_assert_eq(h.object, 0, "%s", kind);
    tri_world_free(&tw);

    /* With uv and shading normals: both interpolated with (0.25, 0.25, 0.5):
     * u = 0.25·0.5 + 0.25·4 + 0.5·1 = 1.625, v = 0.25·0.25 + 0.25·1 + 0.5·2
     * = 1.3125 (exact in binary). The normals are normalised before they
     * are interpolated, so lengths 5, 2 and 0.5 change nothing. */
    const double uv[3][2] = {{0.5, 0.25}, {4, 1}, {1, 2}};
    const rd_vec3 n[3] = {v3(0, 0, 5), v3(2, 0, 0), v3(0, 0.5, 0)};
    make(&tw, a, b, c, n, uv);
    cr_assert_eq(world_hit(&tw, r, INFINITY, &h), 2.0, "%s", kind);
    assert_near(h.u, 1.625, 1e-15);
    assert_near(h.v, 1.3125, 1e-15);
    /* 0.25·z + 0.25·x + 0.5·y = (0.25, 0.5, 0.25), normalised by sqrt(0.375). */
    double l = sqrt(0.375);
    assert_vec_near(h.n, 0.25 / l, 0.5 / l, 0.25 / l, 1e-15);
    assert_vec_near(h.ng, 0, 0, 1, 0);
    /* From behind, the interpolated normal turns to face the ray. */
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.25, 0.5, -5), v3(0, 0, 1)), INFINITY, &h), 3.0, "%s", kind);
    assert_vec_near(h.n, -0.25 / l, -0.5 / l, -0.25 / l, 1e-15);
    tri_world_free(&tw);

    /* Normals that cancel where the ray hits fall back to the geometric
     * one: n0 = +z and n1 = -z at the midpoint of the edge v0-v1, which
     * the watertight test counts as inside. */
    const rd_vec3 cancel[3] = {v3(0, 0, 1), v3(0, 0, -1), v3(0, 1, 0)};
    make(&tw, a, b, c, cancel, NULL);
    cr_assert_eq(world_hit(&tw, ray_of(v3(0.5, 0, 0), v3(0, 0, -1)), INFINITY, &h), 2.0, "%s", kind);
    assert_near(h.bary[2], 0, 0);
    assert_vec_near(h.n, 0, 0, 1, 0);
    tri_world_free(&tw);
}

/* The two ways a triangle enters a scene shade the same. */
Test(intersect, triangle_fill_hit_values_mesh_face) { check_fill_hit(tri_mesh_world, "mesh face"); }
Test(intersect, triangle_fill_hit_values_triangle_object) { check_fill_hit(tri_object_world, "[triangle]"); }

/* The shading normal as the hit fill made it on every hit before the world
 * kept unit normals: each corner's normalized there, then the blend. */
static rd_vec3 normal_per_hit(const rd_vec3 raw[3], const double *bc, rd_vec3 ng, rd_vec3 d)
{
    rd_vec3 n0 = v3_normalize(raw[0]), n1 = v3_normalize(raw[1]), n2 = v3_normalize(raw[2]);
    rd_vec3 n = v3_normalize(v3_add(v3_add(v3_scale(n0, bc[0]), v3_scale(n1, bc[1])), v3_scale(n2, bc[2])));
    n = v3_max_abs(n) > 0 ? n : ng;
    return v3_dot(n, d) > 0 ? v3_neg(n) : n;
}

/* Rays at points spread over every face of tw's world: each hit's shading
 * normal has the bits normal_per_hit gives. Returns the hits. */
static int check_normals_per_hit(const tri_world *tw, const char *what)
{
    static const double at[][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {0.7, 0.2, 0.1}, {0.05, 0.05, 0.9}, {0.1, 0.85, 0.05}};
    int hits = 0;
    for (size_t i = 0; i < tw->w.ntris; i++)
        for (size_t k = 0; k < sizeof at / sizeof *at; k++) {
            const rd_wtri *t = rd_world_tri(&tw->w, i);
            rd_vec3 p =
                v3_add(v3_add(v3_scale(t->v[0], at[k][0]), v3_scale(t->v[1], at[k][1])), v3_scale(t->v[2], at[k][2]));
            rd_ray r = ray_of(v3(0, 0, 0), v3_normalize(p));
            rd_hit h;
            if (!world_hit(tw, r, INFINITY, &h))
                continue;
            const rd_wtri *ht = rd_world_tri(&tw->w, h.prim);
            rd_vec3 raw[3];
            for (int c = 0; c < 3; c++) {
                const rd_mesh *m = ht->mesh < 0 ? NULL : &tw->s.meshes[ht->mesh];
                raw[c] = m ? m->normals[m->faces[ht->face].n[c]] : tw->s.objects[ht->object].n[c];
            }
            rd_vec3 want = normal_per_hit(raw, h.bary, h.ng, r.d);
            cr_assert(memcmp(&h.n, &want, sizeof want) == 0,
                      "%s: face %zu at (%g, %g, %g): (%a, %a, %a), want (%a, %a, %a)", what, (size_t)h.prim, at[k][0],
                      at[k][1], at[k][2], h.n.x, h.n.y, h.n.z, want.x, want.y, want.z);
            hits++;
        }
    return hits;
}

/* Normals of every length, each shared by up to six faces of a 4x4 grid of
 * corners, and [triangle]s' own: the world normalizes each once, and every
 * face that uses it shades as it did when each hit normalized its own. */
Test(intersect, unit_normals_made_once_give_the_per_hit_bits)
{
    static const double scale[] = {1, 3.7, 1e-200, 1e200, 0.3, 7e-3};
    rd_vec3 pos[16], nrm[16];
    uint32_t faces[18][3];
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            int v = 4 * y + x;
            pos[v] = v3(x - 1.5, y - 1.5, -3 - 0.1 * ((x * y) % 3));
            nrm[v] = v3_scale(v3(0.3 * (x - 1.5) + 0.01 * v, 0.2 * (y - 1.5), 1), scale[v % 6]);
        }
    for (int y = 0, f = 0; y < 3; y++)
        for (int x = 0; x < 3; x++, f += 2) {
            uint32_t a = (uint32_t)(4 * y + x);
            memcpy(faces[f], (uint32_t[3]){a, a + 1, a + 5}, sizeof faces[f]);
            memcpy(faces[f + 1], (uint32_t[3]){a, a + 5, a + 4}, sizeof faces[f + 1]);
        }
    tri_world tw;
    mesh_world(&tw, pos, 16, (const uint32_t(*)[3])faces, 18, nrm, NULL);
    cr_assert_eq(tw.w.nunit_n, 16);
    cr_assert_gt(check_normals_per_hit(&tw, "grid"), 60);
    tri_world_free(&tw);
    rd_vec3 own[3] = {v3(1e-300, 0, 1e-300), v3(0, 5, 2), v3(-0.25, 0.125, 3)};
    tri_object_world(&tw, v3(-1, -1, -2), v3(1, -1, -2.5), v3(0, 1, -2), own, NULL);
    cr_assert_eq(tw.w.nunit_n, 3);
    cr_assert_gt(check_normals_per_hit(&tw, "[triangle]"), 3);
    tri_world_free(&tw);
}

Test(intersect, triangle_watertight_shared_edge)
{
    /* Random parallelograms split along a diagonal v0-v2 into two faces of
     * one mesh, T1 = (v0, v1, v2) and T2 = (v2, v3, v0). Rays from random
     * origins on either side aimed at points of the shared edge must hit:
     * the edge test of Woop et al. evaluates the same expression (up to
     * sign) for both triangles, so no ray slips between them. */
    test_rng g = {12345};
    int misses = 0, n = 0;
    char first[300] = "";
    for (int quad = 0; quad < 200; quad++) {
        rd_vec3 pos[4];
        pos[0] = rng_point(&g, -10, 10);
        pos[1] = rng_point(&g, -10, 10);
        pos[2] = rng_point(&g, -10, 10);
        pos[3] = v3_add(pos[0], v3_sub(pos[2], pos[1]));
        if (v3_len(v3_cross(v3_sub(pos[1], pos[0]), v3_sub(pos[2], pos[0]))) < 1) /* skip slivers */
            continue;
        /* Vary the corner order of both faces (the shared edge is walked
         * in opposite directions or the same one). */
        uint32_t faces[2][3] = {{0, 1, 2}, {2, 3, 0}};
        if (!(quad % 2))
            memcpy(faces[0], (uint32_t[3]){1, 2, 0}, sizeof faces[0]);
        if (!(quad % 3))
            memcpy(faces[1], (uint32_t[3]){0, 2, 3}, sizeof faces[1]);
        tri_world tw;
        mesh_world(&tw, pos, 4, faces, 2, NULL, NULL);
        for (int k = 0; k < 500; k++) {
            double s = rng_range(&g, 0.001, 0.999);
            rd_vec3 target = v3_add(pos[0], v3_scale(v3_sub(pos[2], pos[0]), s));
            rd_vec3 dir0 = rng_unit(&g);
            rd_vec3 o = v3_add(target, v3_scale(dir0, rng_range(&g, 0.5, 50)));
            rd_vec3 d = v3_sub(target, o);
            if (k % 2)
                d = v3_normalize(d);
            n++;
            if (!(world_hit(&tw, ray_of(o, d), INFINITY, NULL) > 0)) {
                if (!misses)
                    snprintf(first, sizeof first, "o=(%.17g,%.17g,%.17g) d=(%.17g,%.17g,%.17g)", o.x, o.y, o.z, d.x,
                             d.y, d.z);
                misses++;
            }
        }
        tri_world_free(&tw);
    }
    cr_assert(n > 50000, "too few rays generated (%d)", n);
    cr_assert_eq(misses, 0, "%d of %d rays through a shared edge missed both triangles, e.g. %s", misses, n, first);
}

Test(intersect, triangle_watertight_shared_vertex)
{
    /* A fan of 7 faces around an interior vertex C: every ray aimed at C
     * must hit one of them. */
    test_rng g = {777};
    int misses = 0, n = 0;
    for (int fan = 0; fan < 100; fan++) {
        rd_vec3 pos[8];
        pos[0] = rng_point(&g, -5, 5);
        rd_vec3 nrm = rng_unit(&g);
        rd_vec3 a = v3_normalize(v3_cross(nrm, rng_unit(&g)));
        rd_vec3 bb = v3_cross(nrm, a);
        for (int i = 0; i < 7; i++) {
            double ang = 2 * M_PI * (i + 0.3 * rng_uniform(&g)) / 7;
            double rad = rng_range(&g, 0.5, 3);
            /* A bit off-plane: a gently curved fan. */
            double off = rng_range(&g, -0.05, 0.05);
            pos[1 + i] = v3_add(
                pos[0], v3_add(v3_add(v3_scale(a, rad * cos(ang)), v3_scale(bb, rad * sin(ang))), v3_scale(nrm, off)));
        }
        uint32_t faces[7][3];
        for (uint32_t i = 0; i < 7; i++) {
            faces[i][0] = 0;
            faces[i][1] = 1 + i;
            faces[i][2] = 1 + (i + 1) % 7;
        }
        tri_world tw;
        mesh_world(&tw, pos, 8, faces, 7, NULL, NULL);
        for (int k = 0; k < 200; k++) {
            rd_vec3 dir0 = rng_unit(&g);
            if (fabs(v3_dot(dir0, nrm)) < 0.2) /* stay off the fan's own plane */
                continue;
            rd_vec3 o = v3_add(pos[0], v3_scale(dir0, rng_range(&g, 1, 30)));
            rd_vec3 d = v3_normalize(v3_sub(pos[0], o));
            n++;
            misses += !(world_hit(&tw, ray_of(o, d), INFINITY, NULL) > 0);
        }
        tri_world_free(&tw);
    }
    cr_assert(n > 10000);
    cr_assert_eq(misses, 0, "%d of %d rays aimed at a shared vertex missed every triangle", misses, n);
}

Test(intersect, triangle_zero_area_never_hits)
{
    /* Exactly degenerate triangles (exact integer coordinates):
     *  - three collinear points, v2 - v0 = 3·(v1 - v0);
     *  - two equal vertices; all three equal.
     * Rays from random origins aimed at points of the segment: the world
     * must never report a hit on such a triangle (it has no normal). After
     * the shear into the ray's frame the three points are collinear only up
     * to rounding, so a test that rejects only det == 0 lets some of these
     * rays through. */
    const rd_vec3 deg[4][3] = {
        {{1, 1, 1}, {2, 3, 4}, {4, 7, 10}},
        {{4, 7, 10}, {1, 1, 1}, {2, 3, 4}},
        {{1, 1, 1}, {2, 3, 4}, {2, 3, 4}},
        {{2, 3, 4}, {2, 3, 4}, {2, 3, 4}},
    };
    test_rng g = {99};
    for (int i = 0; i < 4; i++) {
        tri_world tw;
        tri_mesh_world(&tw, deg[i][0], deg[i][1], deg[i][2], NULL, NULL);
        int hits = 0;
        char first[300] = "";
        rd_vec3 a = deg[i][0], e = v3_sub(deg[i][2], deg[i][0]);
        if (i == 2)
            e = v3_sub(deg[i][1], deg[i][0]);
        for (int k = 0; k < 20000; k++) {
            rd_vec3 target = v3_add(a, v3_scale(e, rng_uniform(&g)));
            rd_vec3 o = rng_point(&g, -20, 20);
            rd_vec3 d = v3_normalize(v3_sub(target, o));
            rd_hit h;
            double t = world_hit(&tw, ray_of(o, d), INFINITY, &h);
            if (t != 0) {
                if (!hits)
                    snprintf(first, sizeof first, "o=(%.17g,%.17g,%.17g) d=(%.17g,%.17g,%.17g) t=%g b=(%g,%g,%g)", o.x,
                             o.y, o.z, d.x, d.y, d.z, t, h.bary[0], h.bary[1], h.bary[2]);
                hits++;
            }
        }
        cr_expect_eq(hits, 0,
                     "degenerate triangle %d (v0=(%g,%g,%g) v1=(%g,%g,%g) v2=(%g,%g,%g)) was hit by %d of 20000 rays, "
                     "e.g. %s",
                     i, deg[i][0].x, deg[i][0].y, deg[i][0].z, deg[i][1].x, deg[i][1].y, deg[i][1].z, deg[i][2].x,
                     deg[i][2].y, deg[i][2].z, hits, first);
        tri_world_free(&tw);
    }
}

/* ======================================================================= */
/* rd_offset_origin: no self-intersection at any scale                     */
/* ======================================================================= */

/* Random spheres at `scale` (centres up to 50·scale away, radii from
 * 0.01·scale to 10·scale), hit from outside by rays from random origins.
 * From each hit: a ray leaving on the outward side (random, one in four
 * grazing, plus the mirror direction) must never meet the sphere again;
 * a ray continued inward must meet it only at the far side, at the chord
 * length 2r·cos. */
static void sphere_offset_at_scale(double scale, uint64_t seed)
{
    test_rng g = {seed};
    int rehits = 0, bad_chords = 0, tested = 0;
    char first[400] = "";
    for (int i = 0; i < 4000; i++) {
        rd_sphere s = {v3_scale(rng_point(&g, -50, 50), scale), scale * exp(rng_range(&g, log(0.01), log(10)))};
        rd_vec3 nstar = rng_unit(&g);
        rd_vec3 pstar = v3_add(s.c, v3_scale(nstar, s.r));
        rd_vec3 o =
            v3_add(pstar, v3_scale(dir_with_cos(&g, nstar, rng_range(&g, 0.05, 1)), scale * rng_range(&g, 0.1, 200)));
        rd_ray r = ray_of(o, v3_normalize(v3_sub(pstar, o)));
        rd_hit h;
        memset(&h, 0, sizeof h);
        h.t = rd_sphere_intersect(&s, r, INFINITY);
        if (!(h.t > 0))
            continue;
        rd_sphere_fill_hit(&s, r, &h);
        tested++;
        for (int k = 0; k < 4; k++) {
            rd_vec3 d2 = k == 0 ? v3_normalize(v3_reflect(r.d, h.ng)) : outward_dir(&g, h.ng);
            if (!(v3_dot(d2, h.ng) > 0))
                continue;
            rd_ray r2 = ray_of(rd_offset_origin(&h, d2), d2);
            double t2 = rd_sphere_intersect(&s, r2, INFINITY);
            if (t2 != 0) {
                if (!rehits)
                    snprintf(first, sizeof first,
                             "scale %g: c=(%.17g,%.17g,%.17g) r=%.17g p=(%.17g,%.17g,%.17g) d=(%.17g,%.17g,%.17g) "
                             "t2=%g",
                             scale, s.c.x, s.c.y, s.c.z, s.r, h.p.x, h.p.y, h.p.z, d2.x, d2.y, d2.z, t2);
                rehits++;
            }
        }
        /* Continued into the sphere (refraction-like), not too grazing. */
        double c = rng_range(&g, 0.01, 1);
        rd_vec3 d3 = dir_with_cos(&g, v3_neg(h.ng), c);
        rd_ray r3 = ray_of(rd_offset_origin(&h, d3), d3);
        double t3 = rd_sphere_intersect(&s, r3, INFINITY);
        double chord = 2 * s.r * -v3_dot(d3, h.ng);
        if (!(fabs(t3 - chord) <= 1e-6 * chord)) {
            if (!bad_chords && !rehits)
                snprintf(first, sizeof first, "scale %g: inward ray hit at t=%.17g, chord %.17g", scale, t3, chord);
            bad_chords++;
        }
    }
    cr_assert(tested > 3500, "scale %g: only %d hits generated", scale, tested);
    cr_assert_eq(rehits + bad_chords, 0, "scale %g: %d outward self-hits, %d wrong inward hits of %d; first: %s", scale,
                 rehits, bad_chords, tested, first);
}

Test(intersect, offset_sphere_scale_1e_minus9) { sphere_offset_at_scale(1e-9, 1); }
Test(intersect, offset_sphere_scale_1) { sphere_offset_at_scale(1, 2); }
Test(intersect, offset_sphere_scale_1e9) { sphere_offset_at_scale(1e9, 3); }

/* Random planes (point up to 50·scale away, random normal), hit at random
 * points up to 100·scale from their point by rays from either side. A ray
 * leaving the hit in any direction (reflected or continued through; one in
 * four grazing) must never meet the plane again. */
static void plane_offset_at_scale(double scale, uint64_t seed)
{
    test_rng g = {seed};
    int rehits = 0, tested = 0;
    char first[400] = "";
    for (int i = 0; i < 4000; i++) {
        rd_plane pl = plane_of(v3_scale(rng_point(&g, -50, 50), scale), rng_unit(&g));
        rd_vec3 pstar = v3_add(pl.q, v3_add(v3_scale(pl.tu, scale * rng_range(&g, -100, 100)),
                                            v3_scale(pl.tv, scale * rng_range(&g, -100, 100))));
        rd_vec3 side = rng_uniform(&g) < 0.5 ? pl.n : v3_neg(pl.n);
        rd_vec3 o =
            v3_add(pstar, v3_scale(dir_with_cos(&g, side, rng_range(&g, 0.05, 1)), scale * rng_range(&g, 0.1, 200)));
        rd_ray r = ray_of(o, v3_normalize(v3_sub(pstar, o)));
        rd_hit h;
        memset(&h, 0, sizeof h);
        h.t = rd_plane_intersect(&pl, r, INFINITY);
        if (!(h.t > 0))
            continue;
        rd_plane_fill_hit(&pl, r, &h);
        tested++;
        for (int k = 0; k < 6; k++) {
            rd_vec3 d2;
            if (k == 0)
                d2 = v3_normalize(v3_reflect(r.d, h.ng)); /* mirror */
            else if (k == 1)
                d2 = r.d; /* straight through */
            else
                d2 = outward_dir(&g, rng_uniform(&g) < 0.5 ? h.ng : v3_neg(h.ng));
            rd_ray r2 = ray_of(rd_offset_origin(&h, d2), d2);
            double t2 = rd_plane_intersect(&pl, r2, INFINITY);
            if (t2 != 0) {
                if (!rehits)
                    snprintf(first, sizeof first,
                             "scale %g: q=(%.17g,%.17g,%.17g) n=(%.17g,%.17g,%.17g) p=(%.17g,%.17g,%.17g) "
                             "d=(%.17g,%.17g,%.17g) t2=%g",
                             scale, pl.q.x, pl.q.y, pl.q.z, pl.n.x, pl.n.y, pl.n.z, h.p.x, h.p.y, h.p.z, d2.x, d2.y,
                             d2.z, t2);
                rehits++;
            }
        }
    }
    cr_assert(tested > 3500, "scale %g: only %d hits generated", scale, tested);
    cr_assert_eq(rehits, 0, "scale %g: %d self-hits from %d plane hits; first: %s", scale, rehits, tested, first);
}

Test(intersect, offset_plane_scale_1e_minus9) { plane_offset_at_scale(1e-9, 11); }
Test(intersect, offset_plane_scale_1) { plane_offset_at_scale(1, 12); }
Test(intersect, offset_plane_scale_1e9) { plane_offset_at_scale(1e9, 13); }

/* The tracer computes a hit's two pushed origins once and hands them to all
 * of its shadow rays: rd_offset_origin must depend on dir only through the
 * side rd_offset_below gives (a dir along the surface, or NaN, counts as
 * above), to the bit. */
Test(intersect, offset_depends_on_dir_only_by_side)
{
    test_rng g = {21};
    for (int i = 0; i < 2000; i++) {
        rd_hit h;
        memset(&h, 0, sizeof h);
        h.p = v3_scale(rng_point(&g, -1, 1), exp(rng_range(&g, -20, 20)));
        h.ng = rng_unit(&g);
        h.perr = 1e-15 * exp(rng_range(&g, -20, 20));
        rd_vec3 side[2] = {rd_offset_side(&h, 0), rd_offset_side(&h, 1)};
        cr_assert(v3_dot(v3_sub(side[0], h.p), h.ng) > 0 && v3_dot(v3_sub(side[1], h.p), h.ng) < 0);
        for (int k = 0; k < 8; k++) {
            rd_vec3 dir = k == 0 ? v3(NAN, 0, 0) : (k == 1 ? v3(0, 0, 0) : rng_unit(&g));
            int below = rd_offset_below(&h, dir);
            cr_assert_eq(below, v3_dot(h.ng, dir) < 0);
            rd_vec3 o = rd_offset_origin(&h, dir);
            cr_assert(memcmp(&o, &side[below], sizeof o) == 0, "hit %d dir %d: not side %d's origin", i, k, below);
        }
    }
}

Test(intersect, offset_pushes_to_the_side_of_dir)
{
    /* Hit on the plane y = 0 at the origin of the plane's frame: the origin
     * moves up for an upward ray and down for a downward one, by a distance
     * that scales with the error bound. */
    rd_hit h;
    memset(&h, 0, sizeof h);
    h.p = v3(3, 0, 4);
    h.ng = v3(0, 1, 0);
    h.perr = 1e-12;
    rd_vec3 up = rd_offset_origin(&h, v3(0.6, 0.8, 0));
    rd_vec3 dn = rd_offset_origin(&h, v3(0.6, -0.8, 0));
    cr_assert(up.y > 0 && dn.y < 0, "up.y = %g, down.y = %g", up.y, dn.y);
    cr_assert(up.y >= h.perr && up.y < 100 * h.perr, "push %g for perr %g", up.y, h.perr);
    cr_assert_eq(up.x, 3.0);
    cr_assert_eq(up.z, 4.0);
    /* Doubling the error bound (a scene twice as far) doubles the push. */
    h.perr = 2e-12;
    rd_vec3 up2 = rd_offset_origin(&h, v3(0.6, 0.8, 0));
    assert_near(up2.y, 2 * up.y, 1e-3 * up.y);
}
