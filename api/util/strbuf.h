/* A growing text buffer: printf-append until done, then take the text.
 * Out of memory is remembered rather than reported at every append: the
 * text is then NULL from rd_strbuf_take, and nothing was lost silently. */
#ifndef RD_STRBUF_H
#define RD_STRBUF_H

#include <stddef.h>

typedef struct {
    char *text; /* NUL-terminated once anything was appended */
    size_t len, cap;
    int failed; /* an append ran out of memory */
} rd_strbuf;

/* Appends; a no-op once an append has failed. */
void rd_strbuf_printf(rd_strbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Appends n bytes as they are (NULs included: binary data too). */
void rd_strbuf_append(rd_strbuf *b, const void *data, size_t n);

/* The text, malloc'ed (the caller frees it; "" when nothing was
 * appended), or NULL when an append failed. Leaves b empty. */
char *rd_strbuf_take(rd_strbuf *b, size_t *len);

/* Frees what b holds. */
void rd_strbuf_free(rd_strbuf *b);

#endif
