#include "name_set.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hash.h"

struct rd_name_slot {
    char *name;
    size_t len;
    int kind, line;
    uint64_t hash;
};

void rd_name_set_init(rd_name_set *s) { memset(s, 0, sizeof *s); }

void rd_name_set_free(rd_name_set *s)
{
    for (size_t i = 0; i < s->cap; i++)
        free(s->slots[i].name);
    free(s->slots);
    memset(s, 0, sizeof *s);
}

static uint64_t hash(int kind, const char *p, size_t n) { return rd_fnv1a(RD_FNV_OFFSET ^ (uint64_t)kind, p, n); }

static int grow(rd_name_set *s)
{
    size_t nc = s->cap ? s->cap * 2 : 64;
    struct rd_name_slot *n = calloc(nc, sizeof *n);
    if (!n)
        return 0;
    for (size_t i = 0; i < s->cap; i++) {
        if (!s->slots[i].name)
            continue;
        size_t j = s->slots[i].hash & (nc - 1);
        while (n[j].name)
            j = (j + 1) & (nc - 1);
        n[j] = s->slots[i];
    }
    free(s->slots);
    s->slots = n;
    s->cap = nc;
    return 1;
}

long rd_name_set_add(rd_name_set *s, int kind, const char *name, size_t len, int line)
{
    if ((s->count + 1) * 2 > s->cap && !grow(s))
        return -2;
    uint64_t h = hash(kind, name, len);
    size_t j = h & (s->cap - 1);
    while (s->slots[j].name) {
        struct rd_name_slot *e = &s->slots[j];
        if (e->hash == h && e->kind == kind && e->len == len && memcmp(e->name, name, len) == 0)
            return e->line;
        j = (j + 1) & (s->cap - 1);
    }
    char *copy = malloc(len + 1);
    if (!copy)
        return -2;
    memcpy(copy, name, len);
    copy[len] = 0;
    s->slots[j].name = copy;
    s->slots[j].len = len;
    s->slots[j].kind = kind;
    s->slots[j].line = line;
    s->slots[j].hash = h;
    s->count++;
    return -1;
}
