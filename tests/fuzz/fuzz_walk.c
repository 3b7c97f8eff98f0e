/* libFuzzer target for the ray walks (core/geometry/world.c, packet.c):
 * bytes become a world of spheres, triangles and perhaps a plane, then rays;
 * every answer of rd_world_closest (field by field, bit for bit),
 * rd_world_any, rd_world_any_hint and the packet walks, with every node test
 * this CPU runs, must equal the oracle's (tests/oracles/walk_oracle.h).
 *
 * Numbers come two ways, chosen by a bit of each: a 16-bit integer over 64
 * (exact, so primitives share corners, edges, planes and box faces, and
 * rays start on them), or the raw bits of a double (any value: subnormal,
 * huge, infinite, NaN). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_check.h"
#include "oracles/walk_oracle.h"
#include "world.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct {
    const uint8_t *p;
    size_t left;
} bytes;

static uint64_t take(bytes *b, int n)
{
    uint64_t v = 0;
    for (int i = 0; i < n; i++) {
        v = v << 8 | (b->left ? *b->p : 0);
        if (b->left) {
            b->p++;
            b->left--;
        }
    }
    return v;
}

static double number(bytes *b)
{
    if (take(b, 1) & 1) {
        uint64_t bits = take(b, 8);
        double x;
        memcpy(&x, &bits, sizeof x);
        return x;
    }
    return (double)(int16_t)take(b, 2) / 64;
}

static rd_vec3 point(bytes *b)
{
    double x = number(b), y = number(b), z = number(b);
    return v3(x, y, z);
}

/* Up to 64 primitives; scene values must be finite, as the readers make
 * them (rays need not be). */
static int finite3(rd_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static void add_prims(rd_scene *s, bytes *b)
{
    int n = (int)(take(b, 1) % 64);
    for (int i = 0; i < n && b->left; i++) {
        int kind = (int)(take(b, 1) % 8);
        rd_object o;
        memset(&o, 0, sizeof o);
        o.material = 0;
        o.mesh = -1;
        if (kind == 0) {
            o.type = RD_OBJ_PLANE;
            o.point = point(b);
            o.normal = point(b);
            if (!finite3(o.point) || !finite3(o.normal) || v3_max_abs(o.normal) == 0)
                continue;
        } else if (kind < 3) {
            o.type = RD_OBJ_SPHERE;
            o.center = point(b);
            o.radius = fabs(number(b));
            if (!finite3(o.center) || !(o.radius > 0) || !isfinite(o.radius))
                continue;
        } else {
            o.type = RD_OBJ_TRIANGLE;
            for (int c = 0; c < 3; c++)
                o.v[c] = point(b);
            if (!finite3(o.v[0]) || !finite3(o.v[1]) || !finite3(o.v[2]))
                continue;
        }
        rd_object *slot = rd_scene_add_object(s);
        if (!slot)
            return;
        *slot = o;
    }
}

static double a_tmax(bytes *b)
{
    switch (take(b, 1) % 4) {
    case 0: return 1;
    case 1: return fabs(number(b));
    default: return INFINITY;
    }
}

static void check_ray(const rd_world *w, rd_ray r, double tmax, uint32_t *hint)
{
    rd_hit want, got;
    memset(&want, 0, sizeof want);
    memset(&got, 0, sizeof got);
    int o = walk_oracle_closest(w, r, tmax, &want), g = rd_world_closest(w, r, tmax, &got);
    char why[300] = "";
    if (o != g || (o == 1 && !walk_oracle_same_hit(&got, &want, why, sizeof why)))
        rd_fuzz_fail("closest: walk %d, oracle %d: %s (o %a %a %a, d %a %a %a, tmax %a)", g, o, why, r.o.x, r.o.y,
                     r.o.z, r.d.x, r.d.y, r.d.z, tmax);
    int a = walk_oracle_any(w, r, tmax);
    if (a != rd_world_any(w, r, tmax) || a != rd_world_any_hint(w, r, tmax, hint))
        rd_fuzz_fail("any-hit: the oracle says %d (o %a %a %a, d %a %a %a, tmax %a)", a, r.o.x, r.o.y, r.o.z, r.d.x,
                     r.d.y, r.d.z, tmax);
}

static void check_packet(const rd_world *w, const rd_ray *r, const double *tmax, int n)
{
    rd_hit h[RD_PACKET_MAX];
    uint32_t last = 0;
    unsigned found = rd_world_closest_packet(w, r, n, tmax[0], h);
    unsigned blocked = rd_world_any_packet(w, r, tmax, n, &last);
    for (int i = 0; i < n; i++) {
        rd_hit want;
        memset(&want, 0, sizeof want);
        int o = walk_oracle_closest(w, r[i], tmax[0], &want);
        char why[300] = "";
        if ((int)(found >> i & 1) != o || (o == 1 && !walk_oracle_same_hit(&h[i], &want, why, sizeof why)))
            rd_fuzz_fail("packet ray %d of %d: closest %u, oracle %d: %s", i, n, found >> i & 1, o, why);
        if ((int)(blocked >> i & 1) != walk_oracle_any(w, r[i], tmax[i]))
            rd_fuzz_fail("packet ray %d of %d: any-hit %u", i, n, blocked >> i & 1);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    bytes b = {data, size};
    rd_scene s;
    rd_scene_init(&s);
    if (!rd_scene_add_material(&s)) {
        rd_scene_free(&s);
        return 0;
    }
    s.camera.eye = point(&b);
    if (!finite3(s.camera.eye))
        s.camera.eye = v3(0, 0, 0);
    add_prims(&s, &b);
    rd_world w;
    rd_error err = {0};
    if (rd_world_build(&w, &s, &err)) {
        rd_scene_free(&s);
        return 0;
    }
    rd_ray rays[RD_PACKET_MAX];
    double tmax[RD_PACKET_MAX];
    int n = 0;
    while (b.left && n < RD_PACKET_MAX) {
        rays[n].o = point(&b);
        rays[n].d = point(&b);
        tmax[n] = a_tmax(&b);
        n++;
    }
    rd_world v = w;
    for (int variant = 0; variant < 3; variant++) {
        if ((variant == 1 && !w.avx512) || (variant == 2 && !w.avx2))
            continue;
        v.avx512 = variant == 0 ? w.avx512 : 0;
        v.avx2 = variant == 2 ? 0 : w.avx2;
        uint32_t hint = 0;
        for (int i = 0; i < n; i++)
            check_ray(&v, rays[i], tmax[i], &hint);
        if (n)
            check_packet(&v, rays, tmax, n);
    }
    rd_world_free(&w);
    rd_scene_free(&s);
    return 0;
}
