/* The bounded primitives' tests as the BVH walks call them, shared by the
 * single-ray walks (world.c) and the packet walks (packet.c).
 *
 * A closest hit must not depend on the order in which a walk meets the
 * primitives, or a packet (whose order is the packet's, not the ray's)
 * could shade a pixel differently from a lone ray. Two rules make it so:
 *
 * - Between primitives at exactly the same t, the lower BVH id (spheres,
 *   then triangles, in scene order) wins, as in the plain loops of a world
 *   without a BVH. A plane (tested first) keeps a tie, as before.
 * - A walk skips a box only when its entry t0 exceeds the cut, the best t
 *   so far times 1 + 2^-18; and a primitive's hit counts only when t is at
 *   least its leaf box's entry times 1 - 2^-20 (its floor). A skipped box
 *   therefore holds no hit that could win or tie, whenever it is skipped.
 *   Entries are monotone under containment (rounding is monotone, and a
 *   parent's float box contains its children's), so this holds for inner
 *   nodes too. The floor only drops a hit that rounding put before its own
 *   box by a millionth of its distance, which sound geometry never does.
 *
 * So the closest hit is the least (t, id) over the hits that count,
 * whatever the walk. */
#ifndef RD_PRIM_H
#define RD_PRIM_H

#include <stdint.h>
#include <string.h>

#include "triangle.h"
#include "world.h"

/* What a closest-hit search has found so far. */
enum { RD_K_NONE, RD_K_SPHERE, RD_K_PLANE, RD_K_TRI };

#define RD_CUT_UP (1 + 0x1p-18)
#define RD_FLOOR_DOWN (1 - 0x1p-20)

typedef struct {
    double t;     /* the hit's distance; tmax while none */
    double limit; /* what a primitive's t must stay below to be taken */
    double cut;   /* boxes entered beyond it are skipped */
    int kind;     /* RD_K_* */
    size_t idx;   /* index among its kind; a triangle's slot in w->tris */
    uint32_t id;  /* BVH id of a sphere or triangle */
    double bary[3];
} rd_best;

/* The next double above t > 0 (t itself when infinite): a BVH primitive
 * at exactly t must still be tested, to compare ids. */
static inline double rd_next_up(double t)
{
    if (!(t < INFINITY))
        return t;
    uint64_t bits;
    memcpy(&bits, &t, sizeof bits);
    bits++;
    memcpy(&t, &bits, sizeof t);
    return t;
}

static inline rd_best rd_best_make(double tmax)
{
    return (rd_best){tmax, tmax, tmax * RD_CUT_UP, RD_K_NONE, 0, UINT32_MAX, {0, 0, 0}};
}

/* The floor of a leaf whose box the ray enters at t0. */
static inline double rd_leaf_floor(double t0) { return t0 * RD_FLOOR_DOWN; }

/* Whether a primitive at t (already below b->limit) with BVH id `id`
 * replaces b. */
static inline int rd_best_takes(const rd_best *b, double t, uint32_t id) { return t < b->t || id < b->id; }

static inline void rd_best_set(rd_best *b, double t, int kind, size_t idx, uint32_t id)
{
    b->t = t;
    b->kind = kind;
    b->idx = idx;
    b->id = id;
    /* Ties with a plane (found first) or with tmax itself are lost. */
    b->limit = kind == RD_K_PLANE ? t : rd_next_up(t);
    b->cut = t * RD_CUT_UP;
}

/* The triangle test's per-ray part (its shear and three divisions), made
 * when a ray first reaches a triangle: most rays of a sphere scene, or of
 * a mesh's empty surroundings, never do. */
typedef struct {
    rd_tri_ray tr;
    int made;
} rd_tri_lazy;

static inline rd_tri_lazy rd_tri_lazy_none(void) { return (rd_tri_lazy){.made = 0}; }

static inline __attribute__((always_inline)) const rd_tri_ray *rd_tri_lazy_get(rd_tri_lazy *l, const rd_ray *r)
{
    if (!l->made) {
        l->tr = rd_tri_ray_make(*r);
        l->made = 1;
    }
    return &l->tr;
}

/* Whether the leaf `hint` names (as rd_world_any_hint leaves it) blocks the
 * ray: its box as the ray's walk tests it, then its primitives. */
int rd_world_hint_blocks(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, rd_tri_lazy *tr, double tmax,
                         uint32_t hint);

/* Primitive id against b; floor: its leaf's (0 outside a BVH). */
static inline __attribute__((always_inline)) void rd_prim_closest(const rd_world *w, uint32_t id, const rd_ray *r,
                                                                  rd_tri_lazy *tr, double floor, rd_best *b)
{
    if (id < w->nspheres) {
        double t = rd_sphere_intersect(&w->spheres[id], *r, b->limit);
        if (t > 0 && t >= floor && rd_best_takes(b, t, id))
            rd_best_set(b, t, RD_K_SPHERE, id, id);
        return;
    }
    size_t at = rd_world_tri_slot(w, id - w->nspheres);
    double bary[3];
    double t = rd_tri_intersect_ray(w->tris[at].v, rd_tri_lazy_get(tr, r), b->limit, bary);
    if (t > 0 && t >= floor && rd_best_takes(b, t, id)) {
        rd_best_set(b, t, RD_K_TRI, at, id);
        memcpy(b->bary, bary, sizeof bary);
    }
}

static inline __attribute__((always_inline)) int rd_prim_any(const rd_world *w, uint32_t id, const rd_ray *r,
                                                             rd_tri_lazy *tr, double tmax)
{
    if (id < w->nspheres)
        return rd_sphere_intersect(&w->spheres[id], *r, tmax) > 0;
    double bary[3];
    return rd_tri_intersect_ray(rd_world_tri(w, id - w->nspheres)->v, rd_tri_lazy_get(tr, r), tmax, bary) > 0;
}

/* Triangle p of the leaf order (world.h) against b; its id is read only
 * when its hit counts. */
static inline __attribute__((always_inline)) void rd_leaf_tri_closest(const rd_world *w, uint32_t p, const rd_ray *r,
                                                                      rd_tri_lazy *tr, double floor, rd_best *b)
{
    double bary[3];
    size_t at = p - w->tri_first;
    double t = rd_tri_intersect_ray(w->tris[at].v, rd_tri_lazy_get(tr, r), b->limit, bary);
    if (!(t > 0 && t >= floor))
        return;
    uint32_t id = w->bvh.prims[p];
    if (rd_best_takes(b, t, id)) {
        rd_best_set(b, t, RD_K_TRI, at, id);
        memcpy(b->bary, bary, sizeof bary);
    }
}

/* The bits of a leaf's triangles among its count primitives. */
static inline unsigned rd_leaf_tris(uint32_t count, uint16_t spheres)
{
    return ~(unsigned)spheres & ((1u << count) - 1);
}

/* The primitives of the leaf [first, first + count) of bvh.prims, whose
 * kinds are `spheres` (rd_bvh4_node.spheres), against b. */
static inline __attribute__((always_inline)) void rd_leaf_closest(const rd_world *w, uint32_t first, uint32_t count,
                                                                  uint16_t spheres, const rd_ray *r, rd_tri_lazy *tr,
                                                                  double floor, rd_best *b)
{
    if (count > RD_BVH4_KINDS) {
        for (uint32_t i = 0; i < count; i++)
            rd_prim_closest(w, w->bvh.prims[first + i], r, tr, floor, b);
        return;
    }
    for (unsigned m = spheres; m; m &= m - 1)
        rd_prim_closest(w, w->bvh.prims[first + (uint32_t)__builtin_ctz(m)], r, tr, floor, b);
    for (unsigned m = rd_leaf_tris(count, spheres); m; m &= m - 1)
        rd_leaf_tri_closest(w, first + (uint32_t)__builtin_ctz(m), r, tr, floor, b);
}

/* 1 when a triangle of the leaf at first + a bit of `tris` blocks the ray. */
static inline __attribute__((always_inline)) int rd_leaf_tris_any(const rd_world *w, uint32_t first, unsigned tris,
                                                                  const rd_ray *r, rd_tri_lazy *tr, double tmax)
{
    double bary[3];
    for (unsigned m = tris; m; m &= m - 1)
        if (rd_tri_intersect_ray(w->tris[first + (uint32_t)__builtin_ctz(m) - w->tri_first].v, rd_tri_lazy_get(tr, r),
                                 tmax, bary) > 0)
            return 1;
    return 0;
}

/* 1 when a primitive of the leaf blocks the ray within tmax. */
static inline __attribute__((always_inline)) int rd_leaf_any(const rd_world *w, uint32_t first, uint32_t count,
                                                             uint16_t spheres, const rd_ray *r, rd_tri_lazy *tr,
                                                             double tmax)
{
    if (count > RD_BVH4_KINDS) {
        for (uint32_t i = 0; i < count; i++)
            if (rd_prim_any(w, w->bvh.prims[first + i], r, tr, tmax))
                return 1;
        return 0;
    }
    for (unsigned m = spheres; m; m &= m - 1)
        if (rd_prim_any(w, w->bvh.prims[first + (uint32_t)__builtin_ctz(m)], r, tr, tmax))
            return 1;
    return rd_leaf_tris_any(w, first, rd_leaf_tris(count, spheres), r, tr, tmax);
}

/* Pushes entry e (with a field t) onto a walk's stack, among the entries
 * above index base kept in decreasing t, so that the nearest is searched
 * first and shrinks the cut the soonest. */
#define RD_PUSH_NEAREST_ON_TOP(stack, sp, base, e)                                                                     \
    do {                                                                                                               \
        int j_ = (sp)++;                                                                                               \
        while (j_ > (base) && (stack)[j_ - 1].t < (e).t) {                                                             \
            (stack)[j_] = (stack)[j_ - 1];                                                                             \
            j_--;                                                                                                      \
        }                                                                                                              \
        (stack)[j_] = (e);                                                                                             \
    } while (0)

/* 1 when a plane lies on the ray at t in (0, tmax). */
int rd_world_planes_any(const rd_world *w, rd_ray r, double tmax);

/* The planes, tested before anything else (they win ties). */
void rd_world_planes_closest(const rd_world *w, rd_ray r, rd_best *b);

/* h from what a search found (b->kind not RD_K_NONE), as rd_world_closest
 * fills it. */
void rd_world_finish_hit(const rd_world *w, rd_ray r, const rd_best *b, rd_hit *h);

#endif
