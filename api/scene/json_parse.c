#include "json_parse.h"

#include <cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_check.h"
#include "name_set.h"
#include "number_text.h"
#include "scene_builder.h"
#include "scene_keys.h"
#include "suggest.h"
#include "utf8.h"

/* A name as "%.*s" arguments: at most 60 characters, none of them split. */
#define CUT(s) (int)rd_utf8_prefix((s), strlen(s), 60), (s)

#define PATH_MAX_LEN 300
#define NUM_TEXT 32

typedef struct {
    const char *source;
    rd_builder *b;
    rd_scene_limits lim;
    /* per section scratch: entries and the text of their numbers */
    rd_entry *entries;
    char (*paths)[PATH_MAX_LEN];
    char (*nums)[RD_VALUE_MAX_TOKENS][NUM_TEXT];
    size_t cap;
} jparser;

static rd_loc path_loc(const char *path)
{
    rd_loc l = {0, 0, path};
    return l;
}

/* Line and column of byte offset off. */
static rd_loc text_loc(const char *text, size_t len, size_t off)
{
    rd_loc l = {0, 0, NULL};
    rd_utf8_position(text, len, off, &l.line, &l.column);
    return l;
}

static int grow(jparser *jp, size_t n)
{
    if (n <= jp->cap)
        return 1;
    size_t nc = jp->cap ? jp->cap : 16;
    while (nc < n)
        nc *= 2;
    rd_entry *e = realloc(jp->entries, nc * sizeof *e);
    if (!e)
        return 0;
    jp->entries = e;
    char(*p)[PATH_MAX_LEN] = realloc(jp->paths, nc * sizeof *p);
    if (!p)
        return 0;
    jp->paths = p;
    char(*t)[RD_VALUE_MAX_TOKENS][NUM_TEXT] = realloc(jp->nums, nc * sizeof *t);
    if (!t)
        return 0;
    jp->nums = t;
    jp->cap = nc;
    return 1;
}

/* One JSON value as a token: numbers keep a round-trip text, strings their
 * characters, anything else a word that no key accepts. */
static rd_token token_of(const cJSON *v, char *numbuf)
{
    rd_token t = {"", 0, 0, 0, 1, 0};
    if (cJSON_IsNumber(v)) {
        rd_number_text(v->valuedouble, numbuf, NUM_TEXT);
        t.text = numbuf;
        t.number = 1;
        t.other = 0;
    } else if (cJSON_IsString(v)) {
        t.text = v->valuestring;
        t.quoted = 1;
        t.other = 0;
    } else if (cJSON_IsArray(v)) {
        t.text = "[...]";
    } else if (cJSON_IsObject(v)) {
        t.text = "{...}";
    } else if (cJSON_IsTrue(v)) {
        t.text = "true";
    } else if (cJSON_IsFalse(v)) {
        t.text = "false";
    } else {
        t.text = "null";
    }
    t.len = strlen(t.text);
    return t;
}

/* Applies the members of obj (except those named in skip) as one section. */
static rd_error_code section(jparser *jp, const char *kind, const char *name, const char *path, const cJSON *obj,
                             const char *const *skip, rd_error *err)
{
    size_t n = 0;
    for (const cJSON *m = obj->child; m; m = m->next)
        n++;
    if (!grow(jp, n + 1))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", jp->source);
    size_t k = 0;
    for (const cJSON *m = obj->child; m; m = m->next) {
        int skipped = 0;
        for (int i = 0; skip && skip[i]; i++)
            skipped |= strcmp(m->string, skip[i]) == 0;
        if (skipped)
            continue;
        rd_entry *e = &jp->entries[k];
        memset(e, 0, sizeof *e);
        snprintf(jp->paths[k], PATH_MAX_LEN, "%.200s.%.*s", path, CUT(m->string));
        e->key = m->string;
        e->key_len = strlen(m->string);
        e->key_loc = path_loc(jp->paths[k]);
        e->value.loc = path_loc(jp->paths[k]);
        if (cJSON_IsArray(m)) {
            e->value.is_array = 1;
            for (const cJSON *a = m->child; a; a = a->next) {
                if (e->value.n < RD_VALUE_MAX_TOKENS) {
                    e->value.tok[e->value.n] = token_of(a, jp->nums[k][e->value.n]);
                    e->value.n++;
                }
                e->value.total++;
            }
        } else {
            e->value.tok[0] = token_of(m, jp->nums[k][0]);
            e->value.n = e->value.total = 1;
        }
        k++;
    }
    return rd_builder_section(jp->b, kind, strlen(kind), name, name ? strlen(name) : 0, path_loc(path), jp->entries, k,
                              err);
}

static rd_error_code expect_object(jparser *jp, const cJSON *v, const char *path, const char *what, rd_error *err)
{
    if (cJSON_IsObject(v))
        return RD_OK;
    return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc(path), "expected %s (an object)", what);
}

/* A string member used for structure (a light's name, an object's type). */
static rd_error_code string_member(jparser *jp, const cJSON *obj, const char *key, const char *path, const char **out,
                                   rd_error *err)
{
    *out = NULL;
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!m)
        return RD_OK;
    if (!cJSON_IsString(m)) {
        char p[PATH_MAX_LEN];
        snprintf(p, sizeof p, "%.200s.%s", path, key);
        return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc(p), "%s: expected a string", key);
    }
    *out = m->valuestring;
    return RD_OK;
}

static rd_error_code duplicates(jparser *jp, const cJSON *obj, const char *path, rd_error *err)
{
    /* A set of the member names keeps objects with many members linear. */
    rd_name_set seen;
    rd_name_set_init(&seen);
    const cJSON *dup = NULL;
    long first = -1;
    for (const cJSON *a = obj->child; a && !dup && first != -2; a = a->next)
        if (a->string && (first = rd_name_set_add(&seen, 0, a->string, strlen(a->string), 1)) >= 0)
            dup = a;
    rd_name_set_free(&seen);
    if (first == -2)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", jp->source);
    if (dup) {
        char p[PATH_MAX_LEN];
        if (*path)
            snprintf(p, sizeof p, "%.200s.%.*s", path, CUT(dup->string));
        else
            snprintf(p, sizeof p, "%.*s", CUT(dup->string));
        return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc(p), "duplicate key '%.*s'", CUT(dup->string));
    }
    for (const cJSON *a = obj->child; a; a = a->next)
        if (cJSON_IsObject(a) || cJSON_IsArray(a)) {
            char p[PATH_MAX_LEN];
            if (*path)
                snprintf(p, sizeof p, "%.200s.%.*s", path, CUT(a->string ? a->string : ""));
            else
                snprintf(p, sizeof p, "%.*s", CUT(a->string ? a->string : ""));
            if (cJSON_IsObject(a)) {
                rd_error_code rc = duplicates(jp, a, p, err);
                if (rc)
                    return rc;
            } else {
                int i = 0;
                for (const cJSON *e = a->child; e; e = e->next, i++) {
                    if (!cJSON_IsObject(e))
                        continue;
                    char q[PATH_MAX_LEN + 16];
                    snprintf(q, sizeof q, "%.200s[%d]", p, i);
                    rd_error_code rc = duplicates(jp, e, q, err);
                    if (rc)
                        return rc;
                }
            }
        }
    return RD_OK;
}

static rd_error_code top_level(jparser *jp, const cJSON *root, rd_error *err)
{
    static const char *const tops[] = {"render", "camera", "lights", "materials", "objects", NULL};
    rd_error_code rc;
    if (!cJSON_IsObject(root))
        return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, (rd_loc){1, 1, NULL},
                                "expected a JSON object with render, camera, lights, materials, objects");
    if ((rc = duplicates(jp, root, "", err)))
        return rc;
    for (const cJSON *m = root->child; m; m = m->next) {
        int known = 0;
        rd_suggestion sg;
        rd_suggest_init(&sg);
        for (int i = 0; tops[i]; i++) {
            known |= strcmp(m->string, tops[i]) == 0;
            rd_suggest_offer(&sg, m->string, strlen(m->string), tops[i]);
        }
        if (!known) {
            char p[PATH_MAX_LEN], hint[300];
            snprintf(p, sizeof p, "%.*s", CUT(m->string));
            return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc(p), "unknown key '%.*s'%s", CUT(m->string),
                                    rd_suggest_hint(&sg, strlen(m->string), hint, sizeof hint));
        }
    }
    const cJSON *v;
    if ((v = cJSON_GetObjectItemCaseSensitive(root, "render"))) {
        if ((rc = expect_object(jp, v, "render", "the render settings", err)) ||
            (rc = section(jp, "render", NULL, "render", v, NULL, err)))
            return rc;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(root, "camera"))) {
        if ((rc = expect_object(jp, v, "camera", "the camera", err)) ||
            (rc = section(jp, "camera", NULL, "camera", v, NULL, err)))
            return rc;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(root, "materials"))) {
        if ((rc = expect_object(jp, v, "materials", "materials by name", err)))
            return rc;
        for (const cJSON *m = v->child; m; m = m->next) {
            char p[PATH_MAX_LEN];
            snprintf(p, sizeof p, "materials.%.*s", CUT(m->string));
            if ((rc = expect_object(jp, m, p, "a material", err)) ||
                (rc = section(jp, "material", m->string, p, m, NULL, err)))
                return rc;
        }
    }
    static const char *const light_skip[] = {"name", NULL};
    static const char *const object_skip[] = {"name", "type", NULL};
    if ((v = cJSON_GetObjectItemCaseSensitive(root, "lights"))) {
        if (!cJSON_IsArray(v))
            return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc("lights"), "expected an array of lights");
        int i = 0;
        for (const cJSON *m = v->child; m; m = m->next, i++) {
            char p[PATH_MAX_LEN];
            const char *name;
            snprintf(p, sizeof p, "lights[%d]", i);
            if ((rc = expect_object(jp, m, p, "a light", err)) || (rc = string_member(jp, m, "name", p, &name, err)) ||
                (rc = section(jp, "light", name, p, m, light_skip, err)))
                return rc;
        }
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(root, "objects"))) {
        if (!cJSON_IsArray(v))
            return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc("objects"), "expected an array of objects");
        int i = 0;
        for (const cJSON *m = v->child; m; m = m->next, i++) {
            char p[PATH_MAX_LEN];
            const char *name, *type;
            snprintf(p, sizeof p, "objects[%d]", i);
            if ((rc = expect_object(jp, m, p, "an object", err)) ||
                (rc = string_member(jp, m, "name", p, &name, err)) ||
                (rc = string_member(jp, m, "type", p, &type, err)))
                return rc;
            if (!type)
                return rd_builder_error(jp->b, err, RD_ERR_INVALID, path_loc(p),
                                        "object is missing required key 'type' (sphere, plane, triangle or mesh)");
            rd_suggestion sg;
            rd_suggest_init(&sg);
            int known = 0;
            for (int k = RD_SEC_SPHERE; k < RD_SEC_COUNT; k++) {
                const char *kind = rd_section_kind_name((rd_section_kind)k);
                known |= strcmp(type, kind) == 0;
                rd_suggest_offer(&sg, type, strlen(type), kind);
            }
            if (!known) {
                char q[PATH_MAX_LEN + 8];
                char hint[300];
                snprintf(q, sizeof q, "%.200s.type", p);
                return rd_builder_error(jp->b, err, RD_ERR_SYNTAX, path_loc(q),
                                        "type: expected one of sphere, plane, triangle, mesh, got '%.*s'%s", CUT(type),
                                        rd_suggest_hint(&sg, strlen(type), hint, sizeof hint));
            }
            if ((rc = section(jp, type, name, p, m, object_skip, err)))
                return rc;
        }
    }
    return rd_builder_finish(jp->b, err);
}

rd_error_code rd_json_parse(const char *text, size_t len, const char *source, const rd_scene_limits *lim_in,
                            rd_scene *s, rd_error *err)
{
    jparser jp;
    memset(&jp, 0, sizeof jp);
    jp.lim = lim_in ? *lim_in : rd_scene_limits_default();
    jp.source = source ? source : "<scene>";
    rd_error_code rc = rd_scene_text_check(text, len, jp.source, &jp.lim, err);
    if (rc)
        return rc;
    size_t skip = rd_utf8_bom(text, len);
    rc = rd_json_check(text + skip, len - skip, jp.source, jp.lim.max_nesting, jp.lim.max_name, err);
    if (rc)
        return rc;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text + skip, len - skip, &end, 0);
    /* cJSON reads every text the strict check passed, up to its own
     * nesting limit: within that, no tree means no memory. */
    if (!root && jp.lim.max_nesting <= CJSON_NESTING_LIMIT)
        return rd_loc_error(err, RD_ERR_NOMEM, jp.source, (rd_loc){0, 0, NULL}, "out of memory");
    if (!root) {
        size_t off = end && end >= text + skip && end <= text + len ? (size_t)(end - text) : len;
        rd_loc l = text_loc(text, len, off);
        if (off >= len)
            return rd_loc_error(err, RD_ERR_SYNTAX, jp.source, l, "JSON syntax error: unexpected end of input");
        return rd_loc_error(err, RD_ERR_SYNTAX, jp.source, l, "JSON syntax error");
    }
    /* Only white space may follow the value. */
    size_t off = (size_t)(end - text);
    while (off < len && (text[off] == ' ' || text[off] == '\t' || text[off] == '\r' || text[off] == '\n'))
        off++;
    if (off < len) {
        cJSON_Delete(root);
        return rd_loc_error(err, RD_ERR_SYNTAX, jp.source, text_loc(text, len, off),
                            "JSON syntax error: text after the scene object");
    }
    jp.b = rd_builder_new(s, jp.source, &jp.lim);
    if (!jp.b) {
        cJSON_Delete(root);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "%s: out of memory", jp.source);
    }
    rc = top_level(&jp, root, err);
    rd_builder_free(jp.b);
    cJSON_Delete(root);
    free(jp.entries);
    free(jp.paths);
    free(jp.nums);
    return rc;
}
