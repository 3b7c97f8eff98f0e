/* The Accept header read as RFC 9110 (12.5.1) has it: media ranges with
 * q-values, the most specific range that matches a type giving its q. The
 * header is the client's: any bytes, read without copying or allocating. */
#include <string.h>
#include <strings.h>

#include "http_internal.h"

enum { Q_ONE = 1000, Q_BAD = 0 };

static const char OWS[] = " \t";

/* "q=" followed by a qvalue: 0, 0.d, 0.dd, 0.ddd, 1, 1.0... A value that is
 * not one is taken as 0: a client that cannot spell it is not asking. */
static int parse_q(const char *p, size_t n)
{
    if (n < 2 || (p[0] != 'q' && p[0] != 'Q') || p[1] != '=')
        return -1; /* another parameter */
    p += 2, n -= 2;
    if (n == 0 || (p[0] != '0' && p[0] != '1'))
        return Q_BAD;
    int q = (p[0] - '0') * Q_ONE;
    if (n == 1)
        return q;
    if (p[1] != '.' || n > 5)
        return Q_BAD;
    int scale = 100;
    for (size_t i = 2; i < n; i++, scale /= 10) {
        if (p[i] < '0' || p[i] > '9')
            return Q_BAD;
        q += (p[i] - '0') * scale;
    }
    return q > Q_ONE ? Q_BAD : q;
}

/* How closely range (n bytes) names type: 3 the type itself, 2 its
 * "major/wildcard", 1 the wildcard of every type, 0 not at all. */
static int specificity(const char *range, size_t n, const char *type)
{
    size_t tn = strlen(type), major = strcspn(type, "/");
    if (n == tn && strncasecmp(range, type, n) == 0)
        return 3;
    if (n == major + 2 && strncasecmp(range, type, major) == 0 && range[major] == '/' && range[major + 1] == '*')
        return 2;
    return n == 3 && memcmp(range, "*/*", 3) == 0 ? 1 : 0;
}

/* The q-value of one element's parameters (p up to end): 1 unless a q says. */
static int element_q(const char *p, const char *end)
{
    int q = Q_ONE;
    while (p < end) {
        p += strspn(p, "; \t"); /* never past end: a comma or the NUL */
        size_t n = strcspn(p, ";");
        if (p + n > end)
            n = (size_t)(end - p);
        size_t len = n;
        while (len && strchr(OWS, p[len - 1]))
            len--;
        int v = len ? parse_q(p, len) : -1;
        if (v >= 0)
            q = v;
        p += n;
    }
    return q;
}

int rd_accept_quality(const char *accept, const char *type, int *named)
{
    int best = 0, q = -1;
    if (named)
        *named = 0;
    for (const char *p = accept; p && *p;) {
        p += strspn(p, ", \t");
        const char *end = p + strcspn(p, ",");
        size_t n = strcspn(p, "; \t,");
        int s = specificity(p, n, type);
        if (s > best || (s && s == best)) {
            int eq = element_q(p + n, end);
            q = s > best || eq > q ? eq : q;
            best = s;
        }
        p = end;
    }
    if (named)
        *named = best == 3;
    return q;
}
