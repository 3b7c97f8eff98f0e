/* Packets of up to RD_PACKET_MAX coherent rays walked through the
 * four-wide BVH together (world.h, rd_world_closest_packet).
 *
 * Each node is tested for all the packet's rays still walking there, and
 * each ray with its own slab test: the masks of the rays that enter each
 * child go down with it. With AVX-512 the test runs eight rays to a
 * register, one child at a time, with the same double operations in the
 * same order as the four-wide test of one ray (bvh4.h), so every lane gets
 * exactly the accept bit and entry distance that test gives its ray; other
 * CPUs run that test ray by ray. A packet thus saves the loads, the stack
 * and the branches of the nodes its rays share, and with AVX-512 half the
 * box arithmetic; each ray makes exactly the decisions of its own walk.
 *
 * Closest hits: a ray tests a child within its own cut, a leaf's
 * primitives with its own floor (prim.h), so its hit is the one its own
 * walk finds whatever order the packet takes. Any-hit answers do not
 * depend on order. */
#include <float.h>
#include <immintrin.h>
#include <math.h>

#include "prim.h"
#include "world.h"

/* A packet's rays as the node tests read them. */
typedef struct {
    rd_bvh_ray br[RD_PACKET_MAX];
    /* By lanes, for AVX-512: two groups of eight. */
    double o[3][RD_PACKET_MAX], inv[3][RD_PACKET_MAX];
    uint8_t neg[3][2], flat[3][2];
} packet;

static void packet_lanes(packet *p, int n)
{
    memset(p->neg, 0, sizeof p->neg);
    memset(p->flat, 0, sizeof p->flat);
    for (int i = 0; i < RD_PACKET_MAX; i++) {
        const rd_bvh_ray *b = &p->br[i < n ? i : 0];
        const double o[3] = {b->o.x, b->o.y, b->o.z}, inv[3] = {b->inv.x, b->inv.y, b->inv.z};
        for (int k = 0; k < 3; k++) {
            p->o[k][i] = o[k];
            p->inv[k][i] = inv[k];
            p->neg[k][i / 8] |= (uint8_t)(b->neg[k] << (i % 8));
            p->flat[k][i / 8] |= (uint8_t)(b->flat[k] << (i % 8));
        }
    }
}

/* Which rays of a node's visitors enter each child (mask[c]), and where
 * (t[c][i]); a ray's tmax is tmax[i]. */
typedef struct {
    unsigned mask[4];
    double t[4][RD_PACKET_MAX];
} node_hits;

#define RD_NODE_PER_RAY(NAME, ATTR, TEST)                                                                              \
    ATTR static inline void NAME(const rd_bvh4_node *n, const packet *p, unsigned rays, const double *tmax,            \
                                 node_hits *nh)                                                                        \
    {                                                                                                                  \
        nh->mask[0] = nh->mask[1] = nh->mask[2] = nh->mask[3] = 0;                                                     \
        for (unsigned m = rays; m; m &= m - 1) {                                                                       \
            int i = __builtin_ctz(m);                                                                                  \
            double tn[4];                                                                                              \
            for (unsigned hit = TEST(n, &p->br[i], tmax[i], tn); hit; hit &= hit - 1) {                                \
                int c = __builtin_ctz(hit);                                                                            \
                nh->mask[c] |= 1u << i;                                                                                \
                nh->t[c][i] = tn[c];                                                                                   \
            }                                                                                                          \
        }                                                                                                              \
    }

RD_NODE_PER_RAY(node_sse2, __attribute__((always_inline)), rd_bvh4_test_sse2)
RD_NODE_PER_RAY(node_avx2, __attribute__((always_inline, target("avx2"))), rd_bvh4_test_avx2)

/* rd_bvh4_test_avx2 for eight rays and one child: its operations lane by
 * lane, a flat axis's lanes kept out of the distances by the mask as that
 * test skips them. */
#define RD_AVX512 "avx512f,avx2"
static inline __attribute__((always_inline, target(RD_AVX512))) __mmask8
box8(const rd_bvh4_node *n, int c, const packet *p, int g, __m512d tmax, __m512d *tnear)
{
    __m512d t0 = _mm512_setzero_pd(), t1 = tmax;
    const __m512d widen = _mm512_set1_pd(RD_BVH4_WIDEN);
    __mmask8 in = 0xff;
    for (int k = 0; k < 3; k++) {
        __m512d lo = _mm512_set1_pd(n->lo[k][c]), hi = _mm512_set1_pd(n->hi[k][c]);
        __m512d o = _mm512_loadu_pd(p->o[k] + 8 * g), inv = _mm512_loadu_pd(p->inv[k] + 8 * g);
        __mmask8 neg = p->neg[k][g], flat = p->flat[k][g];
        __mmask8 inside = _mm512_cmp_pd_mask(o, lo, _CMP_GE_OQ) & _mm512_cmp_pd_mask(o, hi, _CMP_LE_OQ);
        in &= (__mmask8)(~flat | inside);
        __m512d l = _mm512_mask_blend_pd(neg, lo, hi), u = _mm512_mask_blend_pd(neg, hi, lo);
        __m512d a = _mm512_mul_pd(_mm512_sub_pd(l, o), inv);
        __m512d b = _mm512_mul_pd(_mm512_mul_pd(_mm512_sub_pd(u, o), inv), widen);
        t0 = _mm512_mask_max_pd(t0, (__mmask8)~flat, a, t0);
        t1 = _mm512_mask_min_pd(t1, (__mmask8)~flat, b, t1);
    }
    *tnear = t0;
    return in & _mm512_cmp_pd_mask(t0, t1, _CMP_LE_OQ);
}

static inline __attribute__((always_inline, target(RD_AVX512))) void
node_avx512(const rd_bvh4_node *n, const packet *p, unsigned rays, const double *tmax, node_hits *nh)
{
    nh->mask[0] = nh->mask[1] = nh->mask[2] = nh->mask[3] = 0;
    for (int g = 0; g < 2; g++) {
        __mmask8 act = (__mmask8)(rays >> (8 * g));
        if (!act)
            continue;
        __m512d tm = _mm512_loadu_pd(tmax + 8 * g);
        for (int c = 0; c < 4; c++) {
            __m512d t0;
            __mmask8 m = box8(n, c, p, g, tm, &t0) & act;
            nh->mask[c] |= (unsigned)m << (8 * g);
            _mm512_storeu_pd(nh->t[c] + 8 * g, t0);
        }
    }
}

/* A node to visit, the rays that visit it, and the least of their entries. */
typedef struct {
    uint32_t idx;
    unsigned rays;
    double t;
} pvisit;

static inline double least_entry(const node_hits *nh, int c)
{
    double t = INFINITY;
    for (unsigned m = nh->mask[c]; m; m &= m - 1)
        t = nh->t[c][__builtin_ctz(m)] < t ? nh->t[c][__builtin_ctz(m)] : t;
    return t;
}

/* Leaves are searched as soon as their node is tested, ray by ray; inner
 * children go on the stack nearest on top. */
#define RD_PACKET_CLOSEST(NAME, ATTR, NODE)                                                                            \
    ATTR static void NAME(const rd_world *w, const rd_ray *r, const packet *p, rd_tri_lazy *tr, unsigned rays,         \
                          rd_best *b)                                                                                  \
    {                                                                                                                  \
        double cut[RD_PACKET_MAX];                                                                                     \
        for (int i = 0; i < RD_PACKET_MAX; i++)                                                                        \
            cut[i] = rays >> i & 1 ? b[i].cut : 0;                                                                     \
        pvisit stack[RD_BVH4_STACK];                                                                                   \
        int sp = 0;                                                                                                    \
        stack[sp++] = (pvisit){0, rays, 0};                                                                            \
        while (sp > 0) {                                                                                               \
            pvisit v = stack[--sp];                                                                                    \
            /* The rays that still reach the node within their cut. */                                                 \
            unsigned live = 0;                                                                                         \
            for (unsigned m = v.rays; m; m &= m - 1)                                                                   \
                live |= (unsigned)(v.t <= cut[__builtin_ctz(m)]) << __builtin_ctz(m);                                  \
            if (!live)                                                                                                 \
                continue;                                                                                              \
            const rd_bvh4_node *n = &w->bvh4.nodes[v.idx];                                                             \
            node_hits nh;                                                                                              \
            NODE(n, p, live, cut, &nh);                                                                                \
            for (int c = 0; c < 4; c++) {                                                                              \
                if (!n->count[c])                                                                                      \
                    continue;                                                                                          \
                for (unsigned m = nh.mask[c]; m; m &= m - 1) {                                                         \
                    int i = __builtin_ctz(m);                                                                          \
                    double floor = rd_leaf_floor(nh.t[c][i]);                                                          \
                    for (uint32_t k = 0; k < n->count[c]; k++)                                                         \
                        rd_prim_closest(w, w->bvh.prims[n->child[c] + k], &r[i], &tr[i], floor, &b[i]);                \
                    cut[i] = b[i].cut;                                                                                 \
                }                                                                                                      \
            }                                                                                                          \
            int base = sp;                                                                                             \
            for (int c = 0; c < 4; c++) {                                                                              \
                if (n->count[c] || !nh.mask[c])                                                                        \
                    continue;                                                                                          \
                pvisit e = {n->child[c], nh.mask[c], least_entry(&nh, c)};                                             \
                RD_PUSH_NEAREST_ON_TOP(stack, sp, base, e);                                                            \
            }                                                                                                          \
        }                                                                                                              \
    }

#define RD_PACKET_ANY(NAME, ATTR, NODE)                                                                                \
    ATTR static unsigned NAME(const rd_world *w, const rd_ray *r, const packet *p, rd_tri_lazy *tr,                    \
                              const double *tmax, unsigned rays, uint32_t *last)                                       \
    {                                                                                                                  \
        double tm[RD_PACKET_MAX];                                                                                      \
        for (int i = 0; i < RD_PACKET_MAX; i++)                                                                        \
            tm[i] = rays >> i & 1 ? tmax[i] : 0;                                                                       \
        unsigned blocked = 0;                                                                                          \
        struct {                                                                                                       \
            uint32_t idx;                                                                                              \
            unsigned rays;                                                                                             \
        } stack[RD_BVH4_STACK];                                                                                        \
        int sp = 0;                                                                                                    \
        stack[sp].idx = 0;                                                                                             \
        stack[sp++].rays = rays;                                                                                       \
        while (sp > 0 && rays) {                                                                                       \
            sp--;                                                                                                      \
            unsigned live = stack[sp].rays & rays;                                                                     \
            if (!live)                                                                                                 \
                continue;                                                                                              \
            uint32_t node = stack[sp].idx;                                                                             \
            const rd_bvh4_node *n = &w->bvh4.nodes[node];                                                              \
            node_hits nh;                                                                                              \
            NODE(n, p, live, tm, &nh);                                                                                 \
            for (int c = 0; c < 4; c++) {                                                                              \
                if (!n->count[c]) {                                                                                    \
                    if (nh.mask[c]) {                                                                                  \
                        stack[sp].idx = n->child[c];                                                                   \
                        stack[sp++].rays = nh.mask[c];                                                                 \
                    }                                                                                                  \
                    continue;                                                                                          \
                }                                                                                                      \
                for (unsigned m = nh.mask[c] & rays; m; m &= m - 1) {                                                  \
                    int i = __builtin_ctz(m);                                                                          \
                    for (uint32_t k = 0; k < n->count[c]; k++) {                                                       \
                        uint32_t id = w->bvh.prims[n->child[c] + k];                                                   \
                        if (rd_prim_any(w, id, &r[i], &tr[i], tmax[i])) {                                              \
                            *last = rd_world_hint(node, c);                                                            \
                            blocked |= 1u << i;                                                                        \
                            rays &= ~(1u << i);                                                                        \
                            break;                                                                                     \
                        }                                                                                              \
                    }                                                                                                  \
                }                                                                                                      \
            }                                                                                                          \
        }                                                                                                              \
        return blocked;                                                                                                \
    }

RD_PACKET_CLOSEST(closest_sse2, __attribute__((noinline)), node_sse2)
RD_PACKET_CLOSEST(closest_avx2, __attribute__((noinline, target("avx2"))), node_avx2)
RD_PACKET_CLOSEST(closest_avx512, __attribute__((noinline, target(RD_AVX512))), node_avx512)
RD_PACKET_ANY(any_sse2, __attribute__((noinline)), node_sse2)
RD_PACKET_ANY(any_avx2, __attribute__((noinline, target("avx2"))), node_avx2)
RD_PACKET_ANY(any_avx512, __attribute__((noinline, target(RD_AVX512))), node_avx512)

/* A ray the walks turn away (rd_ray_finite) would accept every box of
 * the packet's walk: such packets go ray by ray. */
static int all_finite(const rd_ray *r, int n)
{
    int ok = 1;
    for (int i = 0; i < n; i++)
        ok &= rd_ray_finite(r[i]);
    return ok;
}

unsigned rd_world_closest_packet(const rd_world *w, const rd_ray *r, int n, double tmax, rd_hit *h)
{
    if (!w->use_bvh || n < 2 || !all_finite(r, n)) {
        unsigned found = 0;
        for (int i = 0; i < n; i++)
            found |= (unsigned)rd_world_closest(w, r[i], tmax, &h[i]) << i;
        return found;
    }
    rd_best b[RD_PACKET_MAX];
    packet p;
    rd_tri_lazy tr[RD_PACKET_MAX];
    for (int i = 0; i < n; i++) {
        b[i] = rd_best_make(tmax);
        rd_world_planes_closest(w, r[i], &b[i]);
        p.br[i] = rd_bvh_ray_make(r[i]);
        tr[i] = rd_tri_lazy_none();
    }
    unsigned all = (1u << n) - 1;
    if (w->avx512) {
        packet_lanes(&p, n);
        closest_avx512(w, r, &p, tr, all, b);
    } else if (w->avx2) {
        closest_avx2(w, r, &p, tr, all, b);
    } else {
        closest_sse2(w, r, &p, tr, all, b);
    }
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
    if (!w->use_bvh || n < 2 || !all_finite(r, n)) {
        unsigned blocked = 0;
        for (int i = 0; i < n; i++)
            blocked |= (unsigned)rd_world_any_hint(w, r[i], tmax[i], last) << i;
        return blocked;
    }
    unsigned blocked = 0, rays = 0;
    packet p;
    rd_tri_lazy tr[RD_PACKET_MAX];
    for (int i = 0; i < n; i++) {
        if (rd_world_planes_any(w, r[i], tmax[i])) {
            blocked |= 1u << i;
            continue;
        }
        tr[i] = rd_tri_lazy_none();
        p.br[i] = rd_bvh_ray_make(r[i]);
        /* The leaf that blocked the last blocked ray first (world.h). */
        if (last && *last && rd_world_hint_blocks(w, &r[i], &p.br[i], &tr[i], tmax[i], *last)) {
            blocked |= 1u << i;
            continue;
        }
        rays |= 1u << i;
    }
    if (!rays)
        return blocked;
    uint32_t sink = 0;
    uint32_t *keep = last ? last : &sink;
    if (w->avx512) {
        /* Lanes of rays that are not walked hold the first ray (never
         * read): their arithmetic stays finite. */
        for (int i = 0; i < n; i++)
            if (!(rays >> i & 1))
                p.br[i] = p.br[__builtin_ctz(rays)];
        packet_lanes(&p, n);
        blocked |= any_avx512(w, r, &p, tr, tmax, rays, keep);
    } else {
        blocked |= w->avx2 ? any_avx2(w, r, &p, tr, tmax, rays, keep) : any_sse2(w, r, &p, tr, tmax, rays, keep);
    }
    /* As rd_world_any_hint: a packet that all reached the light forgets. */
    if (!blocked)
        *keep = 0;
    return blocked;
}
