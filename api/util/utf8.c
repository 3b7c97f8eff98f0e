#include "utf8.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

size_t rd_utf8_invalid_at(const char *str, size_t len)
{
    const unsigned char *s = (const unsigned char *)str;
    size_t i = 0;
    const uint64_t ones = 0x0101010101010101ull, highs = 0x8080808080808080ull;
    while (i < len) {
        /* Eight plain ASCII bytes, none of them NUL, at a time. */
        if (i + 8 <= len) {
            uint64_t w;
            memcpy(&w, s + i, 8);
            if (!(w & highs) && !((w - ones) & ~w & highs)) {
                i += 8;
                continue;
            }
        }
        unsigned c = s[i];
        if (c == 0)
            return i;
        if (c < 0x80) {
            i++;
            continue;
        }
        int n;
        unsigned cp, min;
        if ((c & 0xe0) == 0xc0) {
            n = 1, cp = c & 0x1f, min = 0x80;
        } else if ((c & 0xf0) == 0xe0) {
            n = 2, cp = c & 0x0f, min = 0x800;
        } else if ((c & 0xf8) == 0xf0) {
            n = 3, cp = c & 0x07, min = 0x10000;
        } else {
            return i;
        }
        for (int k = 1; k <= n; k++) {
            if (i + (size_t)k >= len || (s[i + k] & 0xc0) != 0x80)
                return i;
            cp = (cp << 6) | (s[i + k] & 0x3f);
        }
        if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff))
            return i;
        i += (size_t)n + 1;
    }
    return len;
}

int rd_utf8_column(const char *line_start, const char *pos)
{
    int col = 1;
    for (const char *p = line_start; p < pos; p++)
        if (((unsigned char)*p & 0xc0) != 0x80)
            col++;
    return col;
}

size_t rd_utf8_prefix(const char *s, size_t len, size_t max_chars)
{
    size_t i = 0, chars = 0;
    while (i < len && chars < max_chars) {
        unsigned char c = (unsigned char)s[i];
        size_t n = c < 0x80 ? 1 : (c & 0xe0) == 0xc0 ? 2 : (c & 0xf0) == 0xe0 ? 3 : (c & 0xf8) == 0xf0 ? 4 : 1;
        if (i + n > len)
            break;
        i += n;
        chars++;
    }
    return i;
}

size_t rd_utf8_bom(const char *text, size_t len) { return len >= 3 && memcmp(text, "\xef\xbb\xbf", 3) == 0 ? 3 : 0; }

void rd_utf8_position(const char *text, size_t len, size_t off, int *line, int *column)
{
    int n = 1;
    size_t bom = rd_utf8_bom(text, len);
    const char *ls = off >= bom ? text + bom : text;
    for (size_t i = 0; i < off; i++)
        if (text[i] == '\n')
            n++, ls = text + i + 1;
    *line = n;
    *column = rd_utf8_column(ls, text + off);
}

/* The bytes of the character starting at s[0] (at most len), or 0 when
 * those bytes are not one valid UTF-8 character. */
static size_t char_len(const unsigned char *s, size_t len)
{
    size_t n = s[0] < 0x80 ? 1 : (s[0] & 0xe0) == 0xc0 ? 2 : (s[0] & 0xf0) == 0xe0 ? 3 : (s[0] & 0xf8) == 0xf0 ? 4 : 0;
    if (n == 0 || n > len || rd_utf8_invalid_at((const char *)s, n) != n)
        return s[0] == 0 ? 1 : 0;
    return n;
}

int rd_utf8_readable(const char *str, size_t len, char *out, size_t size)
{
    const unsigned char *s = (const unsigned char *)str;
    size_t o = 0;
    for (size_t i = 0; i < len;) {
        size_t n = char_len(s + i, len - i);
        char esc[4];
        const char *from = (const char *)s + i, *put = from;
        size_t k = n;
        if (n == 0) {
            snprintf(esc, sizeof esc, "%%%02X", s[i]);
            put = esc, k = 3;
        } else if (s[i] < 0x20 || s[i] == 0x7f) {
            put = "_", k = 1;
        }
        if (o + k > size - 1)
            break;
        memcpy(out + o, put, k);
        o += k;
        i += n ? n : 1;
    }
    out[o] = 0;
    return rd_utf8_invalid_at(str, len) == len;
}
