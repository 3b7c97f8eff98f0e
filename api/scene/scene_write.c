#include "scene_write.h"

#include <cJSON.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_text.h"
#include "number_text.h"
#include "scene_keys.h"
#include "strbuf.h"

/* What a key's field holds when nobody wrote it, for a section of the
 * given subtype: a fresh section built the way the reader builds one. */
typedef union {
    rd_render_settings r;
    rd_camera c;
    rd_light l;
    rd_material m;
    rd_object o;
} any_section;

/* 0 when out of memory. */
static int defaults_for(rd_section_kind sec, int subtype, any_section *d)
{
    memset(d, 0, sizeof *d);
    rd_scene s;
    rd_scene_init(&s);
    int ok = 1;
    switch (sec) {
    case RD_SEC_RENDER: d->r = s.render; break;
    case RD_SEC_CAMERA: d->c = s.camera; break;
    case RD_SEC_LIGHT: {
        rd_light *l = rd_scene_add_light(&s);
        if (l) {
            l->type = (rd_light_type)subtype;
            d->l = *l;
        }
        ok = l != NULL;
        break;
    }
    case RD_SEC_MATERIAL: rd_material_defaults(&d->m, (rd_material_type)subtype); break;
    default: {
        rd_object *o = rd_scene_add_object(&s);
        if (o)
            d->o = *o;
        ok = o != NULL;
        break;
    }
    }
    rd_scene_free(&s);
    return ok;
}

static int key_bytes(const rd_key *k)
{
    switch (k->type) {
    case RD_KT_INT:
    case RD_KT_ENUM: return sizeof(int);
    case RD_KT_SEED: return sizeof(uint64_t);
    case RD_KT_REAL: return sizeof(double);
    case RD_KT_VEC2: return 2 * sizeof(double);
    case RD_KT_VEC3:
    case RD_KT_REAL_OR_VEC3: return sizeof(rd_vec3);
    default: return 0;
    }
}

/* Whether key k of the section at base should be written; every: also at
 * its default. */
static int wanted(const rd_key *k, unsigned bit, const void *base, const any_section *d, const rd_object *o, int every)
{
    if (!(k->applies & bit) || strcmp(k->name, "type") == 0)
        return 0;
    if (k->required & bit)
        return 1;
    const char *f = (const char *)base + k->offset;
    if (k->type == RD_KT_NAME || k->type == RD_KT_STRING)
        return *(char *const *)f != NULL;
    if (o && k->section == RD_SEC_TRIANGLE) {
        if (k->name[0] == 'n')
            return o->has_normals;
        if (k->name[0] == 'u')
            return o->has_uv;
    }
    if (every)
        return 1;
    return memcmp(f, (const char *)d + k->offset, (size_t)key_bytes(k)) != 0;
}

#define put rd_strbuf_printf

static void put_num(rd_strbuf *b, double v)
{
    char t[40];
    rd_number_text(v, t, sizeof t);
    put(b, "%s", t);
}

static int bare_word(const char *s)
{
    if (!*s)
        return 0;
    for (const char *p = s; *p; p++) {
        char c = *p;
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
              c == '.' || (unsigned char)c >= 0x80))
            return 0;
    }
    return 1;
}

static int cfg_string(rd_strbuf *b, const char *s, rd_error *err)
{
    if (strpbrk(s, "\"\r\n"))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "'%.60s' cannot be written in cfg (it holds a quote or a line end)", s);
    if (bare_word(s))
        put(b, "%s", s);
    else
        put(b, "\"%s\"", s);
    return RD_OK;
}

static rd_error_code cfg_value(rd_strbuf *b, const rd_key *k, const void *base, rd_error *err)
{
    const char *f = (const char *)base + k->offset;
    switch (k->type) {
    case RD_KT_INT: put(b, "%d", *(const int *)f); break;
    case RD_KT_SEED: put(b, "%llu", (unsigned long long)*(const uint64_t *)f); break;
    case RD_KT_REAL: put_num(b, *(const double *)f); break;
    case RD_KT_VEC2:
        put_num(b, ((const double *)f)[0]);
        put(b, " ");
        put_num(b, ((const double *)f)[1]);
        break;
    case RD_KT_VEC3:
    case RD_KT_REAL_OR_VEC3: {
        const rd_vec3 *v = (const rd_vec3 *)f;
        put_num(b, v->x);
        put(b, " ");
        put_num(b, v->y);
        put(b, " ");
        put_num(b, v->z);
        break;
    }
    case RD_KT_ENUM: put(b, "%s", k->words[*(const int *)f]); break;
    case RD_KT_NAME:
    case RD_KT_STRING: return cfg_string(b, *(char *const *)f, err);
    }
    return RD_OK;
}

static rd_error_code cfg_section(rd_strbuf *b, rd_section_kind sec, const char *name, int subtype, const void *base,
                                 const rd_object *o, rd_error *err)
{
    any_section d;
    if (!defaults_for(sec, subtype, &d))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory writing the scene");
    unsigned bit = (sec == RD_SEC_LIGHT || sec == RD_SEC_MATERIAL) ? 1u << subtype : 1u;
    put(b, "\n[%s", rd_section_kind_name(sec));
    if (name) {
        put(b, " ");
        if (cfg_string(b, name, err))
            return err->code;
    }
    put(b, "]\n");
    if (sec == RD_SEC_LIGHT)
        put(b, "type = %s\n", rd_light_type_words[subtype]);
    if (sec == RD_SEC_MATERIAL)
        put(b, "type = %s\n", rd_material_type_words[subtype]);
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    for (size_t i = 0; i < nk; i++) {
        if (keys[i].section != sec || !wanted(&keys[i], bit, base, &d, o, 0))
            continue;
        put(b, "%s = ", keys[i].name);
        if (cfg_value(b, &keys[i], base, err))
            return err->code;
        put(b, "\n");
    }
    return RD_OK;
}

static rd_section_kind object_section(const rd_object *o)
{
    switch (o->type) {
    case RD_OBJ_SPHERE: return RD_SEC_SPHERE;
    case RD_OBJ_PLANE: return RD_SEC_PLANE;
    case RD_OBJ_TRIANGLE: return RD_SEC_TRIANGLE;
    default: return RD_SEC_MESH;
    }
}

static rd_error_code finish(rd_strbuf *b, char **out, rd_error *err)
{
    *out = rd_strbuf_take(b, NULL);
    return *out ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory writing the scene");
}

rd_error_code rd_scene_write_cfg(const rd_scene *s, char **out, rd_error *err)
{
    rd_strbuf b = {0};
    *out = NULL;
    rd_error_code rc = RD_OK;
    put(&b, "# written by rayd convert\n");
    rc = cfg_section(&b, RD_SEC_RENDER, NULL, 0, &s->render, NULL, err);
    if (!rc)
        rc = cfg_section(&b, RD_SEC_CAMERA, NULL, 0, &s->camera, NULL, err);
    for (size_t i = 0; !rc && i < s->light_count; i++)
        rc = cfg_section(&b, RD_SEC_LIGHT, s->lights[i].name, (int)s->lights[i].type, &s->lights[i], NULL, err);
    for (size_t i = 0; !rc && i < s->material_count; i++)
        rc = cfg_section(&b, RD_SEC_MATERIAL, s->materials[i].name, (int)s->materials[i].type, &s->materials[i], NULL,
                         err);
    for (size_t i = 0; !rc && i < s->object_count; i++)
        rc =
            cfg_section(&b, object_section(&s->objects[i]), s->objects[i].name, 0, &s->objects[i], &s->objects[i], err);
    if (rc) {
        rd_strbuf_free(&b);
        return rc;
    }
    return finish(&b, out, err);
}

/* Numbers go in as raw text that reads back to the same double: cJSON's
 * own printing keeps 15 digits when they compare "close enough". */
static cJSON *raw_number(double v)
{
    char t[40];
    rd_number_text(v, t, sizeof t);
    return cJSON_CreateRaw(t);
}

static cJSON *raw_numbers(const double *v, int n, int *failed)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; i++)
        rd_json_add(a, NULL, raw_number(v[i]), failed);
    return a;
}

/* Sets *failed when a part could not be made (see rd_json_add). */
static cJSON *json_value(const rd_key *k, const void *base, int *failed)
{
    const char *f = (const char *)base + k->offset;
    switch (k->type) {
    case RD_KT_INT: return raw_number(*(const int *)f);
    case RD_KT_SEED: {
        /* Above 2^53 a JSON number would lose digits: write a string. */
        uint64_t v = *(const uint64_t *)f;
        char t[32];
        snprintf(t, sizeof t, "%llu", (unsigned long long)v);
        return v <= (1ULL << 53) ? cJSON_CreateRaw(t) : cJSON_CreateString(t);
    }
    case RD_KT_REAL: return raw_number(*(const double *)f);
    case RD_KT_VEC2: return raw_numbers((const double *)f, 2, failed);
    case RD_KT_VEC3:
    case RD_KT_REAL_OR_VEC3: {
        const rd_vec3 *v = (const rd_vec3 *)f;
        double a[3] = {v->x, v->y, v->z};
        return raw_numbers(a, 3, failed);
    }
    case RD_KT_ENUM: return cJSON_CreateString(k->words[*(const int *)f]);
    case RD_KT_NAME:
    case RD_KT_STRING: return cJSON_CreateString(*(char *const *)f);
    }
    return NULL;
}

static cJSON *json_section(rd_section_kind sec, int subtype, const void *base, const rd_object *o, const char *name,
                           const char *type_word, int every, int *failed)
{
    any_section d;
    if (!defaults_for(sec, subtype, &d))
        return NULL;
    unsigned bit = (sec == RD_SEC_LIGHT || sec == RD_SEC_MATERIAL) ? 1u << subtype : 1u;
    cJSON *obj = cJSON_CreateObject();
    if (!obj)
        return NULL;
    if (name)
        rd_json_add(obj, "name", cJSON_CreateString(name), failed);
    if (type_word)
        rd_json_add(obj, "type", cJSON_CreateString(type_word), failed);
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    for (size_t i = 0; i < nk; i++)
        if (keys[i].section == sec && wanted(&keys[i], bit, base, &d, o, every))
            rd_json_add(obj, keys[i].name, json_value(&keys[i], base, failed), failed);
    return obj;
}

/* A loaded mesh as arrays (rd_scene_write_options.loaded_meshes); sets
 * *failed when a part could not be made. */
static cJSON *mesh_json(const rd_mesh *m, int *failed)
{
    cJSON *o = cJSON_CreateObject();
    cJSON *pos = rd_json_add(o, "positions", cJSON_CreateArray(), failed);
    cJSON *nrm = rd_json_add(o, "normals", cJSON_CreateArray(), failed);
    cJSON *faces = rd_json_add(o, "faces", cJSON_CreateArray(), failed);
    for (size_t i = 0; pos && !*failed && i < m->npositions; i++) {
        double v[3] = {m->positions[i].x, m->positions[i].y, m->positions[i].z};
        rd_json_add(pos, NULL, raw_numbers(v, 3, failed), failed);
    }
    for (size_t i = 0; nrm && !*failed && i < m->nnormals; i++) {
        double v[3] = {m->normals[i].x, m->normals[i].y, m->normals[i].z};
        rd_json_add(nrm, NULL, raw_numbers(v, 3, failed), failed);
    }
    for (size_t i = 0; faces && !*failed && i < m->nfaces; i++) {
        const rd_mesh_face *f = &m->faces[i];
        double v[6] = {f->v[0], f->v[1], f->v[2], f->n[0], f->n[1], f->n[2]};
        rd_json_add(faces, NULL, raw_numbers(v, 6, failed), failed);
    }
    return o;
}

rd_error_code rd_scene_write_json(const rd_scene *s, char **out, rd_error *err)
{
    return rd_scene_write_json_with(s, NULL, out, err);
}

rd_error_code rd_scene_write_json_with(const rd_scene *s, const rd_scene_write_options *opt, char **out, rd_error *err)
{
    int every = opt && opt->every_key, loaded = opt && opt->loaded_meshes;
    *out = NULL;
    cJSON *root = cJSON_CreateObject();
    if (!root)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory writing the scene");
    int f = 0;
    rd_json_add(root, "render", json_section(RD_SEC_RENDER, 0, &s->render, NULL, NULL, NULL, every, &f), &f);
    rd_json_add(root, "camera", json_section(RD_SEC_CAMERA, 0, &s->camera, NULL, NULL, NULL, every, &f), &f);
    cJSON *lights = rd_json_add(root, "lights", cJSON_CreateArray(), &f);
    for (size_t i = 0; lights && i < s->light_count; i++)
        rd_json_add(lights, NULL,
                    json_section(RD_SEC_LIGHT, (int)s->lights[i].type, &s->lights[i], NULL, s->lights[i].name,
                                 rd_light_type_words[s->lights[i].type], every, &f),
                    &f);
    cJSON *mats = rd_json_add(root, "materials", cJSON_CreateObject(), &f);
    for (size_t i = 0; mats && i < s->material_count; i++) {
        const rd_material *m = &s->materials[i];
        rd_json_add(
            mats, m->name ? m->name : "",
            json_section(RD_SEC_MATERIAL, (int)m->type, m, NULL, NULL, rd_material_type_words[m->type], every, &f), &f);
    }
    cJSON *objs = rd_json_add(root, "objects", cJSON_CreateArray(), &f);
    for (size_t i = 0; objs && i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        rd_section_kind sec = object_section(o);
        cJSON *obj =
            rd_json_add(objs, NULL, json_section(sec, 0, o, o, o->name, rd_section_kind_name(sec), every, &f), &f);
        if (obj && loaded && o->type == RD_OBJ_MESH && o->mesh >= 0 && (size_t)o->mesh < s->mesh_count)
            rd_json_add(obj, "loaded", mesh_json(&s->meshes[o->mesh], &f), &f);
    }
    /* An object or mesh dropped for want of memory would be a different
     * scene, not a shorter text: fail instead. */
    if (f) {
        cJSON_Delete(root);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory writing the scene");
    }
    char *copy = rd_json_print(root);
    if (!copy)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory writing the scene");
    *out = copy;
    return RD_OK;
}
