#include "strbuf.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Room for n more bytes and the NUL; 0 once out of memory. */
static int reserve(rd_strbuf *b, size_t n)
{
    if (b->failed)
        return 0;
    if (b->len + n + 1 > b->cap) {
        size_t nc = b->cap ? b->cap : 1024;
        while (nc < b->len + n + 1)
            nc *= 2;
        char *p = realloc(b->text, nc);
        if (!p) {
            b->failed = 1;
            return 0;
        }
        b->text = p;
        b->cap = nc;
    }
    return 1;
}

void rd_strbuf_append(rd_strbuf *b, const void *data, size_t n)
{
    if (!reserve(b, n))
        return;
    if (n)
        memcpy(b->text + b->len, data, n);
    b->len += n;
    b->text[b->len] = 0;
}

void rd_strbuf_printf(rd_strbuf *b, const char *fmt, ...)
{
    if (b->failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        b->failed = 1;
        return;
    }
    if (!reserve(b, (size_t)n))
        return;
    va_start(ap, fmt);
    vsnprintf(b->text + b->len, b->cap - b->len, fmt, ap);
    va_end(ap);
    b->len += (size_t)n;
}

char *rd_strbuf_take(rd_strbuf *b, size_t *len)
{
    char *t = b->failed ? NULL : b->text ? b->text : calloc(1, 1);
    if (len)
        *len = t ? b->len : 0;
    if (b->failed)
        free(b->text);
    memset(b, 0, sizeof *b);
    return t;
}

void rd_strbuf_free(rd_strbuf *b)
{
    free(b->text);
    memset(b, 0, sizeof *b);
}
