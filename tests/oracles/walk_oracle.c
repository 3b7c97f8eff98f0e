#include "walk_oracle.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "bvh4.h"
#include "prim.h"

/* Every node reachable through accepted boxes: a depth-first stack holds
 * at most three more entries than it pops a level (bvh4.h). */
typedef void (*leaf_fn)(const rd_world *w, uint32_t first, uint32_t count, double t0, void *arg);

static int visit_accepted(const rd_world *w, const rd_bvh_ray *br, double tmax, leaf_fn fn, void *arg)
{
    uint32_t stack[RD_BVH4_STACK];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const rd_bvh4_node *n = &w->bvh4.nodes[stack[--sp]];
        double tn[4];
        unsigned m = rd_bvh4_test_sse2(n, br, tmax, tn);
        for (int i = 0; i < 4; i++) {
            /* An unused slot (an empty box) is nothing, whatever a test of a
             * NaN ray says of it. */
            if (!(m >> i & 1) || !(n->lo[0][i] <= n->hi[0][i]))
                continue;
            if (n->count[i]) {
                fn(w, n->child[i], n->count[i], tn[i], arg);
            } else {
                if (sp == RD_BVH4_STACK)
                    return -1;
                stack[sp++] = n->child[i];
            }
        }
    }
    return 0;
}

typedef struct {
    rd_ray r;
    rd_tri_lazy tr;
    rd_best b;
    double tmax;
    int any;
} query;

static void closest_leaf(const rd_world *w, uint32_t first, uint32_t count, double t0, void *arg)
{
    query *q = arg;
    for (uint32_t i = 0; i < count; i++)
        rd_prim_closest(w, w->bvh.prims[first + i], &q->r, &q->tr, rd_leaf_floor(t0), &q->b);
}

static void any_leaf(const rd_world *w, uint32_t first, uint32_t count, double t0, void *arg)
{
    (void)t0;
    query *q = arg;
    for (uint32_t i = 0; i < count && !q->any; i++)
        q->any = rd_prim_any(w, w->bvh.prims[first + i], &q->r, &q->tr, q->tmax);
}

int walk_oracle_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h)
{
    query q = {.r = r, .tr = rd_tri_lazy_none(), .b = rd_best_make(tmax), .tmax = tmax, .any = 0};
    rd_world_planes_closest(w, r, &q.b);
    if (w->use_bvh) {
        rd_bvh_ray br = rd_bvh_ray_make(r);
        if (visit_accepted(w, &br, q.b.cut, closest_leaf, &q))
            return -1;
    } else {
        for (size_t i = 0; i < w->nspheres + w->ntris; i++)
            rd_prim_closest(w, (uint32_t)i, &r, &q.tr, 0, &q.b);
    }
    if (q.b.kind == RD_K_NONE)
        return 0;
    rd_world_finish_hit(w, r, &q.b, h);
    return 1;
}

int walk_oracle_any(const rd_world *w, rd_ray r, double tmax)
{
    if (rd_world_planes_any(w, r, tmax))
        return 1;
    query q = {.r = r, .tr = rd_tri_lazy_none(), .tmax = tmax, .any = 0};
    if (w->use_bvh) {
        rd_bvh_ray br = rd_bvh_ray_make(r);
        if (visit_accepted(w, &br, tmax, any_leaf, &q))
            return -1;
        return q.any;
    }
    for (size_t i = 0; i < w->nspheres + w->ntris && !q.any; i++)
        q.any = rd_prim_any(w, (uint32_t)i, &r, &q.tr, tmax);
    return q.any;
}

static int same_double(double a, double b) { return !memcmp(&a, &b, sizeof a); }

static int same_vec(rd_vec3 a, rd_vec3 b)
{
    return same_double(a.x, b.x) && same_double(a.y, b.y) && same_double(a.z, b.z);
}

#define DIFF_D(field)                                                                                                  \
    if (!same_double(a->field, b->field))                                                                              \
        return snprintf(why, n, #field " %a against %a", a->field, b->field), 0;
#define DIFF_V(field)                                                                                                  \
    if (!same_vec(a->field, b->field))                                                                                 \
        return snprintf(why, n, #field " (%a, %a, %a) against (%a, %a, %a)", a->field.x, a->field.y, a->field.z,       \
                        b->field.x, b->field.y, b->field.z),                                                           \
               0;
#define DIFF_I(field)                                                                                                  \
    if (a->field != b->field)                                                                                          \
        return snprintf(why, n, #field " %lld against %lld", (long long)a->field, (long long)b->field), 0;

int walk_oracle_same_hit(const rd_hit *a, const rd_hit *b, char *why, size_t n)
{
    DIFF_I(prim_kind)
    DIFF_I(prim)
    DIFF_I(object)
    DIFF_I(material)
    DIFF_D(t)
    DIFF_V(p)
    DIFF_V(ng)
    DIFF_V(n)
    DIFF_I(front)
    DIFF_D(perr)
    DIFF_D(u)
    DIFF_D(v)
    if (a->prim_kind == RD_K_TRI)
        for (int i = 0; i < 3; i++)
            DIFF_D(bary[i])
    return 1;
}
