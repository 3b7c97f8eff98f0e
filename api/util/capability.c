#include "capability.h"

#include <errno.h>
#include <string.h>
#include <sys/random.h>

static const char hexdigits[] = "0123456789abcdef";

static int fill_random(unsigned char *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t k = getrandom(buf + got, n - got, 0);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return -1;
        got += (size_t)k;
    }
    return 0;
}

rd_error_code rd_cap_new(char out[RD_CAP_MAX], char kind, rd_error *err)
{
    unsigned char bytes[RD_CAP_BITS / 8];
    out[0] = 0;
    if (fill_random(bytes, sizeof bytes))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "no id could be made: getrandom: %s", strerror(errno));
    char *p = out;
    if (kind)
        *p++ = kind;
    for (size_t i = 0; i < sizeof bytes; i++) {
        *p++ = hexdigits[bytes[i] >> 4];
        *p++ = hexdigits[bytes[i] & 15];
    }
    *p = 0;
    return RD_OK;
}

int rd_cap_valid(const char *s, char kind)
{
    if (!s)
        return 0;
    if (kind && *s++ != kind)
        return 0;
    return strlen(s) == RD_CAP_HEX && strspn(s, hexdigits) == RD_CAP_HEX;
}

int rd_cap_equal(const char *a, const char *b)
{
    size_t la = strnlen(a, RD_CAP_MAX), lb = strnlen(b, RD_CAP_MAX);
    unsigned diff = (unsigned)(la ^ lb);
    size_t n = la > lb ? la : lb;
    for (size_t i = 0; i < n; i++) {
        unsigned char x = i < la ? (unsigned char)a[i] : 0, y = i < lb ? (unsigned char)b[i] : 0;
        diff |= (unsigned)(x ^ y);
    }
    return diff == 0;
}

uint64_t rd_cap_bucket(const char *id)
{
    const char *d = id;
    if (*d && !strchr(hexdigits, *d))
        d++; /* the kind letter */
    uint64_t h = 0;
    for (int i = 0; i < 16; i++) {
        const char *c = d[i] ? strchr(hexdigits, d[i]) : NULL;
        if (!c)
            return 0;
        h = h << 4 | (uint64_t)(c - hexdigits);
    }
    return h;
}
