#include "cfg_parse.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"
#include "scene_builder.h"
#include "utf8.h"

typedef struct {
    const char *text, *end, *source;
    rd_builder *b;
    /* the open section */
    int open;
    const char *kind, *name;
    size_t kind_len, name_len;
    rd_loc where;
    rd_entry *entries;
    size_t n, cap;
} parser;

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }
static int is_word_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.' || c == '+' || (unsigned char)c >= 0x80;
}
static int is_key_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

static rd_loc at(int line, const char *ls, const char *p)
{
    rd_loc l = {line, rd_utf8_column(ls, p), NULL};
    return l;
}

static rd_error_code flush(parser *ps, rd_error *err)
{
    if (!ps->open)
        return RD_OK;
    ps->open = 0;
    return rd_builder_section(ps->b, ps->kind, ps->kind_len, ps->name, ps->name_len, ps->where, ps->entries, ps->n,
                              err);
}

static rd_error_code header(parser *ps, int line, const char *ls, const char *p, const char *le, rd_error *err)
{
    rd_loc where = at(line, ls, p);
    p++; /* '[' */
    while (p < le && is_space(*p))
        p++;
    const char *k = p;
    while (p < le && is_key_char(*p))
        p++;
    if (p == k)
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p), "expected a section kind after '['");
    size_t klen = (size_t)(p - k);
    if (klen > RD_MAX_KEY_BYTES)
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, where, "a section kind longer than %d bytes",
                                RD_MAX_KEY_BYTES);
    while (p < le && is_space(*p))
        p++;
    const char *name = NULL;
    size_t nlen = 0;
    if (p < le && *p == '"') {
        const char *q = memchr(p + 1, '"', (size_t)(le - p - 1));
        if (!q)
            return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p), "unterminated string");
        name = p + 1;
        nlen = (size_t)(q - p - 1);
        p = q + 1;
    } else if (p < le && is_word_char(*p)) {
        name = p;
        while (p < le && is_word_char(*p))
            p++;
        nlen = (size_t)(p - name);
    }
    while (p < le && is_space(*p))
        p++;
    if (p >= le || *p != ']')
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p),
                                p >= le ? "missing ']' at the end of the section header"
                                        : "expected ']' after the section name");
    p++;
    while (p < le && is_space(*p))
        p++;
    if (p < le && *p != '#' && *p != ';')
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p), "unexpected text after the section header");
    rd_error_code rc = flush(ps, err);
    if (rc)
        return rc;
    ps->open = 1;
    ps->kind = k;
    ps->kind_len = klen;
    ps->name = name;
    ps->name_len = nlen;
    ps->where = where;
    ps->n = 0;
    return RD_OK;
}

static rd_error_code key_value(parser *ps, int line, const char *ls, const char *p, const char *le, rd_error *err)
{
    const char *k = p;
    while (p < le && is_key_char(*p))
        p++;
    if (p == k || (p < le && !is_space(*p) && *p != '='))
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, k), "expected '[section]' or 'key = value'");
    rd_loc key_loc = at(line, ls, k);
    size_t klen = (size_t)(p - k);
    if (klen > RD_MAX_KEY_BYTES)
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, key_loc, "a key longer than %d bytes", RD_MAX_KEY_BYTES);
    while (p < le && is_space(*p))
        p++;
    if (p >= le || *p != '=')
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p), "expected '=' after key '%.*s'",
                                (int)rd_utf8_prefix(k, klen, 60), k);
    p++;
    if (!ps->open)
        return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, key_loc,
                                "key '%.*s' outside any section; start one with a header such as [render]",
                                (int)rd_utf8_prefix(k, klen, 60), k);
    if (!rd_grow_array((void **)&ps->entries, &ps->cap, ps->n + 1, sizeof *ps->entries, 16))
        return rd_builder_error(ps->b, err, RD_ERR_NOMEM, key_loc, "out of memory");
    rd_entry *e = &ps->entries[ps->n++];
    memset(e, 0, sizeof *e);
    e->key = k;
    e->key_len = klen;
    e->key_loc = key_loc;
    while (p < le && is_space(*p))
        p++;
    e->value.loc = at(line, ls, p);
    while (p < le) {
        if (*p == '#' || *p == ';')
            break;
        rd_token t = {p, 0, 0, 0, 0, rd_utf8_column(ls, p)};
        if (*p == '"') {
            const char *q = memchr(p + 1, '"', (size_t)(le - p - 1));
            if (!q)
                return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p), "unterminated string");
            t.text = p + 1;
            t.len = (size_t)(q - p - 1);
            t.quoted = 1;
            p = q + 1;
            if (p < le && !is_space(*p) && *p != '#' && *p != ';')
                return rd_builder_error(ps->b, err, RD_ERR_SYNTAX, at(line, ls, p),
                                        "expected a space after the closing quote");
        } else {
            while (p < le && !is_space(*p) && *p != '#' && *p != ';' && *p != '"')
                p++;
            t.len = (size_t)(p - t.text);
        }
        if (e->value.n < RD_VALUE_MAX_TOKENS)
            e->value.tok[e->value.n++] = t;
        e->value.total++;
        while (p < le && is_space(*p))
            p++;
    }
    return RD_OK;
}

rd_error_code rd_cfg_parse(const char *text, size_t len, const char *source, const rd_scene_limits *lim_in, rd_scene *s,
                           rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    source = source ? source : "<scene>";
    rd_error_code rc = rd_scene_text_check(text, len, source, &lim, err);
    if (rc)
        return rc;
    parser ps;
    memset(&ps, 0, sizeof ps);
    ps.text = text;
    ps.end = text + len;
    ps.source = source;
    ps.b = rd_builder_new(s, source, &lim);
    if (!ps.b)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", source);
    const char *p = text + rd_utf8_bom(text, len);
    int line = 0;
    while (p < ps.end && rc == RD_OK) {
        line++;
        const char *ls = p;
        const char *le = memchr(p, '\n', (size_t)(ps.end - p));
        const char *next = le ? le + 1 : ps.end;
        if (!le)
            le = ps.end;
        if (le > ls && le[-1] == '\r')
            le--;
        const char *q = ls;
        while (q < le && is_space(*q))
            q++;
        if (q < le && *q != '#' && *q != ';') {
            if (*q == '[')
                rc = header(&ps, line, ls, q, le, err);
            else
                rc = key_value(&ps, line, ls, q, le, err);
        }
        p = next;
    }
    if (rc == RD_OK)
        rc = flush(&ps, err);
    if (rc == RD_OK)
        rc = rd_builder_finish(ps.b, err);
    free(ps.entries);
    rd_builder_free(ps.b);
    return rc;
}
