/* Pieces of a multipart form as libmicrohttpd's post processor hands them
 * over: shared by the routes that read forms. */
#include <stdlib.h>
#include <string.h>

#include "http_internal.h"

int rd_form_append(unsigned char **buf, size_t *len, const char *data, size_t size)
{
    unsigned char *p = realloc(*buf, *len + size + 1);
    if (!p)
        return 0;
    memcpy(p + *len, data, size);
    *len += size;
    p[*len] = 0;
    *buf = p;
    return 1;
}

int rd_form_text(char *dst, size_t cap, const char *data, size_t size)
{
    size_t have = strlen(dst);
    if (have + size >= cap)
        return 0;
    memcpy(dst + have, data, size);
    dst[have + size] = 0;
    return 1;
}
