/* Packets of up to RD_PACKET_MAX coherent rays walked through the
 * four-wide BVH together (world.h, rd_world_closest_packet).
 *
 * An inner node is tested once for the whole packet, against bounds of
 * what every ray's own slab test would compute: the packet's origins and
 * inverse directions span per-axis intervals, and since rounding is
 * monotone, the rounded slab distances at the intervals' corners bound
 * each ray's rounded distances with no epsilon (the robust widening is
 * applied to the bound just as to each ray). A box the bounds reject, no
 * ray of the packet accepts. An axis on which the packet's directions
 * differ in sign, or one of them is zero, is left out of the bounds, which
 * only makes them looser.
 *
 * Leaves are reached ray by ray: each ray tests the leaves' boxes with its
 * own slab test, and the primitives with the same tests as a lone ray.
 * Any-hit answers do not depend on order; closest hits do not either,
 * since prim.h breaks ties by id. So every ray's answer is exactly the one
 * rd_world_closest or rd_world_any_hint gives it. */
#include <float.h>
#include <math.h>

#include "prim.h"
#include "world.h"

typedef struct {
    double omin[3], omax[3], imin[3], imax[3];
    int use[3], neg[3];
} frustum;

static void frustum_make(const rd_bvh_ray *br, unsigned rays, frustum *f)
{
    for (int k = 0; k < 3; k++) {
        f->use[k] = 1;
        f->neg[k] = -1;
        f->omin[k] = f->imin[k] = INFINITY;
        f->omax[k] = f->imax[k] = -INFINITY;
    }
    for (unsigned m = rays; m; m &= m - 1) {
        const rd_bvh_ray *b = &br[__builtin_ctz(m)];
        const double o[3] = {b->o.x, b->o.y, b->o.z}, inv[3] = {b->inv.x, b->inv.y, b->inv.z};
        for (int k = 0; k < 3; k++) {
            if (b->flat[k] || (f->neg[k] >= 0 && f->neg[k] != b->neg[k]))
                f->use[k] = 0;
            f->neg[k] = b->neg[k];
            f->omin[k] = o[k] < f->omin[k] ? o[k] : f->omin[k];
            f->omax[k] = o[k] > f->omax[k] ? o[k] : f->omax[k];
            f->imin[k] = inv[k] < f->imin[k] ? inv[k] : f->imin[k];
            f->imax[k] = inv[k] > f->imax[k] ? inv[k] : f->imax[k];
        }
    }
}

static inline __attribute__((always_inline)) double min4(double a, double b, double c, double d)
{
    double x = a < b ? a : b, y = c < d ? c : d;
    return x < y ? x : y;
}

static inline __attribute__((always_inline)) double max4(double a, double b, double c, double d)
{
    double x = a > b ? a : b, y = c > d ? c : d;
    return x > y ? x : y;
}

/* The children of n that some ray of the packet may meet within
 * [0, tmax]; tnear[i] a lower bound of every ray's entry into child i. */
static inline __attribute__((always_inline)) unsigned frustum_test(const rd_bvh4_node *n, const frustum *f, double tmax,
                                                                   double tnear[4])
{
    double t0[4] = {0, 0, 0, 0}, t1[4] = {tmax, tmax, tmax, tmax};
    for (int k = 0; k < 3; k++) {
        if (!f->use[k])
            continue;
        const float *lo = f->neg[k] ? n->hi[k] : n->lo[k], *hi = f->neg[k] ? n->lo[k] : n->hi[k];
        const double omin = f->omin[k], omax = f->omax[k], imin = f->imin[k], imax = f->imax[k];
        for (int c = 0; c < 4; c++) {
            double x0 = (double)lo[c] - omax, x1 = (double)lo[c] - omin;
            double y0 = (double)hi[c] - omax, y1 = (double)hi[c] - omin;
            double a = min4(x0 * imin, x0 * imax, x1 * imin, x1 * imax);
            double b = max4(y0 * imin, y0 * imax, y1 * imin, y1 * imax) * RD_BVH4_WIDEN;
            t0[c] = a > t0[c] ? a : t0[c];
            t1[c] = b < t1[c] ? b : t1[c];
        }
    }
    unsigned mask = 0;
    for (int c = 0; c < 4; c++) {
        tnear[c] = t0[c];
        /* An unused slot's box is empty (lo > hi): with every axis left
         * out, nothing else would turn it away. */
        mask |= (unsigned)(t0[c] <= t1[c] && n->lo[0][c] <= n->hi[0][c]) << c;
    }
    return mask;
}

/* An inner node to visit, and a lower bound of every ray's entry. */
typedef struct {
    uint32_t idx;
    double t;
} pvisit;

/* The largest cut of the packet's rays: a box entered beyond it by every
 * ray is skipped by every ray. */
static inline double widest_cut(const rd_best *b, unsigned rays)
{
    double t = 0;
    for (unsigned m = rays; m; m &= m - 1) {
        double c = b[__builtin_ctz(m)].cut;
        t = c > t ? c : t;
    }
    return t;
}

/* Inner children are visited nearest first by the packet's bounds; leaf
 * children at once, ray by ray, each ray with its own box test, cut and
 * floor (prim.h), as its own walk would. */
#define RD_PACKET_CLOSEST(NAME, ATTR, TEST)                                                                            \
    ATTR static void NAME(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, const rd_tri_ray *tr,              \
                          unsigned rays, rd_best *b)                                                                   \
    {                                                                                                                  \
        frustum f;                                                                                                     \
        frustum_make(br, rays, &f);                                                                                    \
        pvisit stack[RD_BVH4_STACK];                                                                                   \
        int sp = 0;                                                                                                    \
        stack[sp++] = (pvisit){0, 0};                                                                                  \
        while (sp > 0) {                                                                                               \
            pvisit v = stack[--sp];                                                                                    \
            double tcut = widest_cut(b, rays);                                                                         \
            if (v.t > tcut)                                                                                            \
                continue;                                                                                              \
            const rd_bvh4_node *n = &w->bvh4.nodes[v.idx];                                                             \
            double tn[4];                                                                                              \
            unsigned fm = frustum_test(n, &f, tcut, tn), leaves = 0;                                                   \
            for (int c = 0; c < 4; c++)                                                                                \
                leaves |= (unsigned)((fm >> c & 1) && n->count[c]) << c;                                               \
            for (unsigned m = leaves ? rays : 0; m; m &= m - 1) {                                                      \
                int i = __builtin_ctz(m);                                                                              \
                double ti[4];                                                                                          \
                for (unsigned hit = TEST(n, &br[i], b[i].cut, ti) & leaves; hit; hit &= hit - 1) {                     \
                    int c = __builtin_ctz(hit);                                                                        \
                    double floor = rd_leaf_floor(ti[c]);                                                               \
                    for (uint32_t k = 0; k < n->count[c]; k++)                                                         \
                        rd_prim_closest(w, w->bvh.prims[n->child[c] + k], r[i], &tr[i], floor, &b[i]);                 \
                }                                                                                                      \
            }                                                                                                          \
            /* Farthest first onto the stack, so the nearest is searched first. */                                     \
            int base = sp;                                                                                             \
            for (int c = 0; c < 4; c++) {                                                                              \
                if (!(fm >> c & 1) || n->count[c])                                                                     \
                    continue;                                                                                          \
                pvisit e = {n->child[c], tn[c]};                                                                       \
                int j = sp++;                                                                                          \
                while (j > base && stack[j - 1].t < e.t) {                                                             \
                    stack[j] = stack[j - 1];                                                                           \
                    j--;                                                                                               \
                }                                                                                                      \
                stack[j] = e;                                                                                          \
            }                                                                                                          \
        }                                                                                                              \
    }

#define RD_PACKET_ANY(NAME, ATTR, TEST)                                                                                \
    ATTR static unsigned NAME(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, const rd_tri_ray *tr,          \
                              const double *tmax, unsigned rays, uint32_t *last)                                       \
    {                                                                                                                  \
        frustum f;                                                                                                     \
        frustum_make(br, rays, &f);                                                                                    \
        double tcut = 0;                                                                                               \
        for (unsigned m = rays; m; m &= m - 1)                                                                         \
            tcut = tmax[__builtin_ctz(m)] > tcut ? tmax[__builtin_ctz(m)] : tcut;                                      \
        unsigned blocked = 0;                                                                                          \
        uint32_t stack[RD_BVH4_STACK];                                                                                 \
        int sp = 0;                                                                                                    \
        stack[sp++] = 0;                                                                                               \
        while (sp > 0 && rays) {                                                                                       \
            const rd_bvh4_node *n = &w->bvh4.nodes[stack[--sp]];                                                       \
            double tn[4];                                                                                              \
            unsigned fm = frustum_test(n, &f, tcut, tn), leaves = 0;                                                   \
            for (int c = 0; c < 4; c++) {                                                                              \
                if (!(fm >> c & 1))                                                                                    \
                    continue;                                                                                          \
                if (n->count[c])                                                                                       \
                    leaves |= 1u << c;                                                                                 \
                else                                                                                                   \
                    stack[sp++] = n->child[c];                                                                         \
            }                                                                                                          \
            for (unsigned m = leaves ? rays : 0; m; m &= m - 1) {                                                      \
                int i = __builtin_ctz(m);                                                                              \
                unsigned hit = TEST(n, &br[i], tmax[i], tn) & leaves;                                                  \
                for (; hit; hit &= hit - 1) {                                                                          \
                    int c = __builtin_ctz(hit);                                                                        \
                    uint32_t k = 0;                                                                                    \
                    while (k < n->count[c] && !rd_prim_any(w, w->bvh.prims[n->child[c] + k], r[i], &tr[i], tmax[i]))   \
                        k++;                                                                                           \
                    if (k < n->count[c]) {                                                                             \
                        *last = w->bvh.prims[n->child[c] + k] + 1;                                                     \
                        blocked |= 1u << i;                                                                            \
                        rays &= ~(1u << i);                                                                            \
                        break;                                                                                         \
                    }                                                                                                  \
                }                                                                                                      \
            }                                                                                                          \
        }                                                                                                              \
        return blocked;                                                                                                \
    }

RD_PACKET_CLOSEST(closest_sse2, __attribute__((noinline)), rd_bvh4_test_sse2)
RD_PACKET_CLOSEST(closest_avx2, __attribute__((noinline, target("avx2"))), rd_bvh4_test_avx2)
RD_PACKET_ANY(any_sse2, __attribute__((noinline)), rd_bvh4_test_sse2)
RD_PACKET_ANY(any_avx2, __attribute__((noinline, target("avx2"))), rd_bvh4_test_avx2)

unsigned rd_world_closest_packet(const rd_world *w, const rd_ray *r, int n, double tmax, rd_hit *h)
{
    if (!w->use_bvh || n < 2) {
        unsigned found = 0;
        for (int i = 0; i < n; i++)
            found |= (unsigned)rd_world_closest(w, r[i], tmax, &h[i]) << i;
        return found;
    }
    rd_best b[RD_PACKET_MAX];
    rd_bvh_ray br[RD_PACKET_MAX];
    rd_tri_ray tr[RD_PACKET_MAX];
    for (int i = 0; i < n; i++) {
        b[i] = rd_best_make(tmax);
        rd_world_planes_closest(w, r[i], &b[i]);
        br[i] = rd_bvh_ray_make(r[i]);
        tr[i] = rd_prim_tri_ray(w, r[i]);
    }
    unsigned all = (1u << n) - 1;
    if (w->avx2)
        closest_avx2(w, r, br, tr, all, b);
    else
        closest_sse2(w, r, br, tr, all, b);
    unsigned found = 0;
    for (int i = 0; i < n; i++) {
        if (b[i].kind == RD_K_NONE)
            continue;
        rd_world_finish_hit(w, r[i], &b[i], &h[i]);
        found |= 1u << i;
    }
    return found;
}

unsigned rd_world_any_packet(const rd_world *w, const rd_ray *r, const double *tmax, int n, uint32_t *last)
{
    if (!w->use_bvh || n < 2) {
        unsigned blocked = 0;
        for (int i = 0; i < n; i++)
            blocked |= (unsigned)rd_world_any_hint(w, r[i], tmax[i], last) << i;
        return blocked;
    }
    unsigned blocked = 0, rays = 0;
    rd_bvh_ray br[RD_PACKET_MAX];
    rd_tri_ray tr[RD_PACKET_MAX];
    for (int i = 0; i < n; i++) {
        int hit = 0;
        for (size_t k = 0; k < w->nplanes && !hit; k++)
            hit = rd_plane_intersect(&w->planes[k], r[i], tmax[i]) > 0;
        tr[i] = rd_prim_tri_ray(w, r[i]);
        /* The occluder of the last blocked ray first (world.h). */
        if (!hit && last && *last)
            hit = rd_prim_any(w, *last - 1, r[i], &tr[i], tmax[i]);
        if (hit) {
            blocked |= 1u << i;
            continue;
        }
        br[i] = rd_bvh_ray_make(r[i]);
        rays |= 1u << i;
    }
    if (!rays)
        return blocked;
    uint32_t sink = 0;
    uint32_t *keep = last ? last : &sink;
    return blocked | (w->avx2 ? any_avx2(w, r, br, tr, tmax, rays, keep) : any_sse2(w, r, br, tr, tmax, rays, keep));
}
