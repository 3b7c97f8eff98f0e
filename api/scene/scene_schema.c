#include "scene_schema.h"

#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "json_text.h"
#include "rayd/scene.h"
#include "scene_keys.h"

static cJSON *number_schema(const rd_key *k, const char *type)
{
    cJSON *s = cJSON_CreateObject();
    cJSON_AddStringToObject(s, "type", type);
    if (!isinf(k->lo))
        cJSON_AddNumberToObject(s, k->lo_open ? "exclusiveMinimum" : "minimum", k->lo);
    if (!isinf(k->hi))
        cJSON_AddNumberToObject(s, k->hi_open ? "exclusiveMaximum" : "maximum", k->hi);
    return s;
}

static cJSON *array_of_numbers(int n)
{
    cJSON *s = cJSON_CreateObject();
    cJSON_AddStringToObject(s, "type", "array");
    cJSON *items = cJSON_AddObjectToObject(s, "items");
    cJSON_AddStringToObject(items, "type", "number");
    cJSON_AddNumberToObject(s, "minItems", n);
    cJSON_AddNumberToObject(s, "maxItems", n);
    return s;
}

static cJSON *key_schema(const rd_key *k)
{
    switch (k->type) {
    case RD_KT_INT: return number_schema(k, "integer");
    case RD_KT_SEED: {
        cJSON *s = cJSON_CreateObject();
        cJSON_AddStringToObject(s, "type", "integer");
        cJSON_AddNumberToObject(s, "minimum", 0);
        return s;
    }
    case RD_KT_REAL: return number_schema(k, "number");
    case RD_KT_VEC2: return array_of_numbers(2);
    case RD_KT_VEC3: return array_of_numbers(3);
    case RD_KT_REAL_OR_VEC3: {
        cJSON *s = cJSON_CreateObject();
        cJSON *one = cJSON_AddArrayToObject(s, "oneOf");
        cJSON *num = cJSON_CreateObject();
        cJSON_AddStringToObject(num, "type", "number");
        cJSON_AddItemToArray(one, num);
        cJSON_AddItemToArray(one, array_of_numbers(3));
        return s;
    }
    case RD_KT_ENUM: {
        cJSON *s = cJSON_CreateObject();
        int n = 0;
        while (k->words[n])
            n++;
        cJSON_AddItemToObject(s, "enum", cJSON_CreateStringArray(k->words, n));
        return s;
    }
    case RD_KT_NAME:
    case RD_KT_STRING: {
        cJSON *s = cJSON_CreateObject();
        cJSON_AddStringToObject(s, "type", "string");
        cJSON_AddNumberToObject(s, "minLength", 1);
        return s;
    }
    }
    return cJSON_CreateObject();
}

/* An object schema for one section kind. extra: structural members such as
 * "name"; subtype_words: for lights and materials, one if/then per type
 * limiting the keys to those that apply and requiring the required ones. */
static cJSON *section_schema(rd_section_kind sec, const char *const *extra,
                             const char *const *subtype_words, const char *default_type)
{
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    cJSON *s = cJSON_CreateObject();
    cJSON_AddStringToObject(s, "type", "object");
    cJSON *props = cJSON_AddObjectToObject(s, "properties");
    for (int i = 0; extra && extra[i]; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "type", "string");
        cJSON_AddNumberToObject(e, "minLength", 1);
        cJSON_AddItemToObject(props, extra[i], e);
    }
    for (size_t i = 0; i < nk; i++)
        if (keys[i].section == sec)
            cJSON_AddItemToObject(props, keys[i].name, key_schema(&keys[i]));
    cJSON_AddFalseToObject(s, "additionalProperties");
    if (!subtype_words) {
        cJSON *req = cJSON_CreateArray();
        for (size_t i = 0; i < nk; i++)
            if (keys[i].section == sec && keys[i].required)
                cJSON_AddItemToArray(req, cJSON_CreateString(keys[i].name));
        if (cJSON_GetArraySize(req))
            cJSON_AddItemToObject(s, "required", req);
        else
            cJSON_Delete(req);
        return s;
    }
    if (!default_type)
        cJSON_AddItemToObject(s, "required", cJSON_CreateStringArray((const char *[]){"type"}, 1));
    cJSON *all = cJSON_AddArrayToObject(s, "allOf");
    for (int t = 0; subtype_words[t]; t++) {
        unsigned bit = 1u << t;
        cJSON *rule = cJSON_CreateObject();
        cJSON *ifs = cJSON_AddObjectToObject(rule, "if");
        cJSON *ifp = cJSON_AddObjectToObject(ifs, "properties");
        cJSON *c = cJSON_AddObjectToObject(ifp, "type");
        cJSON_AddStringToObject(c, "const", subtype_words[t]);
        /* Without "type" a light is a point light: only that rule applies. */
        if (!default_type || strcmp(default_type, subtype_words[t]) != 0)
            cJSON_AddItemToObject(ifs, "required", cJSON_CreateStringArray((const char *[]){"type"}, 1));
        cJSON *then = cJSON_AddObjectToObject(rule, "then");
        cJSON *names = cJSON_CreateArray();
        cJSON *req = cJSON_CreateArray();
        cJSON_AddItemToArray(names, cJSON_CreateString("type"));
        for (int i = 0; extra && extra[i]; i++)
            cJSON_AddItemToArray(names, cJSON_CreateString(extra[i]));
        for (size_t i = 0; i < nk; i++) {
            if (keys[i].section != sec || strcmp(keys[i].name, "type") == 0)
                continue;
            if (keys[i].applies & bit)
                cJSON_AddItemToArray(names, cJSON_CreateString(keys[i].name));
            if (keys[i].required & bit)
                cJSON_AddItemToArray(req, cJSON_CreateString(keys[i].name));
        }
        cJSON *pn = cJSON_AddObjectToObject(then, "propertyNames");
        cJSON_AddItemToObject(pn, "enum", names);
        if (cJSON_GetArraySize(req))
            cJSON_AddItemToObject(then, "required", req);
        else
            cJSON_Delete(req);
        cJSON_AddItemToArray(all, rule);
    }
    return s;
}

static cJSON *objects_schema(void)
{
    static const rd_section_kind kinds[] = {RD_SEC_SPHERE, RD_SEC_PLANE, RD_SEC_TRIANGLE, RD_SEC_MESH};
    cJSON *arr = cJSON_CreateObject();
    cJSON_AddStringToObject(arr, "type", "array");
    cJSON *items = cJSON_AddObjectToObject(arr, "items");
    cJSON *one = cJSON_AddArrayToObject(items, "oneOf");
    static const char *const extra[] = {"name", NULL};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        cJSON *s = section_schema(kinds[i], extra, NULL, NULL);
        cJSON *props = cJSON_GetObjectItemCaseSensitive(s, "properties");
        cJSON *t = cJSON_CreateObject();
        cJSON_AddStringToObject(t, "const", rd_section_kind_name(kinds[i]));
        cJSON_AddItemToObject(props, "type", t);
        cJSON *req = cJSON_GetObjectItemCaseSensitive(s, "required");
        if (req)
            cJSON_AddItemToArray(req, cJSON_CreateString("type"));
        cJSON_AddItemToArray(one, s);
    }
    return arr;
}

rd_error_code rd_scene_schema(char **out, rd_error *err)
{
    *out = NULL;
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    cJSON_AddStringToObject(root, "$schema", "https://json-schema.org/draft/2020-12/schema");
    cJSON_AddStringToObject(root, "title", "rayd scene");
    cJSON_AddStringToObject(root, "description",
                            "A rayd scene in JSON (scene-format.md). Generated by 'rayd schema' from the "
                            "parser's key table. The parser also checks what a schema cannot: material "
                            "names exist, numbers are finite, geometry is not degenerate, size limits.");
    cJSON_AddStringToObject(root, "type", "object");
    cJSON *props = cJSON_AddObjectToObject(root, "properties");
    cJSON_AddItemToObject(props, "render", section_schema(RD_SEC_RENDER, NULL, NULL, NULL));
    cJSON_AddItemToObject(props, "camera", section_schema(RD_SEC_CAMERA, NULL, NULL, NULL));
    static const char *const light_extra[] = {"name", NULL};
    cJSON *lights = cJSON_AddObjectToObject(props, "lights");
    cJSON_AddStringToObject(lights, "type", "array");
    cJSON_AddItemToObject(lights, "items",
                          section_schema(RD_SEC_LIGHT, light_extra, rd_light_type_words, "point"));
    cJSON *mats = cJSON_AddObjectToObject(props, "materials");
    cJSON_AddStringToObject(mats, "type", "object");
    cJSON_AddItemToObject(mats, "additionalProperties",
                          section_schema(RD_SEC_MATERIAL, NULL, rd_material_type_words, NULL));
    cJSON_AddItemToObject(props, "objects", objects_schema());
    cJSON_AddFalseToObject(root, "additionalProperties");
    char *copy = rd_json_print(root);
    if (!copy)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    *out = copy;
    return RD_OK;
}
