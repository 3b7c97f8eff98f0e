/* Four spheres at once (core/geometry/sphere4.h) against rd_sphere_intersect:
 * each lane's answer, for any tmax, has the scalar test's bits. Spheres
 * and rays: ordinary, tangent, from inside, from the surface, tiny and far,
 * huge, and with NaN or infinite components. */
#include <criterion/criterion.h>
#include <math.h>
#include <string.h>

#include "bvh4.h"
#include "sphere4.h"
#include "support/rng.h"

static double odd(test_rng *r, double x)
{
    static const double v[] = {0.0, -0.0, 1e-300, 1e300, INFINITY, NAN};
    return rng_int(r, 12) == 0 ? v[rng_int(r, 6)] : x;
}

static rd_sphere random_sphere(test_rng *r)
{
    double scale = pow(10, rng_range(r, -8, 8));
    rd_vec3 c = v3_scale(rng_point(r, -4, 4), scale);
    return (rd_sphere){v3(odd(r, c.x), c.y, c.z), odd(r, rng_range(r, 0.01, 2) * scale)};
}

static rd_ray random_ray(test_rng *r, const rd_sphere *s)
{
    rd_ray ray = {rng_point(r, -6, 6), rng_unit(r)};
    switch (rng_int(r, 5)) {
    case 0: ray.o = v3_add(s->c, v3_scale(rng_unit(r), s->r)); break; /* on the surface */
    case 1: ray.o = s->c; break;                                      /* from the centre */
    case 2: {                                                         /* tangent */
        rd_vec3 n = rng_unit(r);
        ray.o = v3_add(s->c, v3_scale(n, s->r));
        ray.d = v3_cross(n, rng_unit(r));
        ray.o = v3_sub(ray.o, ray.d);
        break;
    }
    default: ray.o = v3_add(s->c, v3_scale(ray.o, fabs(s->r) + 1));
    }
    ray.d = v3(odd(r, ray.d.x), ray.d.y, ray.d.z);
    return ray;
}

__attribute__((target("avx2"))) static void lanes_against_scalar(void)
{
    test_rng r = {4};
    long hits = 0;
    for (int round = 0; round < 50000; round++) {
        rd_sphere s[4];
        for (int i = 0; i < 4; i++)
            s[i] = random_sphere(&r);
        int n = 1 + rng_int(&r, 4);
        rd_sphere4 p;
        rd_sphere4_pack(s, (size_t)n, &p);
        rd_ray ray = random_ray(&r, &s[rng_int(&r, n)]);
        rd_sphere4_roots q;
        unsigned ok = rd_sphere4_roots_of(&p, &ray, &q);
        for (int i = 0; i < 4; i++) {
            double tmax = rng_int(&r, 3) ? INFINITY : rng_range(&r, 0, 20) * fabs(s[i].r);
            double want = i < n ? rd_sphere_intersect(&s[i], ray, tmax) : 0;
            double got = ok >> i & 1 ? rd_sphere4_pick(&q, i, tmax) : 0;
            hits += want > 0;
            cr_assert(!memcmp(&want, &got, sizeof want),
                      "round %d lane %d of %d: lanes %a, scalar %a (c %a %a %a r %a, o %a %a %a, d %a %a %a)", round, i,
                      n, got, want, s[i].c.x, s[i].c.y, s[i].c.z, s[i].r, ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y,
                      ray.d.z);
        }
    }
    cr_assert_gt(hits, 20000, "only %ld hits", hits);
}

Test(sphere4, every_lane_is_the_scalar_test)
{
    if (!rd_bvh4_cpu_has_avx2())
        cr_skip_test("this CPU has no AVX2: its worlds never test four spheres at once");
    lanes_against_scalar();
}
