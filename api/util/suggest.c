#include "suggest.h"

#include <stdio.h>

#include <string.h>

/* Damerau-Levenshtein (optimal string alignment) distance, capped at 255. */
static int edit_distance(const char *a, size_t alen, const char *b, size_t blen)
{
    enum { MAXL = 64 };
    if (alen > MAXL || blen > MAXL)
        return 255;
    int d[MAXL + 1][MAXL + 1];
    for (size_t i = 0; i <= alen; i++)
        d[i][0] = (int)i;
    for (size_t j = 0; j <= blen; j++)
        d[0][j] = (int)j;
    for (size_t i = 1; i <= alen; i++) {
        for (size_t j = 1; j <= blen; j++) {
            int cost = a[i - 1] != b[j - 1];
            int v = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < v)
                v = d[i][j - 1] + 1;
            if (d[i - 1][j - 1] + cost < v)
                v = d[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < v)
                v = d[i - 2][j - 2] + 1;
            d[i][j] = v;
        }
    }
    return d[alen][blen] > 255 ? 255 : d[alen][blen];
}

void rd_suggest_init(rd_suggestion *s)
{
    s->best = NULL;
    s->dist = 255;
}

void rd_suggest_offer(rd_suggestion *s, const char *typed, size_t len, const char *candidate)
{
    int d = edit_distance(typed, len, candidate, strlen(candidate));
    if (d < s->dist) {
        s->dist = d;
        s->best = candidate;
    }
}

const char *rd_suggest_result(const rd_suggestion *s, size_t typed_len)
{
    if (!s->best || s->dist == 0)
        return NULL;
    size_t longer = strlen(s->best) > typed_len ? strlen(s->best) : typed_len;
    if (s->dist <= 2 && (size_t)s->dist * 3 <= longer)
        return s->best;
    return NULL;
}

const char *rd_suggest_hint(const rd_suggestion *s, size_t typed_len, char *buf, size_t size)
{
    const char *best = rd_suggest_result(s, typed_len);
    if (best)
        snprintf(buf, size, "; did you mean '%.200s'?", best);
    else if (size)
        buf[0] = 0;
    return buf;
}
