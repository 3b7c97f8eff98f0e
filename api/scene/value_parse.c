#include "value_parse.h"

#include "utf8.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Longest number text accepted; more digits than this carry no precision. */
#define MAX_NUMBER_TEXT 128

static int is_decimal(const char *s, size_t n)
{
    size_t i = 0, digits = 0;
    if (i < n && (s[i] == '+' || s[i] == '-'))
        i++;
    while (i < n && isdigit((unsigned char)s[i]))
        i++, digits++;
    if (i < n && s[i] == '.') {
        i++;
        while (i < n && isdigit((unsigned char)s[i]))
            i++, digits++;
    }
    if (digits == 0)
        return 0;
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        if (i < n && (s[i] == '+' || s[i] == '-'))
            i++;
        size_t e = 0;
        while (i < n && isdigit((unsigned char)s[i]))
            i++, e++;
        if (e == 0)
            return 0;
    }
    return i == n;
}

static int is_nonfinite_word(const char *s, size_t n)
{
    if (n > 0 && (s[0] == '+' || s[0] == '-'))
        s++, n--;
    return (n == 3 && (strncasecmp(s, "nan", 3) == 0 || strncasecmp(s, "inf", 3) == 0)) ||
           (n == 8 && strncasecmp(s, "infinity", 8) == 0) || (n > 3 && strncasecmp(s, "nan(", 4) == 0);
}

/* The digits of a decimal number in is_decimal's form, when there are at
 * most 15 significant ones and the power of ten is within ±22: then the
 * value is one exact integer times or over one exact power of ten, a
 * single correctly rounded operation, which is what strtod returns
 * (Clinger, "How to read floating point numbers accurately", PLDI 1990).
 * Mesh files are millions of such numbers. 0 when another path is needed. */
static int fast_decimal(const char *s, size_t n, double *out)
{
    static const double pow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                   1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    size_t i = 0;
    int neg = 0, sig = 0, frac = 0, digits = 0;
    uint64_t m = 0;
    if (i < n && (s[i] == '+' || s[i] == '-'))
        neg = s[i++] == '-';
    for (int part = 0; part < 2; part++) {
        for (; i < n && s[i] >= '0' && s[i] <= '9'; i++, digits++) {
            if (m == 0 && s[i] == '0') {
                frac += part;
                continue;
            }
            if (++sig > 15)
                return 0;
            m = m * 10 + (uint64_t)(s[i] - '0');
            frac += part;
        }
        if (part == 0 && i < n && s[i] == '.')
            i++;
        else
            break;
    }
    if (digits == 0)
        return 0;
    long e = 0;
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        int eneg = i < n && s[i] == '-';
        if (i < n && (s[i] == '+' || s[i] == '-'))
            i++;
        size_t e0 = i;
        for (; i < n && s[i] >= '0' && s[i] <= '9' && e < 100000; i++)
            e = e * 10 + (s[i] - '0');
        if (i == e0 || e >= 100000)
            return 0;
        e = eneg ? -e : e;
    }
    if (i != n)
        return 0;
    long k = e - frac;
    if (m == 0) {
        *out = neg ? -0.0 : 0.0;
        return 1;
    }
    if (k < -22 || k > 22)
        return 0;
    double v = k >= 0 ? (double)m * pow10[k] : (double)m / pow10[-k];
    *out = neg ? -v : v;
    return 1;
}

int rd_parse_real(const rd_token *t, double *out)
{
    if (t->quoted || t->other)
        return 1;
    if (t->len <= MAX_NUMBER_TEXT && fast_decimal(t->text, t->len, out))
        return 0;
    if (is_nonfinite_word(t->text, t->len))
        return 2;
    if (t->len > MAX_NUMBER_TEXT || !is_decimal(t->text, t->len))
        return 1;
    char buf[MAX_NUMBER_TEXT + 1];
    memcpy(buf, t->text, t->len);
    buf[t->len] = 0;
    double v = strtod(buf, NULL);
    if (!isfinite(v))
        return 2;
    *out = v;
    return 0;
}

static int is_integer_text(const char *s, size_t n, int allow_sign)
{
    size_t i = 0;
    if (allow_sign && i < n && (s[i] == '+' || s[i] == '-'))
        i++;
    if (i == n)
        return 0;
    for (; i < n; i++)
        if (!isdigit((unsigned char)s[i]))
            return 0;
    return 1;
}

int rd_parse_int(const rd_token *t, long long lo, long long hi, long long *out)
{
    if (t->quoted || t->other || t->len > 40 || !is_integer_text(t->text, t->len, 1))
        return 1;
    char buf[48];
    memcpy(buf, t->text, t->len);
    buf[t->len] = 0;
    errno = 0;
    long long v = strtoll(buf, NULL, 10);
    if (errno == ERANGE || v < lo || v > hi)
        return 2;
    *out = v;
    return 0;
}

int rd_parse_u64(const rd_token *t, unsigned long long *out)
{
    const char *s = t->text;
    size_t n = t->len;
    if (n > 0 && s[0] == '+')
        s++, n--;
    /* A quoted seed is accepted: JSON numbers above 2^53 lose digits. */
    if (t->other || n > 30 || !is_integer_text(s, n, 0))
        return 1;
    char buf[40];
    memcpy(buf, s, n);
    buf[n] = 0;
    errno = 0;
    unsigned long long v = strtoull(buf, NULL, 10);
    if (errno == ERANGE)
        return 1;
    *out = v;
    return 0;
}

/* The token as it should be quoted in a message: at most 40 characters
 * (never a split one), control bytes shown as '?', "..." when cut, and its
 * quotes (after 'the string ') when it was one. buf holds at least 192 bytes. */
static const char *token_show(const rd_token *t, char *buf, size_t size)
{
    /* At most 40 characters, never a split one; quoted tokens keep their
     * quotes, so '"45"' does not read like the number 45. */
    size_t n = rd_utf8_prefix(t->text, t->len, 40);
    size_t room = size > 8 ? size - 8 : 0;
    if (n > room)
        n = rd_utf8_prefix(t->text, room, room);
    size_t j = 0;
    if (t->quoted) {
        memcpy(buf, "the string \"", 12);
        j = 12;
    }
    for (size_t i = 0; i < n; i++)
        buf[j++] = (unsigned char)t->text[i] < 0x20 || t->text[i] == 0x7f ? '?' : t->text[i];
    if (n < t->len) {
        memcpy(buf + j, "...", 3);
        j += 3;
    }
    if (t->quoted)
        buf[j++] = '"';
    buf[j] = 0;
    return buf;
}

const char *rd_token_what(const rd_token *t, char *buf, size_t size)
{
    if (t->other)
        return t->text; /* "true", "null", "[...]", "{...}" */
    char inner[176];
    token_show(t, inner, sizeof inner);
    snprintf(buf, size, t->quoted ? "%s" : "'%s'", inner);
    return buf;
}
