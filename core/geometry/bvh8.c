#include "bvh8.h"

#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"

typedef struct {
    rd_bvh8 *t;
    const rd_bvh *b;
    size_t cap;
} collapser;

static uint32_t new_node(collapser *c)
{
    if (!rd_grow_array((void **)&c->t->nodes, &c->cap, c->t->nnodes + 1, sizeof *c->t->nodes, 64))
        return UINT32_MAX;
    return (uint32_t)c->t->nnodes++;
}

static void empty_node(rd_bvh8_node *n)
{
    memset(n, 0, sizeof *n);
    for (int i = 0; i < 8; i++)
        for (int a = 0; a < 3; a++) {
            n->lo[a][i] = INFINITY;
            n->hi[a][i] = -INFINITY;
        }
}

static int collapse(collapser *c, uint32_t binary, uint32_t into)
{
    uint32_t slot[8];
    int k = rd_bvh_gather(c->b, binary, slot, 8);
    rd_bvh8_node n;
    empty_node(&n);
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
    c->t->nodes[into] = n;
    return 1;
}

rd_error_code rd_bvh8_build(rd_bvh8 *t, const rd_bvh *b, rd_error *err)
{
    memset(t, 0, sizeof *t);
    if (b->nnodes == 0)
        return RD_OK;
    collapser c = {t, b, b->nnodes / 6 + 4};
    t->nodes = rd_big_malloc(c.cap * sizeof *t->nodes);
    if (!t->nodes)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    t->nnodes = 1;
    if (!collapse(&c, 0, 0)) {
        rd_bvh8_free(t);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory building the BVH");
    }
    rd_bvh8_node *shrunk = realloc(t->nodes, t->nnodes * sizeof *t->nodes);
    if (shrunk)
        t->nodes = shrunk;
    /* Every box lies in the root's. */
    for (int a = 0; a < 3; a++)
        t->r[a] = fmax(fabs((double)b->nodes[0].lo[a]), fabs((double)b->nodes[0].hi[a]));
    return RD_OK;
}

void rd_bvh8_free(rd_bvh8 *t)
{
    free(t->nodes);
    memset(t, 0, sizeof *t);
}
