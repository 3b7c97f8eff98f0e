#include "bvh.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

/* BINS: SAH bins per axis. LEAF_MAX: primitives per leaf the estimate of
 * node count assumes. SMALL_LEAF: a node this small becomes a leaf when no
 * split is cheaper; a larger one is split even so. */
enum { BINS = 16, LEAF_MAX = 4, SMALL_LEAF = 16, MAX_DEPTH = RD_BVH_STACK - 8 };

static float down(double x)
{
    float f = (float)x;
    if ((double)f > x)
        f = nextafterf(f, -INFINITY);
    return f;
}

static float up(double x)
{
    float f = (float)x;
    if ((double)f < x)
        f = nextafterf(f, INFINITY);
    return f;
}

typedef struct {
    float lo[3], hi[3];
} box;

static void box_empty(box *b)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = INFINITY;
        b->hi[k] = -INFINITY;
    }
}

/* Plain comparisons: bounds are never NaN, and fminf/fmaxf are library
 * calls that dominated the build. */
static inline void box_grow(box *b, const box *o)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = o->lo[k] < b->lo[k] ? o->lo[k] : b->lo[k];
        b->hi[k] = o->hi[k] > b->hi[k] ? o->hi[k] : b->hi[k];
    }
}

static inline void box_grow_point(box *b, const float *c)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = c[k] < b->lo[k] ? c[k] : b->lo[k];
        b->hi[k] = c[k] > b->hi[k] ? c[k] : b->hi[k];
    }
}

static double box_area(const box *b)
{
    double d[3];
    for (int k = 0; k < 3; k++) {
        d[k] = (double)b->hi[k] - (double)b->lo[k];
        if (!(d[k] > 0))
            d[k] = 0;
    }
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

/* A primitive as the build sees it. The records themselves are
 * partitioned, so every pass reads memory in order: indirection through an
 * index array made 1M-primitive builds cache-bound. */
typedef struct {
    box b;
    float c[3];
    uint32_t id;
} rec;

typedef struct {
    rd_bvh *b;
    rec *r;
    size_t cap;
} builder;

static uint32_t new_node(builder *bd)
{
    if (bd->b->nnodes == bd->cap) {
        size_t nc = bd->cap * 2;
        rd_bvh_node *p = realloc(bd->b->nodes, nc * sizeof *p);
        if (!p)
            return UINT32_MAX;
        bd->b->nodes = p;
        bd->cap = nc;
    }
    return (uint32_t)bd->b->nnodes++;
}

/* Splits prims[first, first+count) recursively; returns 0 on out of memory. */
static int build(builder *bd, uint32_t node, size_t first, size_t count, int depth)
{
    rec *r = bd->r;
    box bounds, cb;
    box_empty(&bounds);
    box_empty(&cb);
    for (size_t i = first; i < first + count; i++) {
        box_grow(&bounds, &r[i].b);
        box_grow_point(&cb, r[i].c);
    }
    rd_bvh_node *n = &bd->b->nodes[node];
    memcpy(n->lo, bounds.lo, sizeof n->lo);
    memcpy(n->hi, bounds.hi, sizeof n->hi);
    n->axis = 0;
    if (count <= LEAF_MAX) {
        n->offset = (uint32_t)first;
        n->count = (uint16_t)count;
        return 1;
    }
    /* Best binned SAH split over all three axes. */
    int best_axis = -1, best_bin = 0;
    double best_cost = INFINITY;
    double leaf_cost = (double)count;
    double parent_area = box_area(&bounds);
    /* Bin along the widest spread of centroids only: binning all three
     * axes gave slightly better trees for three times the build work. */
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if ((double)cb.hi[k] - cb.lo[k] > (double)cb.hi[axis] - cb.lo[axis])
            axis = k;
    double ext = (double)cb.hi[axis] - (double)cb.lo[axis];
    double sc = ext > 0 ? BINS / ext : 0;
    float clo = cb.lo[axis];
    if (sc > 0) {
        box bb[BINS];
        size_t bc[BINS] = {0};
        for (int k = 0; k < BINS; k++)
            box_empty(&bb[k]);
        for (size_t i = first; i < first + count; i++) {
            int k = (int)(((double)r[i].c[axis] - clo) * sc);
            k = k < 0 ? 0 : (k >= BINS ? BINS - 1 : k);
            bc[k]++;
            box_grow(&bb[k], &r[i].b);
        }
        double right_area[BINS];
        size_t right_count[BINS];
        box acc;
        box_empty(&acc);
        size_t cnt = 0;
        for (int k = BINS - 1; k > 0; k--) {
            box_grow(&acc, &bb[k]);
            cnt += bc[k];
            right_area[k] = box_area(&acc);
            right_count[k] = cnt;
        }
        box_empty(&acc);
        cnt = 0;
        for (int k = 0; k < BINS - 1; k++) {
            box_grow(&acc, &bb[k]);
            cnt += bc[k];
            if (cnt == 0 || right_count[k + 1] == 0)
                continue;
            double cost = 0.5 + (box_area(&acc) * cnt + right_area[k + 1] * right_count[k + 1]) /
                                    (parent_area > 0 ? parent_area : 1);
            if (cost < best_cost) {
                best_cost = cost;
                best_axis = axis;
                best_bin = k;
            }
        }
    }
    size_t mid;
    if (best_axis < 0 || (best_cost >= leaf_cost && count <= SMALL_LEAF)) {
        if (best_axis < 0 && count > SMALL_LEAF && depth < MAX_DEPTH) {
            /* Centroids all coincide: halve by index so leaves stay small. */
            mid = first + count / 2;
        } else {
            n->offset = (uint32_t)first;
            n->count = (uint16_t)count;
            return 1;
        }
    } else {
        size_t i = first, j = first + count;
        while (i < j) {
            int k = (int)(((double)r[i].c[best_axis] - clo) * sc);
            k = k < 0 ? 0 : (k >= BINS ? BINS - 1 : k);
            if (k <= best_bin) {
                i++;
            } else {
                rec t = r[i];
                r[i] = r[--j];
                r[j] = t;
            }
        }
        mid = i;
        if (mid == first || mid == first + count)
            mid = first + count / 2;
    }
    if (depth >= MAX_DEPTH) {
        /* Deeper than traversal's stack allows: stop here, however big. */
        if (count > UINT16_MAX)
            return 0;
        n->offset = (uint32_t)first;
        n->count = (uint16_t)count;
        return 1;
    }
    bd->b->nodes[node].axis = (uint16_t)(best_axis < 0 ? 0 : best_axis);
    bd->b->nodes[node].count = 0;
    uint32_t left = new_node(bd);
    if (left == UINT32_MAX || !build(bd, left, first, mid - first, depth + 1))
        return 0;
    uint32_t right = new_node(bd);
    if (right == UINT32_MAX)
        return 0;
    bd->b->nodes[node].offset = right;
    return build(bd, right, mid, first + count - mid, depth + 1);
}

rd_error_code rd_bvh_build(rd_bvh *b, const rd_vec3 *lo, const rd_vec3 *hi, size_t n, rd_error *err)
{
    memset(b, 0, sizeof *b);
    if (n == 0)
        return RD_OK;
    if (n >= UINT32_MAX / 2)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "too many primitives for one BVH");
    builder bd;
    bd.b = b;
    bd.cap = 2 * n / LEAF_MAX + 16;
    bd.r = malloc(n * sizeof *bd.r);
    b->prims = malloc(n * sizeof *b->prims);
    b->nodes = malloc(bd.cap * sizeof *b->nodes);
    if (!bd.r || !b->prims || !b->nodes) {
        free(bd.r);
        rd_bvh_free(b);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    }
    for (size_t i = 0; i < n; i++) {
        double l[3] = {lo[i].x, lo[i].y, lo[i].z}, h[3] = {hi[i].x, hi[i].y, hi[i].z};
        for (int k = 0; k < 3; k++) {
            bd.r[i].b.lo[k] = down(l[k]);
            bd.r[i].b.hi[k] = up(h[k]);
            bd.r[i].c[k] = (float)(0.5 * l[k] + 0.5 * h[k]);
        }
        bd.r[i].id = (uint32_t)i;
    }
    b->nprims = n;
    b->nnodes = 1;
    int ok = build(&bd, 0, 0, n, 0);
    for (size_t i = 0; i < n; i++)
        b->prims[i] = bd.r[i].id;
    free(bd.r);
    if (!ok) {
        rd_bvh_free(b);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    }
    /* Give back what the estimate over-reserved. */
    rd_bvh_node *shrunk = realloc(b->nodes, b->nnodes * sizeof *b->nodes);
    if (shrunk)
        b->nodes = shrunk;
    return RD_OK;
}

void rd_bvh_free(rd_bvh *b)
{
    free(b->nodes);
    free(b->prims);
    memset(b, 0, sizeof *b);
}

rd_bvh_ray rd_bvh_ray_make(rd_ray r)
{
    rd_bvh_ray b;
    b.o = r.o;
    double d[3] = {r.d.x, r.d.y, r.d.z}, inv[3];
    for (int k = 0; k < 3; k++) {
        b.flat[k] = d[k] == 0;
        inv[k] = b.flat[k] ? 0 : 1.0 / d[k];
        /* A subnormal component overflows 1/d: huge but finite keeps the
         * products free of NaN. */
        if (!isfinite(inv[k]))
            inv[k] = copysign(DBL_MAX, d[k]);
        b.neg[k] = inv[k] < 0;
    }
    b.inv = v3(inv[0], inv[1], inv[2]);
    return b;
}
