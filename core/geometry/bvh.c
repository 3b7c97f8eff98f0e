#include "bvh.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"
#include "rayd/parallel.h"

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

/* Builds one subtree into its own node array (its root at 0, left children
 * next to their parents), so that subtrees can be built on threads and
 * joined in depth-first order: the tree is the same whatever the threads. */
typedef struct {
    rd_bvh_node *nodes;
    size_t nnodes, cap;
    rec *r;
    int threads; /* this subtree may use this many */
} builder;

static uint32_t new_node(builder *bd)
{
    if (!rd_grow_array((void **)&bd->nodes, &bd->cap, bd->nnodes + 1, sizeof *bd->nodes, 64))
        return UINT32_MAX;
    return (uint32_t)bd->nnodes++;
}

/* Bounds of the records' boxes and of their centroids. */
static void node_bounds(const rec *r, size_t first, size_t count, box *bounds, box *cb)
{
    box_empty(bounds);
    box_empty(cb);
    for (size_t i = first; i < first + count; i++) {
        box_grow(bounds, &r[i].b);
        box_grow_point(cb, r[i].c);
    }
}

/* A binned SAH split: records whose centroid's bin along axis is at most
 * bin go left. axis < 0: no split exists (centroids coincide). */
typedef struct {
    int axis, bin;
    double cost;
    double scale; /* bins per unit along axis */
    float lo;     /* where bin 0 starts */
} split;

static int bin_of(const rec *x, const split *sp)
{
    int k = (int)(((double)x->c[sp->axis] - sp->lo) * sp->scale);
    return k < 0 ? 0 : (k >= BINS ? BINS - 1 : k);
}

/* The cheapest split along the widest spread of centroids: binning all
 * three axes gave slightly better trees for three times the build work. */
static void find_split(const rec *r, size_t first, size_t count, const box *bounds, const box *cb, split *sp)
{
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if ((double)cb->hi[k] - cb->lo[k] > (double)cb->hi[axis] - cb->lo[axis])
            axis = k;
    double ext = (double)cb->hi[axis] - (double)cb->lo[axis];
    *sp = (split){-1, 0, INFINITY, ext > 0 ? BINS / ext : 0, cb->lo[axis]};
    if (!(sp->scale > 0))
        return;
    sp->axis = axis;
    box bb[BINS];
    size_t bc[BINS] = {0};
    for (int k = 0; k < BINS; k++)
        box_empty(&bb[k]);
    for (size_t i = first; i < first + count; i++) {
        int k = bin_of(&r[i], sp);
        bc[k]++;
        box_grow(&bb[k], &r[i].b);
    }
    double right_area[BINS], parent_area = box_area(bounds);
    size_t right_count[BINS], cnt = 0;
    box acc;
    box_empty(&acc);
    for (int k = BINS - 1; k > 0; k--) {
        box_grow(&acc, &bb[k]);
        cnt += bc[k];
        right_area[k] = box_area(&acc);
        right_count[k] = cnt;
    }
    box_empty(&acc);
    cnt = 0;
    int best = -1;
    for (int k = 0; k < BINS - 1; k++) {
        box_grow(&acc, &bb[k]);
        cnt += bc[k];
        if (cnt == 0 || right_count[k + 1] == 0)
            continue;
        double cost =
            0.5 + (box_area(&acc) * cnt + right_area[k + 1] * right_count[k + 1]) / (parent_area > 0 ? parent_area : 1);
        if (cost < sp->cost) {
            sp->cost = cost;
            best = k;
        }
    }
    sp->axis = best < 0 ? -1 : axis;
    sp->bin = best < 0 ? 0 : best;
}

/* Moves the left side's records first; returns where the right begins,
 * halving by index when one side would be empty. */
static size_t partition(rec *r, size_t first, size_t count, const split *sp)
{
    size_t i = first, j = first + count;
    while (i < j) {
        if (bin_of(&r[i], sp) <= sp->bin) {
            i++;
        } else {
            rec t = r[i];
            r[i] = r[--j];
            r[j] = t;
        }
    }
    return i == first || i == first + count ? first + count / 2 : i;
}

static int make_leaf(rd_bvh_node *n, size_t first, size_t count)
{
    if (count > UINT16_MAX)
        return 0;
    n->offset = (uint32_t)first;
    n->count = (uint16_t)count;
    return 1;
}

static int build(builder *bd, uint32_t node, size_t first, size_t count, int depth);

/* Below this many records a subtree is not worth a thread. */
enum { PARALLEL_MIN = 16384 };

typedef struct {
    builder bd;
    size_t first, count;
    int depth, ok;
} subtree;

/* Subtree i of the two (rd_run_each): 0 on this thread, 1 on a new one. */
static void subtree_main(void *ctx, int i)
{
    subtree *t = &((subtree *)ctx)[i];
    uint32_t root = new_node(&t->bd);
    t->ok = root != UINT32_MAX && build(&t->bd, root, t->first, t->count, t->depth);
}

/* Appends t's nodes to bd, moving their child indices along. */
static int append(builder *bd, const subtree *t, uint32_t *base)
{
    if (!rd_grow_array((void **)&bd->nodes, &bd->cap, bd->nnodes + t->bd.nnodes, sizeof *bd->nodes, 64))
        return 0;
    *base = (uint32_t)bd->nnodes;
    for (size_t i = 0; i < t->bd.nnodes; i++) {
        rd_bvh_node n = t->bd.nodes[i];
        if (!n.count)
            n.offset += *base;
        bd->nodes[bd->nnodes++] = n;
    }
    return 1;
}

/* Both children of node at once: the left on this thread, the right on a
 * new one, each into its own array, then joined left first. */
static int build_children_parallel(builder *bd, uint32_t node, size_t first, size_t mid, size_t end, int depth)
{
    int tl = bd->threads / 2;
    subtree t[2] = {{{NULL, 0, 0, bd->r, tl}, first, mid - first, depth + 1, 0},
                    {{NULL, 0, 0, bd->r, bd->threads - tl}, mid, end - mid, depth + 1, 0}};
    rd_run_each(2, subtree_main, t);
    uint32_t lb, rb;
    int ok = t[0].ok && t[1].ok && append(bd, &t[0], &lb) && append(bd, &t[1], &rb);
    if (ok)
        bd->nodes[node].offset = rb;
    free(t[0].bd.nodes);
    free(t[1].bd.nodes);
    return ok;
}

/* Splits prims[first, first+count) recursively; returns 0 on out of memory. */
static int build(builder *bd, uint32_t node, size_t first, size_t count, int depth)
{
    box bounds, cb;
    node_bounds(bd->r, first, count, &bounds, &cb);
    rd_bvh_node *n = &bd->nodes[node];
    memcpy(n->lo, bounds.lo, sizeof n->lo);
    memcpy(n->hi, bounds.hi, sizeof n->hi);
    n->axis = 0;
    if (count <= LEAF_MAX)
        return make_leaf(n, first, count);
    split sp;
    find_split(bd->r, first, count, &bounds, &cb, &sp);
    size_t mid;
    if (sp.axis < 0 || (sp.cost >= (double)count && count <= SMALL_LEAF)) {
        if (!(sp.axis < 0 && count > SMALL_LEAF && depth < MAX_DEPTH))
            return make_leaf(n, first, count);
        /* Centroids all coincide: halve by index so leaves stay small. */
        mid = first + count / 2;
    } else {
        mid = partition(bd->r, first, count, &sp);
    }
    /* Deeper than traversal's stack allows: stop here, however big. */
    if (depth >= MAX_DEPTH)
        return make_leaf(n, first, count);
    n->axis = (uint16_t)(sp.axis < 0 ? 0 : sp.axis);
    n->count = 0;
    /* A lopsided split (a scene's floor against its million-triangle
     * model) would leave one thread idle: the threads go on down instead. */
    size_t small = mid - first < first + count - mid ? mid - first : first + count - mid;
    if (bd->threads > 1 && small >= PARALLEL_MIN && small >= count / 4)
        return build_children_parallel(bd, node, first, mid, first + count, depth);
    uint32_t left = new_node(bd);
    if (left == UINT32_MAX || !build(bd, left, first, mid - first, depth + 1))
        return 0;
    uint32_t right = new_node(bd);
    if (right == UINT32_MAX)
        return 0;
    bd->nodes[node].offset = right;
    return build(bd, right, mid, first + count - mid, depth + 1);
}

/* The records of primitives [first, first + count), from fn's bounds. */
typedef struct {
    rec *r;
    rd_bvh_bounds_fn fn;
    const void *ctx;
} rec_run;

static void recs_fill(void *arg, size_t first, size_t count)
{
    const rec_run *a = arg;
    rd_vec3 lo[RD_BVH_RUN], hi[RD_BVH_RUN];
    for (size_t i = first; i < first + count; i += RD_BVH_RUN) {
        size_t k = first + count - i < RD_BVH_RUN ? first + count - i : RD_BVH_RUN;
        a->fn(a->ctx, i, k, lo, hi);
        for (size_t j = 0; j < k; j++) {
            rec *x = &a->r[i + j];
            double l[3] = {lo[j].x, lo[j].y, lo[j].z}, h[3] = {hi[j].x, hi[j].y, hi[j].z};
            for (int c = 0; c < 3; c++) {
                x->b.lo[c] = down(l[c]);
                x->b.hi[c] = up(h[c]);
                x->c[c] = (float)(0.5 * l[c] + 0.5 * h[c]);
            }
            x->id = (uint32_t)(i + j);
        }
    }
}

typedef struct {
    const rd_vec3 *lo, *hi;
} arrays;

static void from_arrays(const void *ctx, size_t first, size_t count, rd_vec3 *lo, rd_vec3 *hi)
{
    const arrays *a = ctx;
    memcpy(lo, a->lo + first, count * sizeof *lo);
    memcpy(hi, a->hi + first, count * sizeof *hi);
}

rd_error_code rd_bvh_build(rd_bvh *b, const rd_vec3 *lo, const rd_vec3 *hi, size_t n, rd_error *err)
{
    return rd_bvh_build_threads(b, lo, hi, n, 1, err);
}

rd_error_code rd_bvh_build_threads(rd_bvh *b, const rd_vec3 *lo, const rd_vec3 *hi, size_t n, int threads,
                                   rd_error *err)
{
    arrays a = {lo, hi};
    return rd_bvh_build_from(b, n, from_arrays, &a, threads, err);
}

rd_error_code rd_bvh_build_from(rd_bvh *b, size_t n, rd_bvh_bounds_fn fn, const void *ctx, int threads, rd_error *err)
{
    memset(b, 0, sizeof *b);
    if (n == 0)
        return RD_OK;
    if (n >= UINT32_MAX / 2)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "too many primitives for one BVH");
    builder bd = {NULL, 0, 2 * n / LEAF_MAX + 16, rd_big_malloc(n * sizeof *bd.r), threads < 1 ? 1 : threads};
    b->prims = rd_big_malloc(n * sizeof *b->prims);
    bd.nodes = rd_big_malloc(bd.cap * sizeof *bd.nodes);
    if (!bd.r || !b->prims || !bd.nodes) {
        free(bd.r);
        free(bd.nodes);
        rd_bvh_free(b);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    }
    rec_run rr = {bd.r, fn, ctx};
    rd_parallel_runs(n, PARALLEL_MIN, bd.threads, recs_fill, &rr);
    b->nprims = n;
    bd.nnodes = 1;
    int ok = build(&bd, 0, 0, n, 0);
    for (size_t i = 0; i < n; i++)
        b->prims[i] = bd.r[i].id;
    free(bd.r);
    b->nodes = bd.nodes;
    b->nnodes = bd.nnodes;
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
