#include "scene_builder.h"

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "name_set.h"
#include "rayd/memory.h"
#include "scene_keys.h"
#include "suggest.h"
#include "utf8.h"
#include "value_parse.h"

typedef struct {
    size_t object;
    int line, column;
    char *path;
} mat_ref;

struct rd_builder {
    rd_scene *s;
    const char *source;
    rd_scene_limits lim;
    int seen[RD_SEC_COUNT]; /* render/camera: 1 + line of the first one */
    rd_name_set names;      /* (kind, name) -> first line, for duplicates */
    mat_ref *refs;
    size_t nrefs, caprefs;
};

/* Bytes of at most 60 characters of s: names and keys quoted in messages. */
static int cut(const char *s, size_t len) { return (int)rd_utf8_prefix(s, len, 60); }

static void vformat(rd_error *err, rd_error_code code, const char *source, rd_loc loc, const char *fmt, va_list ap)
{
    char msg[400];
    vsnprintf(msg, sizeof msg, fmt, ap);
    if (loc.path) {
        /* The path already ends in the key's name: "objects[2].radius: radius: ..."
         * says it twice. */
        const char *last = strrchr(loc.path, '.');
        last = last ? last + 1 : loc.path;
        size_t n = strcspn(last, "[");
        const char *shown = msg;
        if (n > 0 && strncmp(msg, last, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ')
            shown = msg + n + 2;
        rd_error_set(err, code, loc.line, loc.column, "%s: %s: %s", source, loc.path, shown);
    } else if (loc.line > 0)
        rd_error_set(err, code, loc.line, loc.column, "%s:%d:%d: %s", source, loc.line, loc.column > 0 ? loc.column : 1,
                     msg);
    else
        rd_error_set(err, code, 0, 0, "%s: %s", source, msg);
}

rd_error_code rd_loc_error(rd_error *err, rd_error_code code, const char *source, rd_loc loc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vformat(err, code, source, loc, fmt, ap);
    va_end(ap);
    return code;
}

rd_error_code rd_builder_error(const rd_builder *b, rd_error *err, rd_error_code code, rd_loc loc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vformat(err, code, b->source, loc, fmt, ap);
    va_end(ap);
    return code;
}

rd_error_code rd_scene_text_check(const char *text, size_t len, const char *source, const rd_scene_limits *lim,
                                  rd_error *err)
{
    if (len > lim->max_bytes)
        return rd_loc_error(err, RD_ERR_LIMIT, source, (rd_loc){0, 0, NULL},
                            "scene is %zu bytes, over the limit of %zu (%s)", len, lim->max_bytes,
                            rd_limit_flag(offsetof(rd_scene_limits, max_bytes)));
    size_t bad = rd_utf8_invalid_at(text, len);
    if (bad >= len)
        return RD_OK;
    rd_loc l = {0, 0, NULL};
    rd_utf8_position(text, len, bad, &l.line, &l.column);
    return rd_loc_error(err, RD_ERR_SYNTAX, source, l, text[bad] ? "invalid UTF-8" : "NUL byte in the scene text");
}

rd_builder *rd_builder_new(rd_scene *s, const char *source, const rd_scene_limits *lim)
{
    rd_builder *b = calloc(1, sizeof *b);
    if (!b)
        return NULL;
    b->s = s;
    b->source = source ? source : "<scene>";
    b->lim = lim ? *lim : rd_scene_limits_default();
    rd_name_set_init(&b->names);
    return b;
}

void rd_builder_free(rd_builder *b)
{
    if (!b)
        return;
    rd_name_set_free(&b->names);
    for (size_t i = 0; i < b->nrefs; i++)
        free(b->refs[i].path);
    free(b->refs);
    free(b);
}

static char *dupn(const char *s, size_t n)
{
    char *p = malloc(n + 1);
    if (p) {
        memcpy(p, s, n);
        p[n] = 0;
    }
    return p;
}

/* The place of token i of a value: its column in cfg, its array index in JSON. */
static rd_loc token_loc(const rd_value *v, int i, char *buf, size_t size)
{
    rd_loc l = v->loc;
    if (l.path) {
        if (v->is_array) {
            snprintf(buf, size, "%s[%d]", l.path, i);
            l.path = buf;
        }
    } else if (i < v->n && v->tok[i].column > 0) {
        l.column = v->tok[i].column;
    }
    return l;
}

/* Reads n numbers of a value into out, with the key's range. */
static rd_error_code numbers(rd_builder *b, const rd_key *k, const rd_value *v, int n, double *out, rd_error *err)
{
    char pb[300], tb[176], rb[64];
    if (v->total != n) {
        if (n == 1)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected a number, got %d values", k->name,
                                    v->total);
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected %d numbers, got %d", k->name, n, v->total);
    }
    rd_key_range_text(k, rb, sizeof rb);
    for (int i = 0; i < n; i++) {
        int r = rd_parse_real(&v->tok[i], &out[i]);
        rd_loc l = token_loc(v, i, pb, sizeof pb);
        if (r == 1)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, l, "%s: expected a number%s, got %s", k->name, rb,
                                    rd_token_what(&v->tok[i], tb, sizeof tb));
        if (r == 2)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, l, "%s: expected a finite number, got %s", k->name,
                                    rd_token_what(&v->tok[i], tb, sizeof tb));
        if (!rd_key_in_range(k, out[i]))
            return rd_builder_error(b, err, k->degenerate ? RD_ERR_INVALID : RD_ERR_SYNTAX, l,
                                    "%s: expected a number%s, got %s", k->name, rb,
                                    rd_token_what(&v->tok[i], tb, sizeof tb));
    }
    return RD_OK;
}

static rd_error_code one_token(rd_builder *b, const rd_key *k, const rd_value *v, const char *what, rd_error *err)
{
    if (v->total != 1)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected %s, got %d values", k->name, what,
                                v->total);
    return RD_OK;
}

static rd_error_code enum_value(rd_builder *b, const rd_key *k, const rd_value *v, int *out, rd_error *err)
{
    char tb[200], list[200] = "";
    rd_error_code rc = one_token(b, k, v, "a word", err);
    if (rc)
        return rc;
    const rd_token *t = &v->tok[0];
    rd_suggestion sg;
    rd_suggest_init(&sg);
    for (int i = 0; k->words[i]; i++) {
        if (strlen(k->words[i]) == t->len && memcmp(k->words[i], t->text, t->len) == 0) {
            *out = i;
            return RD_OK;
        }
        rd_suggest_offer(&sg, t->text, t->len, k->words[i]);
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "", k->words[i]);
    }
    char hint[300];
    return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected one of %s, got %s%s", k->name, list,
                            rd_token_what(t, tb, sizeof tb), rd_suggest_hint(&sg, t->len, hint, sizeof hint));
}

/* A JSON value whose shape cannot be the key's (an array for a number, a
 * number for a name), before its contents are read. */
static rd_error_code check_shape(rd_builder *b, const rd_key *k, const rd_value *v, rd_error *err)
{
    char tb[200];
    int json = v->loc.path != NULL;
    int vector = k->type == RD_KT_VEC2 || k->type == RD_KT_VEC3;
    if (json && v->is_array && !vector && k->type != RD_KT_REAL_OR_VEC3) {
        char what[80];
        if (k->type == RD_KT_INT)
            snprintf(what, sizeof what, "an integer in %lld..%lld", (long long)k->lo, (long long)k->hi);
        else
            snprintf(what, sizeof what, "%s",
                     k->type == RD_KT_NAME     ? "a name (a string)"
                     : k->type == RD_KT_STRING ? "a string"
                     : k->type == RD_KT_ENUM   ? "a word (a string)"
                     : k->type == RD_KT_SEED   ? "an integer"
                                               : "a number");
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected %s, got an array", k->name, what);
    }
    if (json && vector && !v->is_array)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected an array of %d numbers, got %s", k->name,
                                k->type == RD_KT_VEC2 ? 2 : 3, rd_token_what(&v->tok[0], tb, sizeof tb));
    if ((k->type == RD_KT_NAME || k->type == RD_KT_STRING || k->type == RD_KT_ENUM) && v->total == 1 &&
        (v->tok[0].number || v->tok[0].other))
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: expected %s, got %s", k->name,
                                k->type == RD_KT_ENUM ? "a word (a string)" : "a name (a string)",
                                rd_token_what(&v->tok[0], tb, sizeof tb));
    return RD_OK;
}

static rd_error_code store_int(rd_builder *b, const rd_key *k, const rd_value *v, int *dst, rd_error *err)
{
    char tb[200], pb[300];
    long long x;
    rd_error_code rc = one_token(b, k, v, "an integer", err);
    if (rc)
        return rc;
    if (rd_parse_int(&v->tok[0], (long long)k->lo, (long long)k->hi, &x))
        return rd_builder_error(b, err, RD_ERR_SYNTAX, token_loc(v, 0, pb, sizeof pb),
                                "%s: expected an integer in %lld..%lld, got %s", k->name, (long long)k->lo,
                                (long long)k->hi, rd_token_what(&v->tok[0], tb, sizeof tb));
    *dst = (int)x;
    return RD_OK;
}

static rd_error_code store_seed(rd_builder *b, const rd_key *k, const rd_value *v, uint64_t *dst, rd_error *err)
{
    char tb[200];
    unsigned long long x;
    rd_error_code rc = one_token(b, k, v, "an integer", err);
    if (rc)
        return rc;
    /* A JSON number at or above 2^53 may already have lost digits. */
    if (v->tok[0].number && strtod(v->tok[0].text, NULL) >= 9007199254740992.0)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc,
                                "%s: a JSON number of 2^53 or more may have lost digits; write the seed as a "
                                "string, e.g. \"18446744073709551615\"",
                                k->name);
    if (rd_parse_u64(&v->tok[0], &x))
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc,
                                "%s: expected an integer in 0..18446744073709551615, got %s%s", k->name,
                                rd_token_what(&v->tok[0], tb, sizeof tb),
                                v->tok[0].number ? " (JSON numbers above 2^53 lose digits: write a large seed "
                                                   "as a string)"
                                                 : "");
    *dst = x;
    return RD_OK;
}

/* REAL, VEC2, VEC3, and REAL_OR_VEC3 (one number s meaning (s, s, s)). */
static rd_error_code store_numbers(rd_builder *b, const rd_key *k, const rd_value *v, void *dst, rd_error *err)
{
    double d[3];
    int one = k->type == RD_KT_REAL || (k->type == RD_KT_REAL_OR_VEC3 && v->total == 1 && !v->is_array);
    int n = one ? 1 : k->type == RD_KT_VEC2 ? 2 : 3;
    rd_error_code rc = numbers(b, k, v, n, d, err);
    if (rc)
        return rc;
    if (k->type == RD_KT_REAL)
        *(double *)dst = d[0];
    else if (k->type == RD_KT_VEC2)
        memcpy(dst, d, 2 * sizeof d[0]);
    else
        *(rd_vec3 *)dst = one ? v3(d[0], d[0], d[0]) : v3(d[0], d[1], d[2]);
    return RD_OK;
}

static rd_error_code store_text(rd_builder *b, const rd_key *k, const rd_value *v, char **slot, rd_error *err)
{
    rd_error_code rc = one_token(b, k, v, k->type == RD_KT_NAME ? "a name" : "a string", err);
    if (rc)
        return rc;
    const rd_token *t = &v->tok[0];
    if (t->len == 0)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: must not be empty", k->name);
    if (t->len > b->lim.max_name)
        return rd_builder_error(b, err, RD_ERR_LIMIT, v->loc, "%s: longer than the limit of %zu bytes (%s)", k->name,
                                b->lim.max_name, rd_limit_flag(offsetof(rd_scene_limits, max_name)));
    if (memchr(t->text, 0, t->len))
        return rd_builder_error(b, err, RD_ERR_SYNTAX, v->loc, "%s: contains a NUL byte", k->name);
    free(*slot);
    *slot = dupn(t->text, t->len);
    return *slot ? RD_OK : rd_builder_error(b, err, RD_ERR_NOMEM, v->loc, "out of memory");
}

/* Stores entry e into the struct at base. */
static rd_error_code apply(rd_builder *b, const rd_key *k, const rd_entry *e, void *base, rd_error *err)
{
    const rd_value *v = &e->value;
    void *dst = (char *)base + k->offset;
    rd_error_code rc = check_shape(b, k, v, err);
    if (rc)
        return rc;
    switch (k->type) {
    case RD_KT_INT: return store_int(b, k, v, dst, err);
    case RD_KT_SEED: return store_seed(b, k, v, dst, err);
    case RD_KT_REAL:
    case RD_KT_VEC2:
    case RD_KT_VEC3:
    case RD_KT_REAL_OR_VEC3: return store_numbers(b, k, v, dst, err);
    case RD_KT_ENUM: return enum_value(b, k, v, dst, err);
    case RD_KT_NAME:
    case RD_KT_STRING: return store_text(b, k, v, dst, err);
    }
    return RD_OK;
}

static rd_loc where_loc_none(void)
{
    rd_loc l = {0, 0, NULL};
    return l;
}

/* "scene.cfg:7:11" or "scene.json: materials.wood.texture": a place to
 * name in messages about a file the scene refers to. */
static char *loc_text(const rd_builder *b, rd_loc l)
{
    char buf[600];
    if (l.path)
        snprintf(buf, sizeof buf, "%s: %s", b->source, l.path);
    else
        snprintf(buf, sizeof buf, "%s:%d:%d", b->source, l.line, l.column > 0 ? l.column : 1);
    return dupn(buf, strlen(buf));
}

static const char *subtype_noun(rd_section_kind sec) { return sec == RD_SEC_LIGHT ? "light" : "material"; }

static void section_label(char *buf, size_t size, rd_section_kind sec, const char *name, size_t nlen)
{
    if (name && nlen)
        snprintf(buf, size, "[%s %.*s]", rd_section_kind_name(sec), cut(name, nlen), name);
    else
        snprintf(buf, size, "[%s]", rd_section_kind_name(sec));
}

static rd_error_code check_name(rd_builder *b, rd_section_kind sec, const char *name, size_t nlen, rd_loc where,
                                rd_error *err)
{
    if (nlen > b->lim.max_name)
        return rd_builder_error(b, err, RD_ERR_LIMIT, where, "%s name is longer than the limit of %zu bytes (%s)",
                                rd_section_kind_name(sec), b->lim.max_name,
                                rd_limit_flag(offsetof(rd_scene_limits, max_name)));
    long first = rd_name_set_add(&b->names, (int)sec, name, nlen, where.line);
    if (first == -2)
        return rd_builder_error(b, err, RD_ERR_NOMEM, where, "out of memory");
    if (first > 0)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "duplicate %s name '%.*s' (first at line %ld)",
                                rd_section_kind_name(sec), cut(name, nlen), name, first);
    if (first == 0)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "duplicate %s name '%.*s'", rd_section_kind_name(sec),
                                cut(name, nlen), name);
    return RD_OK;
}

static const rd_entry *find_entry(const rd_entry *e, size_t n, const char *key)
{
    size_t len = strlen(key);
    for (size_t i = 0; i < n; i++)
        if (e[i].key_len == len && memcmp(e[i].key, key, len) == 0)
            return &e[i];
    return NULL;
}

static rd_error_code unknown_key(rd_builder *b, rd_section_kind sec, const rd_entry *e, const char *label,
                                 rd_error *err)
{
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    rd_suggestion sg;
    rd_suggest_init(&sg);
    for (size_t i = 0; i < nk; i++)
        if (keys[i].section == sec)
            rd_suggest_offer(&sg, e->key, e->key_len, keys[i].name);
    char hint[300];
    return rd_builder_error(b, err, RD_ERR_SYNTAX, e->key_loc, "unknown key '%.*s' in %s%s", cut(e->key, e->key_len),
                            e->key, label, rd_suggest_hint(&sg, e->key_len, hint, sizeof hint));
}

static rd_loc loc_of(const rd_entry *e, rd_loc fallback) { return e ? e->value.loc : fallback; }

/* Checks that need the whole section: degenerate geometry and pairs of keys. */
static rd_error_code check_section(rd_builder *b, rd_section_kind sec, void *base, const rd_entry *e, size_t n,
                                   rd_loc where, rd_error *err)
{
    if (sec == RD_SEC_CAMERA) {
        rd_camera *c = base;
        rd_vec3 view = v3_sub(c->target, c->eye);
        if (!v3_is_finite(view))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "target"), where),
                                    "camera: target - eye is too large to represent (move them closer)");
        if (!(v3_max_abs(view) > 0))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "target"), where),
                                    "camera: target must differ from eye");
        if (!(v3_max_abs(c->up) > 0))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "up"), where),
                                    "camera: up must not be the zero vector");
        rd_vec3 side = v3_cross(v3_normalize(c->up), v3_normalize(view));
        if (!(v3_len(side) > RD_MIN_UP_SINE))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "up"), where),
                                    "camera: up must not be parallel to target - eye");
    } else if (sec == RD_SEC_PLANE) {
        rd_object *o = base;
        if (!(v3_max_abs(o->normal) > 0))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "normal"), where),
                                    "normal: must not be the zero vector");
    } else if (sec == RD_SEC_LIGHT) {
        rd_light *l = base;
        if ((l->type == RD_LIGHT_DIRECTIONAL || l->type == RD_LIGHT_SPOT) && !(v3_max_abs(l->direction) > 0))
            return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, "direction"), where),
                                    "direction: must not be the zero vector");
    } else if (sec == RD_SEC_TRIANGLE) {
        rd_object *o = base;
        static const char *const groups[2][3] = {{"n0", "n1", "n2"}, {"uv0", "uv1", "uv2"}};
        for (int g = 0; g < 2; g++) {
            int have = 0;
            for (int i = 0; i < 3; i++)
                have += find_entry(e, n, groups[g][i]) != NULL;
            if (have != 0 && have != 3)
                return rd_builder_error(b, err, RD_ERR_SYNTAX, where,
                                        "[triangle] needs all of %s, %s, %s or none of them", groups[g][0],
                                        groups[g][1], groups[g][2]);
            if (g == 0)
                o->has_normals = have == 3;
            else
                o->has_uv = have == 3;
        }
        if (o->has_normals)
            for (int i = 0; i < 3; i++)
                if (!(v3_max_abs(o->n[i]) > 0))
                    return rd_builder_error(b, err, RD_ERR_INVALID, loc_of(find_entry(e, n, groups[0][i]), where),
                                            "%s: must not be the zero vector", groups[0][i]);
    }
    return RD_OK;
}

static rd_error_code add_ref(rd_builder *b, size_t object, rd_loc l, rd_error *err)
{
    if (!rd_grow_array((void **)&b->refs, &b->caprefs, b->nrefs + 1, sizeof *b->refs, 64))
        return rd_builder_error(b, err, RD_ERR_NOMEM, l, "out of memory");
    mat_ref *r = &b->refs[b->nrefs];
    r->object = object;
    r->line = l.line;
    r->column = l.column;
    r->path = l.path ? dupn(l.path, strlen(l.path)) : NULL;
    if (l.path && !r->path)
        return rd_builder_error(b, err, RD_ERR_NOMEM, l, "out of memory");
    b->nrefs++;
    return RD_OK;
}

/* The section kind named by kind, or an error with a did-you-mean. */
static rd_error_code resolve_kind(rd_builder *b, const char *kind, size_t kind_len, rd_loc where, rd_section_kind *sec,
                                  rd_error *err)
{
    int ki = rd_section_kind_find(kind, kind_len);
    if (ki >= 0) {
        *sec = (rd_section_kind)ki;
        return RD_OK;
    }
    rd_suggestion sg;
    rd_suggest_init(&sg);
    for (int k = 0; k < RD_SEC_COUNT; k++)
        rd_suggest_offer(&sg, kind, kind_len, rd_section_kind_name((rd_section_kind)k));
    char hint[300];
    return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "unknown section kind '%.*s'%s", cut(kind, kind_len), kind,
                            rd_suggest_hint(&sg, kind_len, hint, sizeof hint));
}

/* [render] and [camera] once and unnamed, [material NAME] named, names
 * unique per kind. */
static rd_error_code check_header(rd_builder *b, rd_section_kind sec, const char *name, size_t name_len, rd_loc where,
                                  rd_error *err)
{
    int named = name && name_len;
    if (sec == RD_SEC_RENDER || sec == RD_SEC_CAMERA) {
        if (b->seen[sec] > 1)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "duplicate [%s] section (first at line %d)",
                                    rd_section_kind_name(sec), b->seen[sec] - 1);
        if (b->seen[sec])
            return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "duplicate [%s] section", rd_section_kind_name(sec));
        b->seen[sec] = 1 + where.line;
        if (named)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "[%s] takes no name", rd_section_kind_name(sec));
    }
    if (sec == RD_SEC_MATERIAL && !named)
        return rd_builder_error(b, err, RD_ERR_SYNTAX, where, "[material] needs a name, as in [material red]");
    return named ? check_name(b, sec, name, name_len, where, err) : RD_OK;
}

/* Keys of sane length, not too many, none twice. */
static rd_error_code check_entries(rd_builder *b, const char *label, const rd_entry *entries, size_t n, rd_loc where,
                                   rd_error *err)
{
    for (size_t i = 0; i < n; i++)
        if (entries[i].key_len > RD_MAX_KEY_BYTES)
            return rd_builder_error(b, err, RD_ERR_SYNTAX, entries[i].key_loc, "a key longer than %d bytes",
                                    RD_MAX_KEY_BYTES);
    if (n > RD_MAX_SECTION_KEYS)
        return rd_builder_error(b, err, RD_ERR_LIMIT, where, "%s has %zu keys; a section holds at most %d", label, n,
                                RD_MAX_SECTION_KEYS);
    for (size_t i = 1; i < n; i++)
        for (size_t j = 0; j < i; j++) {
            const rd_entry *x = &entries[i], *y = &entries[j];
            if (x->key_len != y->key_len || memcmp(x->key, y->key, x->key_len) != 0)
                continue;
            int shown = cut(x->key, x->key_len);
            if (y->key_loc.line > 0)
                return rd_builder_error(b, err, RD_ERR_SYNTAX, x->key_loc,
                                        "duplicate key '%.*s' in %s (first at line %d)", shown, x->key, label,
                                        y->key_loc.line);
            return rd_builder_error(b, err, RD_ERR_SYNTAX, x->key_loc, "duplicate key '%.*s' in %s", shown, x->key,
                                    label);
        }
    return RD_OK;
}

static rd_error_code too_many(rd_builder *b, rd_loc where, const char *what, size_t limit, size_t offset, rd_error *err)
{
    return rd_builder_error(b, err, RD_ERR_LIMIT, where, "too many %s (limit %zu, %s)", what, limit,
                            rd_limit_flag(offset));
}

/* The struct the section fills: the render or camera settings, or a new
 * light, material or object (within its limit), given its name. */
static rd_error_code alloc_section(rd_builder *b, rd_section_kind sec, const char *name, size_t name_len, rd_loc where,
                                   void **base, size_t *object_index, rd_error *err)
{
    rd_scene *s = b->s;
    *base = NULL;
    char **name_slot = NULL;
    if (sec == RD_SEC_RENDER) {
        *base = &s->render;
    } else if (sec == RD_SEC_CAMERA) {
        *base = &s->camera;
    } else if (sec == RD_SEC_LIGHT) {
        if (s->light_count >= b->lim.max_lights)
            return too_many(b, where, "lights", b->lim.max_lights, offsetof(rd_scene_limits, max_lights), err);
        rd_light *l = rd_scene_add_light(s);
        *base = l;
        name_slot = l ? &l->name : NULL;
    } else if (sec == RD_SEC_MATERIAL) {
        if (s->material_count >= b->lim.max_materials)
            return too_many(b, where, "materials", b->lim.max_materials, offsetof(rd_scene_limits, max_materials), err);
        rd_material *m = rd_scene_add_material(s);
        *base = m;
        name_slot = m ? &m->name : NULL;
    } else {
        if (s->object_count >= b->lim.max_objects)
            return too_many(b, where, "objects", b->lim.max_objects, offsetof(rd_scene_limits, max_objects), err);
        static const rd_object_type types[] = {[RD_SEC_SPHERE] = RD_OBJ_SPHERE,
                                               [RD_SEC_PLANE] = RD_OBJ_PLANE,
                                               [RD_SEC_TRIANGLE] = RD_OBJ_TRIANGLE,
                                               [RD_SEC_MESH] = RD_OBJ_MESH};
        *object_index = s->object_count;
        rd_object *o = rd_scene_add_object(s);
        if (o)
            o->type = types[sec];
        *base = o;
        name_slot = o ? &o->name : NULL;
    }
    if (!*base)
        return rd_builder_error(b, err, RD_ERR_NOMEM, where, "out of memory");
    if (name_slot && name && name_len && !(*name_slot = dupn(name, name_len)))
        return rd_builder_error(b, err, RD_ERR_NOMEM, where, "out of memory");
    return RD_OK;
}

/* A light's or material's type comes first: it decides the defaults and
 * which keys apply. *subtype_bit: the type's bit (1 for other sections). */
static rd_error_code apply_type(rd_builder *b, rd_section_kind sec, const char *label, const rd_entry *entries,
                                size_t n, rd_loc where, void *base, const rd_entry **type_entry, unsigned *subtype_bit,
                                rd_error *err)
{
    *subtype_bit = 1;
    *type_entry = NULL;
    if (sec != RD_SEC_LIGHT && sec != RD_SEC_MATERIAL)
        return RD_OK;
    *type_entry = find_entry(entries, n, "type");
    int t = 0;
    if (*type_entry) {
        rd_error_code rc = enum_value(b, rd_key_find(sec, "type", 4), &(*type_entry)->value, &t, err);
        if (rc)
            return rc;
    } else if (sec == RD_SEC_MATERIAL) {
        return rd_builder_error(b, err, RD_ERR_INVALID, where, "%s is missing required key 'type'", label);
    }
    if (sec == RD_SEC_MATERIAL)
        rd_material_defaults(base, (rd_material_type)t);
    else
        ((rd_light *)base)->type = (rd_light_type)t;
    *subtype_bit = 1u << t;
    return RD_OK;
}

/* One entry into base, through its key; file names keep where they were
 * written, material names are resolved once the scene is complete. */
static rd_error_code apply_entry(rd_builder *b, rd_section_kind sec, const char *label, const rd_entry *e,
                                 unsigned subtype_bit, void *base, size_t object_index, rd_error *err)
{
    const rd_key *k = rd_key_find(sec, e->key, e->key_len);
    if (!k)
        return unknown_key(b, sec, e, label, err);
    if (!(k->applies & subtype_bit)) {
        const char *tn = sec == RD_SEC_LIGHT ? rd_light_type_words[__builtin_ctz(subtype_bit)]
                                             : rd_material_type_words[__builtin_ctz(subtype_bit)];
        return rd_builder_error(b, err, RD_ERR_SYNTAX, e->key_loc, "key '%s' does not apply to a %s %s in %s", k->name,
                                tn, subtype_noun(sec), label);
    }
    rd_error_code rc = apply(b, k, e, base, err);
    if (rc)
        return rc;
    if (strcmp(k->name, "file") == 0 || strcmp(k->name, "texture") == 0) {
        char **at = sec == RD_SEC_MESH ? &((rd_object *)base)->where : &((rd_material *)base)->where;
        free(*at);
        if (!(*at = loc_text(b, e->value.loc)))
            return rd_builder_error(b, err, RD_ERR_NOMEM, where_loc_none(), "out of memory");
    }
    if (k->type == RD_KT_NAME && strcmp(k->name, "material") == 0)
        return add_ref(b, object_index, e->value.loc, err);
    return RD_OK;
}

static rd_error_code check_required(rd_builder *b, rd_section_kind sec, const char *label, const rd_entry *entries,
                                    size_t n, unsigned subtype_bit, rd_loc where, rd_error *err)
{
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    for (size_t i = 0; i < nk; i++)
        if (keys[i].section == sec && (keys[i].required & subtype_bit) && !find_entry(entries, n, keys[i].name))
            return rd_builder_error(b, err, RD_ERR_INVALID, where, "%s is missing required key '%s'", label,
                                    keys[i].name);
    return RD_OK;
}

rd_error_code rd_builder_section(rd_builder *b, const char *kind, size_t kind_len, const char *name, size_t name_len,
                                 rd_loc where, const rd_entry *entries, size_t n, rd_error *err)
{
    rd_section_kind sec = RD_SEC_RENDER;
    rd_error_code rc = resolve_kind(b, kind, kind_len, where, &sec, err);
    if (rc)
        return rc;
    char label[100];
    section_label(label, sizeof label, sec, name, name_len);
    void *base = NULL;
    size_t object_index = 0;
    const rd_entry *type_entry = NULL;
    unsigned subtype_bit = 1;
    if ((rc = check_header(b, sec, name, name_len, where, err)) ||
        (rc = check_entries(b, label, entries, n, where, err)) ||
        (rc = alloc_section(b, sec, name, name_len, where, &base, &object_index, err)) ||
        (rc = apply_type(b, sec, label, entries, n, where, base, &type_entry, &subtype_bit, err)))
        return rc;
    for (size_t i = 0; i < n; i++)
        if (&entries[i] != type_entry &&
            (rc = apply_entry(b, sec, label, &entries[i], subtype_bit, base, object_index, err)))
            return rc;
    rc = check_required(b, sec, label, entries, n, subtype_bit, where, err);
    return rc ? rc : check_section(b, sec, base, entries, n, where, err);
}

rd_error_code rd_builder_finish(rd_builder *b, rd_error *err)
{
    rd_scene *s = b->s;
    for (size_t i = 0; i < b->nrefs; i++) {
        rd_object *o = &s->objects[b->refs[i].object];
        int m = rd_scene_find_material(s, o->material_name);
        rd_loc l = {b->refs[i].line, b->refs[i].column, b->refs[i].path};
        if (m < 0) {
            rd_suggestion sg;
            rd_suggest_init(&sg);
            for (size_t j = 0; j < s->material_count; j++)
                rd_suggest_offer(&sg, o->material_name, strlen(o->material_name), s->materials[j].name);
            char hint[300];
            size_t len = strlen(o->material_name);
            return rd_builder_error(b, err, RD_ERR_INVALID, l, "no material named '%.*s'%s", cut(o->material_name, len),
                                    o->material_name, rd_suggest_hint(&sg, len, hint, sizeof hint));
        }
        o->material = m;
    }
    return RD_OK;
}
