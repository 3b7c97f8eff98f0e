#include "scene_schema.h"

#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "json_text.h"
#include "rayd/scene.h"
#include "scene_keys.h"

/* Every builder below takes f, set when any part could not be made (cJSON
 * out of memory; rd_json_add): the tree is then incomplete, and dropped. */

static cJSON *number_schema(const rd_key *k, const char *type, int *f)
{
    cJSON *s = cJSON_CreateObject();
    rd_json_add(s, "type", cJSON_CreateString(type), f);
    if (!isinf(k->lo))
        rd_json_add(s, k->lo_open ? "exclusiveMinimum" : "minimum", cJSON_CreateNumber(k->lo), f);
    if (!isinf(k->hi))
        rd_json_add(s, k->hi_open ? "exclusiveMaximum" : "maximum", cJSON_CreateNumber(k->hi), f);
    return s;
}

static cJSON *array_of_numbers(int n, int *f)
{
    cJSON *s = cJSON_CreateObject();
    rd_json_add(s, "type", cJSON_CreateString("array"), f);
    cJSON *items = rd_json_add(s, "items", cJSON_CreateObject(), f);
    rd_json_add(items, "type", cJSON_CreateString("number"), f);
    rd_json_add(s, "minItems", cJSON_CreateNumber(n), f);
    rd_json_add(s, "maxItems", cJSON_CreateNumber(n), f);
    return s;
}

static cJSON *key_schema(const rd_key *k, int *f)
{
    switch (k->type) {
    case RD_KT_INT: return number_schema(k, "integer", f);
    case RD_KT_SEED: {
        cJSON *s = cJSON_CreateObject();
        rd_json_add(s, "type", cJSON_CreateString("integer"), f);
        rd_json_add(s, "minimum", cJSON_CreateNumber(0), f);
        return s;
    }
    case RD_KT_REAL: return number_schema(k, "number", f);
    case RD_KT_VEC2: return array_of_numbers(2, f);
    case RD_KT_VEC3: return array_of_numbers(3, f);
    case RD_KT_REAL_OR_VEC3: {
        cJSON *s = cJSON_CreateObject();
        cJSON *one = rd_json_add(s, "oneOf", cJSON_CreateArray(), f);
        cJSON *num = rd_json_add(one, NULL, cJSON_CreateObject(), f);
        rd_json_add(num, "type", cJSON_CreateString("number"), f);
        rd_json_add(one, NULL, array_of_numbers(3, f), f);
        return s;
    }
    case RD_KT_ENUM: {
        cJSON *s = cJSON_CreateObject();
        int n = 0;
        while (k->words[n])
            n++;
        rd_json_add(s, "enum", cJSON_CreateStringArray(k->words, n), f);
        return s;
    }
    case RD_KT_NAME:
    case RD_KT_STRING: {
        cJSON *s = cJSON_CreateObject();
        rd_json_add(s, "type", cJSON_CreateString("string"), f);
        rd_json_add(s, "minLength", cJSON_CreateNumber(1), f);
        return s;
    }
    }
    return cJSON_CreateObject();
}

/* An object schema for one section kind. extra: structural members such as
 * "name"; subtype_words: for lights and materials, one if/then per type
 * limiting the keys to those that apply and requiring the required ones. */
static cJSON *section_schema(rd_section_kind sec, const char *const *extra, const char *const *subtype_words,
                             const char *default_type, int *f)
{
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    cJSON *s = cJSON_CreateObject();
    rd_json_add(s, "type", cJSON_CreateString("object"), f);
    cJSON *props = rd_json_add(s, "properties", cJSON_CreateObject(), f);
    for (int i = 0; extra && extra[i]; i++) {
        cJSON *e = rd_json_add(props, extra[i], cJSON_CreateObject(), f);
        rd_json_add(e, "type", cJSON_CreateString("string"), f);
        rd_json_add(e, "minLength", cJSON_CreateNumber(1), f);
    }
    for (size_t i = 0; i < nk; i++)
        if (keys[i].section == sec)
            rd_json_add(props, keys[i].name, key_schema(&keys[i], f), f);
    rd_json_add(s, "additionalProperties", cJSON_CreateFalse(), f);
    if (!subtype_words) {
        cJSON *req = cJSON_CreateArray();
        if (!req)
            *f = 1;
        for (size_t i = 0; i < nk; i++)
            if (keys[i].section == sec && keys[i].required)
                rd_json_add(req, NULL, cJSON_CreateString(keys[i].name), f);
        if (cJSON_GetArraySize(req))
            rd_json_add(s, "required", req, f);
        else
            cJSON_Delete(req);
        return s;
    }
    if (!default_type)
        rd_json_add(s, "required", cJSON_CreateStringArray((const char *[]){"type"}, 1), f);
    cJSON *all = rd_json_add(s, "allOf", cJSON_CreateArray(), f);
    for (int t = 0; subtype_words[t]; t++) {
        unsigned bit = 1u << t;
        cJSON *rule = rd_json_add(all, NULL, cJSON_CreateObject(), f);
        cJSON *ifs = rd_json_add(rule, "if", cJSON_CreateObject(), f);
        cJSON *ifp = rd_json_add(ifs, "properties", cJSON_CreateObject(), f);
        cJSON *c = rd_json_add(ifp, "type", cJSON_CreateObject(), f);
        rd_json_add(c, "const", cJSON_CreateString(subtype_words[t]), f);
        /* Without "type" a light is a point light: only that rule applies. */
        if (!default_type || strcmp(default_type, subtype_words[t]) != 0)
            rd_json_add(ifs, "required", cJSON_CreateStringArray((const char *[]){"type"}, 1), f);
        cJSON *then = rd_json_add(rule, "then", cJSON_CreateObject(), f);
        cJSON *pn = rd_json_add(then, "propertyNames", cJSON_CreateObject(), f);
        cJSON *names = rd_json_add(pn, "enum", cJSON_CreateArray(), f);
        cJSON *req = cJSON_CreateArray();
        if (!req)
            *f = 1;
        rd_json_add(names, NULL, cJSON_CreateString("type"), f);
        for (int i = 0; extra && extra[i]; i++)
            rd_json_add(names, NULL, cJSON_CreateString(extra[i]), f);
        for (size_t i = 0; i < nk; i++) {
            if (keys[i].section != sec || strcmp(keys[i].name, "type") == 0)
                continue;
            if (keys[i].applies & bit)
                rd_json_add(names, NULL, cJSON_CreateString(keys[i].name), f);
            if (keys[i].required & bit)
                rd_json_add(req, NULL, cJSON_CreateString(keys[i].name), f);
        }
        if (cJSON_GetArraySize(req))
            rd_json_add(then, "required", req, f);
        else
            cJSON_Delete(req);
    }
    return s;
}

static cJSON *objects_schema(int *f)
{
    static const rd_section_kind kinds[] = {RD_SEC_SPHERE, RD_SEC_PLANE, RD_SEC_TRIANGLE, RD_SEC_MESH};
    cJSON *arr = cJSON_CreateObject();
    rd_json_add(arr, "type", cJSON_CreateString("array"), f);
    cJSON *items = rd_json_add(arr, "items", cJSON_CreateObject(), f);
    cJSON *one = rd_json_add(items, "oneOf", cJSON_CreateArray(), f);
    static const char *const extra[] = {"name", NULL};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        cJSON *s = rd_json_add(one, NULL, section_schema(kinds[i], extra, NULL, NULL, f), f);
        cJSON *props = cJSON_GetObjectItemCaseSensitive(s, "properties");
        cJSON *t = rd_json_add(props, "type", cJSON_CreateObject(), f);
        rd_json_add(t, "const", cJSON_CreateString(rd_section_kind_name(kinds[i])), f);
        cJSON *req = cJSON_GetObjectItemCaseSensitive(s, "required");
        if (req)
            rd_json_add(req, NULL, cJSON_CreateString("type"), f);
    }
    return arr;
}

rd_error_code rd_scene_schema(char **out, rd_error *err)
{
    *out = NULL;
    int f = 0;
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_json_add(root, "$schema", cJSON_CreateString("https://json-schema.org/draft/2020-12/schema"), &f);
    rd_json_add(root, "title", cJSON_CreateString("rayd scene"), &f);
    rd_json_add(root, "description",
                cJSON_CreateString("A rayd scene in JSON (scene-format.md). Generated by 'rayd schema' from the "
                                   "parser's key table. The parser also checks what a schema cannot: material "
                                   "names exist, numbers are finite, geometry is not degenerate, size limits."),
                &f);
    rd_json_add(root, "type", cJSON_CreateString("object"), &f);
    cJSON *props = rd_json_add(root, "properties", cJSON_CreateObject(), &f);
    rd_json_add(props, "render", section_schema(RD_SEC_RENDER, NULL, NULL, NULL, &f), &f);
    rd_json_add(props, "camera", section_schema(RD_SEC_CAMERA, NULL, NULL, NULL, &f), &f);
    static const char *const light_extra[] = {"name", NULL};
    cJSON *lights = rd_json_add(props, "lights", cJSON_CreateObject(), &f);
    rd_json_add(lights, "type", cJSON_CreateString("array"), &f);
    rd_json_add(lights, "items", section_schema(RD_SEC_LIGHT, light_extra, rd_light_type_words, "point", &f), &f);
    cJSON *mats = rd_json_add(props, "materials", cJSON_CreateObject(), &f);
    rd_json_add(mats, "type", cJSON_CreateString("object"), &f);
    rd_json_add(mats, "additionalProperties", section_schema(RD_SEC_MATERIAL, NULL, rd_material_type_words, NULL, &f),
                &f);
    rd_json_add(props, "objects", objects_schema(&f), &f);
    rd_json_add(root, "additionalProperties", cJSON_CreateFalse(), &f);
    if (f) {
        cJSON_Delete(root);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    char *copy = rd_json_print(root);
    if (!copy)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    *out = copy;
    return RD_OK;
}
