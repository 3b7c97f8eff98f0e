#include "json_check.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "scene_limits.h"
#include "utf8.h"

typedef struct {
    const char *text, *p, *end, *source;
    size_t max_depth, max_name;
    rd_error *err;
} checker;

/* Keys of the format are at most this long; the keys of "materials" are
 * material names, bounded by --max-name-bytes instead. */
#define KEY_BYTES 64

static rd_error_code fail_at(checker *c, const char *at, rd_error_code code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static rd_error_code fail_at(checker *c, const char *at, rd_error_code code, const char *fmt, ...)
{
    int line = 1;
    const char *ls = c->text;
    for (const char *q = c->text; q < at; q++)
        if (*q == '\n')
            line++, ls = q + 1;
    int col = rd_utf8_column(ls, at);
    char msg[300];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return rd_error_set(c->err, code, line, col, "%s:%d:%d: %s", c->source, line, col, msg);
}

static rd_error_code eof(checker *c) { return fail_at(c, c->end, RD_ERR_SYNTAX, "unexpected end of input"); }

static void ws(checker *c)
{
    while (c->p < c->end && (*c->p == ' ' || *c->p == '\t' || *c->p == '\n' || *c->p == '\r'))
        c->p++;
}

static int hex(char ch)
{
    return (ch >= '0' && ch <= '9')   ? ch - '0'
           : (ch >= 'a' && ch <= 'f') ? ch - 'a' + 10
           : (ch >= 'A' && ch <= 'F') ? ch - 'A' + 10
                                      : -1;
}

/* key: 0 a value, 1 a key of the format, 2 a material name. */
static rd_error_code string(checker *c, int key)
{
    const char *start = c->p++;
    while (c->p < c->end) {
        unsigned char ch = (unsigned char)*c->p;
        if (ch == '"') {
            c->p++;
            size_t n = (size_t)(c->p - start - 2);
            if (key == 1 && n > KEY_BYTES)
                return fail_at(c, start, RD_ERR_SYNTAX, "a key longer than %d bytes", KEY_BYTES);
            if (key == 2 && n > c->max_name)
                return fail_at(c, start, RD_ERR_LIMIT, "a material name longer than the limit of %zu bytes (%s)",
                               c->max_name, rd_limit_flag(offsetof(rd_scene_limits, max_name)));
            return RD_OK;
        }
        if (ch < 0x20)
            return fail_at(c, c->p, RD_ERR_SYNTAX,
                           ch == '\n' ? "a string runs past the end of the line (missing '\"'?)"
                                      : "a control character in a string (write it as an escape)");
        if (ch == '\\') {
            const char *esc = c->p++;
            if (c->p >= c->end)
                return eof(c);
            char e = *c->p;
            if (e == 'u') {
                int v = 0;
                for (int i = 1; i <= 4; i++) {
                    if (c->p + i >= c->end)
                        return eof(c);
                    int h = hex(c->p[i]);
                    if (h < 0)
                        return fail_at(c, esc, RD_ERR_SYNTAX, "\\u must be followed by 4 hexadecimal digits");
                    v = v * 16 + h;
                }
                c->p += 5;
                if (v == 0)
                    return fail_at(c, esc, RD_ERR_SYNTAX, "a string holds a NUL character (\\u0000)");
                if (v >= 0xdc00 && v <= 0xdfff)
                    return fail_at(c, esc, RD_ERR_SYNTAX, "a lone low surrogate \\u%04x", v);
                if (v >= 0xd800 && v <= 0xdbff) {
                    int w = 0, ok = c->p + 6 <= c->end && c->p[0] == '\\' && c->p[1] == 'u';
                    for (int i = 2; ok && i < 6; i++) {
                        int h = hex(c->p[i]);
                        ok = h >= 0;
                        w = w * 16 + (h < 0 ? 0 : h);
                    }
                    if (!ok || w < 0xdc00 || w > 0xdfff)
                        return fail_at(c, esc, RD_ERR_SYNTAX, "a high surrogate \\u%04x without its low half", v);
                    c->p += 6;
                }
                continue;
            }
            if (!strchr("\"\\/bfnrt", e) || e == 0)
                return fail_at(c, esc, RD_ERR_SYNTAX, "'\\%c' is not a JSON escape", e >= 0x20 && e < 0x7f ? e : '?');
            c->p++;
            continue;
        }
        c->p++;
    }
    return eof(c);
}

static int digit(const checker *c) { return c->p < c->end && *c->p >= '0' && *c->p <= '9'; }

static rd_error_code number(checker *c)
{
    const char *start = c->p;
    if (*c->p == '-')
        c->p++;
    if (c->p >= c->end)
        return eof(c);
    if (*c->p == '0') {
        c->p++;
        if (digit(c))
            return fail_at(c, start, RD_ERR_SYNTAX, "a JSON number cannot have a leading zero");
    } else if (digit(c)) {
        while (digit(c))
            c->p++;
    } else {
        return fail_at(c, c->p, RD_ERR_SYNTAX, "expected a digit");
    }
    if (c->p < c->end && *c->p == '.') {
        c->p++;
        if (!digit(c))
            return c->p >= c->end ? eof(c) : fail_at(c, c->p, RD_ERR_SYNTAX, "a digit must follow the '.'");
        while (digit(c))
            c->p++;
    }
    if (c->p < c->end && (*c->p == 'e' || *c->p == 'E')) {
        c->p++;
        if (c->p < c->end && (*c->p == '+' || *c->p == '-'))
            c->p++;
        if (!digit(c))
            return c->p >= c->end ? eof(c) : fail_at(c, c->p, RD_ERR_SYNTAX, "a digit must follow the exponent");
        while (digit(c))
            c->p++;
    }
    return RD_OK;
}

static rd_error_code value(checker *c, size_t depth, int names);

static rd_error_code literal(checker *c, const char *word)
{
    size_t n = strlen(word);
    if ((size_t)(c->end - c->p) < n) {
        if (memcmp(c->p, word, (size_t)(c->end - c->p)) == 0)
            return eof(c);
        return fail_at(c, c->p, RD_ERR_SYNTAX, "expected a value");
    }
    if (memcmp(c->p, word, n) != 0)
        return fail_at(c, c->p, RD_ERR_SYNTAX, "expected a value");
    c->p += n;
    return RD_OK;
}

/* names: this value, if an object, is keyed by material names. */
static rd_error_code value(checker *c, size_t depth, int names)
{
    ws(c);
    if (c->p >= c->end)
        return eof(c);
    char ch = *c->p;
    rd_error_code rc;
    if (ch == '{' || ch == '[') {
        if (depth + 1 > c->max_depth)
            return fail_at(c, c->p, RD_ERR_LIMIT, "nesting deeper than the limit of %zu (%s)", c->max_depth,
                           rd_limit_flag(offsetof(rd_scene_limits, max_nesting)));
        char close = ch == '{' ? '}' : ']';
        const char *comma = NULL;
        c->p++;
        ws(c);
        if (c->p >= c->end)
            return eof(c);
        if (*c->p == close) {
            c->p++;
            return RD_OK;
        }
        for (;;) {
            int child_names = 0;
            if (ch == '{') {
                ws(c);
                if (c->p >= c->end)
                    return eof(c);
                if (*c->p != '"')
                    return *c->p == '}' && comma
                               ? fail_at(c, comma, RD_ERR_SYNTAX, "a ',' before '}' (JSON allows no trailing comma)")
                               : fail_at(c, c->p, RD_ERR_SYNTAX, "expected a key in double quotes");
                const char *k = c->p + 1;
                if ((rc = string(c, names ? 2 : 1)))
                    return rc;
                child_names = depth == 0 && c->p - k - 1 == 9 && memcmp(k, "materials", 9) == 0;
                ws(c);
                if (c->p >= c->end)
                    return eof(c);
                if (*c->p != ':')
                    return fail_at(c, c->p, RD_ERR_SYNTAX, "expected ':' after the key");
                c->p++;
            } else {
                ws(c);
                if (c->p < c->end && *c->p == ']' && comma)
                    return fail_at(c, comma, RD_ERR_SYNTAX, "a ',' before ']' (JSON allows no trailing comma)");
            }
            if ((rc = value(c, depth + 1, child_names)))
                return rc;
            ws(c);
            if (c->p >= c->end)
                return eof(c);
            if (*c->p == close) {
                c->p++;
                return RD_OK;
            }
            if (*c->p != ',')
                return fail_at(c, c->p, RD_ERR_SYNTAX, "expected ',' or '%c'", close);
            comma = c->p;
            c->p++;
        }
    }
    if (ch == '"')
        return string(c, 0);
    if (ch == '-' && c->p + 1 < c->end && c->p[1] == 'I')
        return fail_at(c, c->p, RD_ERR_SYNTAX, "NaN and Infinity are not JSON numbers");
    if (ch == '-' || (ch >= '0' && ch <= '9'))
        return number(c);
    if (ch == 't')
        return literal(c, "true");
    if (ch == 'f')
        return literal(c, "false");
    if (ch == 'n')
        return literal(c, "null");
    /* NaN, NAN, Inf, INF, Infinity: the spellings other languages write. */
    if ((ch == 'N' || ch == 'I') && (size_t)(c->end - c->p) >= 3 &&
        (strncasecmp(c->p, "nan", 3) == 0 || strncasecmp(c->p, "inf", 3) == 0))
        return fail_at(c, c->p, RD_ERR_SYNTAX, "NaN and Infinity are not JSON numbers");
    return fail_at(c, c->p, RD_ERR_SYNTAX, "expected a value");
}

rd_error_code rd_json_check(const char *text, size_t len, const char *source, size_t max_depth, size_t max_name,
                            rd_error *err)
{
    checker c = {text, text, text + len, source, max_depth, max_name, err};
    rd_error_code rc = value(&c, 0, 0);
    if (rc)
        return rc;
    ws(&c);
    if (c.p < c.end)
        return fail_at(&c, c.p, RD_ERR_SYNTAX, "text after the scene object");
    return RD_OK;
}
