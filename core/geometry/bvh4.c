#include "bvh4.h"

#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"

/* The binary children a node takes: the two of its binary node, then the
 * largest inner one among them opened up, while fewer than four. */
static int gather(const rd_bvh *b, uint32_t node, uint32_t slot[4])
{
    const rd_bvh_node *n = &b->nodes[node];
    if (n->count) {
        slot[0] = node;
        return 1;
    }
    int k = 0;
    slot[k++] = node + 1;
    slot[k++] = n->offset;
    while (k < 4) {
        int best = -1;
        double best_area = -1;
        for (int i = 0; i < k; i++) {
            const rd_bvh_node *c = &b->nodes[slot[i]];
            if (c->count)
                continue;
            double d[3];
            for (int a = 0; a < 3; a++)
                d[a] = (double)c->hi[a] - (double)c->lo[a];
            double area = d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
            if (area > best_area) {
                best_area = area;
                best = i;
            }
        }
        if (best < 0)
            break;
        uint32_t opened = slot[best];
        slot[best] = opened + 1;
        slot[k++] = b->nodes[opened].offset;
    }
    return k;
}

typedef struct {
    rd_bvh4 *w;
    const rd_bvh *b;
    size_t cap;
} collapser;

static uint32_t new_node(collapser *c)
{
    if (!rd_grow_array((void **)&c->w->nodes, &c->cap, c->w->nnodes + 1, sizeof *c->w->nodes, 64))
        return UINT32_MAX;
    return (uint32_t)c->w->nnodes++;
}

static int collapse(collapser *c, uint32_t binary, uint32_t into)
{
    uint32_t slot[4];
    int k = gather(c->b, binary, slot);
    rd_bvh4_node n;
    memset(&n, 0, sizeof n);
    for (int i = 0; i < 4; i++)
        for (int a = 0; a < 3; a++) {
            n.lo[a][i] = INFINITY;
            n.hi[a][i] = -INFINITY;
        }
    for (int i = 0; i < k; i++) {
        const rd_bvh_node *s = &c->b->nodes[slot[i]];
        for (int a = 0; a < 3; a++) {
            n.lo[a][i] = s->lo[a];
            n.hi[a][i] = s->hi[a];
        }
        n.count[i] = s->count;
        n.child[i] = s->count ? s->offset : 0;
    }
    for (int i = 0; i < k; i++) {
        if (n.count[i])
            continue;
        uint32_t child = new_node(c);
        if (child == UINT32_MAX)
            return 0;
        n.child[i] = child;
        if (!collapse(c, slot[i], child))
            return 0;
    }
    c->w->nodes[into] = n;
    return 1;
}

rd_error_code rd_bvh4_build(rd_bvh4 *w, const rd_bvh *b, rd_error *err)
{
    memset(w, 0, sizeof *w);
    if (b->nnodes == 0)
        return RD_OK;
    collapser c = {w, b, b->nnodes / 2 + 4};
    w->nodes = rd_big_malloc(c.cap * sizeof *w->nodes);
    if (!w->nodes)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    w->nnodes = 1;
    if (!collapse(&c, 0, 0)) {
        rd_bvh4_free(w);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    }
    rd_bvh4_node *shrunk = realloc(w->nodes, w->nnodes * sizeof *w->nodes);
    if (shrunk)
        w->nodes = shrunk;
    return RD_OK;
}

void rd_bvh4_free(rd_bvh4 *w)
{
    free(w->nodes);
    memset(w, 0, sizeof *w);
}

int rd_bvh4_cpu_has_avx2(void)
{
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2");
}

int rd_bvh4_cpu_has_avx512(void)
{
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f");
}
