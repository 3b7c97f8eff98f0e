#include "scene_keys.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "rayd/scene.h"

#define RD_WORD(id, word) word,
const char *const rd_light_type_words[] = {RD_LIGHT_TYPES(RD_WORD) NULL};
const char *const rd_material_type_words[] = {RD_MATERIAL_TYPES(RD_WORD) NULL};
static const char *const section_words[RD_SEC_COUNT] = {RD_SECTION_KINDS(RD_WORD)};
#undef RD_WORD

#define INF INFINITY
#define ALL RD_ALL_SUBTYPES
#define BIT(t) (1u << (t))
#define LP BIT(RD_LIGHT_POINT)
#define LD BIT(RD_LIGHT_DIRECTIONAL)
#define LS BIT(RD_LIGHT_SPOT)
#define LA BIT(RD_LIGHT_AREA)
#define M(t) BIT(RD_MAT_##t)
#define KD_MATS (M(DIFFUSE) | M(PHONG) | M(BLINN_PHONG) | M(COOK_TORRANCE))
#define KS_MATS                                                                                                        \
    (M(PHONG) | M(BLINN_PHONG) | M(COOK_TORRANCE) | M(PERFECT_SPECULAR) | M(SPECULAR_REFRACTION) | M(TEXTURED_PHONG))
#define SHINY_MATS (M(PHONG) | M(BLINN_PHONG) | M(TEXTURED_PHONG))

#define R(f) offsetof(rd_render_settings, f)
#define C(f) offsetof(rd_camera, f)
#define L(f) offsetof(rd_light, f)
#define MT(f) offsetof(rd_material, f)
#define O(f) offsetof(rd_object, f)

/* section, key, type, lo, hi, lo_open, hi_open, applies, required, offset, words, degenerate */
static const rd_key keys[] = {
    {RD_SEC_RENDER, "width", RD_KT_INT, 1, 16384, 0, 0, ALL, 0, R(width), NULL, 0},
    {RD_SEC_RENDER, "height", RD_KT_INT, 1, 16384, 0, 0, ALL, 0, R(height), NULL, 0},
    {RD_SEC_RENDER, "samples", RD_KT_INT, 1, 65536, 0, 0, ALL, 0, R(samples), NULL, 0},
    {RD_SEC_RENDER, "max_depth", RD_KT_INT, 0, 64, 0, 0, ALL, 0, R(max_depth), NULL, 0},
    {RD_SEC_RENDER, "background", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, R(background), NULL, 0},
    {RD_SEC_RENDER, "gamma", RD_KT_REAL, 0, INF, 1, 0, ALL, 0, R(gamma), NULL, 0},
    {RD_SEC_RENDER, "seed", RD_KT_SEED, 0, INF, 0, 0, ALL, 0, R(seed), NULL, 0},

    {RD_SEC_CAMERA, "eye", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, C(eye), NULL, 0},
    {RD_SEC_CAMERA, "target", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, C(target), NULL, 0},
    {RD_SEC_CAMERA, "up", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, C(up), NULL, 0},
    {RD_SEC_CAMERA, "fov", RD_KT_REAL, 0, 180, 1, 1, ALL, 0, C(fov_deg), NULL, 0},

    {RD_SEC_LIGHT, "type", RD_KT_ENUM, 0, 0, 0, 0, ALL, 0, L(type), rd_light_type_words, 0},
    {RD_SEC_LIGHT, "color", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, L(color), NULL, 0},
    {RD_SEC_LIGHT, "position", RD_KT_VEC3, -INF, INF, 0, 0, LP | LS, LP | LS, L(position), NULL, 0},
    {RD_SEC_LIGHT, "direction", RD_KT_VEC3, -INF, INF, 0, 0, LD | LS, LD | LS, L(direction), NULL, 0},
    {RD_SEC_LIGHT, "angle", RD_KT_REAL, 0, 90, 1, 0, LS, 0, L(angle_deg), NULL, 0},
    {RD_SEC_LIGHT, "falloff", RD_KT_REAL, 0, INF, 0, 0, LS, 0, L(falloff), NULL, 0},
    {RD_SEC_LIGHT, "corner", RD_KT_VEC3, -INF, INF, 0, 0, LA, LA, L(corner), NULL, 0},
    {RD_SEC_LIGHT, "edge1", RD_KT_VEC3, -INF, INF, 0, 0, LA, LA, L(edge1), NULL, 0},
    {RD_SEC_LIGHT, "edge2", RD_KT_VEC3, -INF, INF, 0, 0, LA, LA, L(edge2), NULL, 0},
    {RD_SEC_LIGHT, "samples", RD_KT_INT, 1, 64, 0, 0, LA, 0, L(samples), NULL, 0},

    {RD_SEC_MATERIAL, "type", RD_KT_ENUM, 0, 0, 0, 0, ALL, ALL, MT(type), rd_material_type_words, 0},
    {RD_SEC_MATERIAL, "ambient", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, MT(ambient), NULL, 0},
    {RD_SEC_MATERIAL, "kd", RD_KT_VEC3, -INF, INF, 0, 0, KD_MATS, 0, MT(kd), NULL, 0},
    {RD_SEC_MATERIAL, "ks", RD_KT_VEC3, -INF, INF, 0, 0, KS_MATS, 0, MT(ks), NULL, 0},
    {RD_SEC_MATERIAL, "shininess", RD_KT_REAL, 0, INF, 0, 0, SHINY_MATS, 0, MT(shininess), NULL, 0},
    {RD_SEC_MATERIAL, "roughness", RD_KT_REAL, 0, 1, 1, 0, M(COOK_TORRANCE), 0, MT(roughness), NULL, 0},
    {RD_SEC_MATERIAL, "ior", RD_KT_REAL, 0, INF, 1, 0, M(SPECULAR_REFRACTION), 0, MT(ior), NULL, 0},
    {RD_SEC_MATERIAL, "texture", RD_KT_STRING, 0, 0, 0, 0, M(TEXTURED_PHONG), M(TEXTURED_PHONG), MT(texture), NULL, 0},
    {RD_SEC_MATERIAL, "uv_scale", RD_KT_REAL, 0, INF, 1, 0, M(TEXTURED_PHONG), 0, MT(uv_scale), NULL, 0},

    {RD_SEC_SPHERE, "center", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(center), NULL, 0},
    {RD_SEC_SPHERE, "radius", RD_KT_REAL, 0, INF, 1, 0, ALL, ALL, O(radius), NULL, 1},
    {RD_SEC_SPHERE, "material", RD_KT_NAME, 0, 0, 0, 0, ALL, ALL, O(material_name), NULL, 0},

    {RD_SEC_PLANE, "point", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(point), NULL, 0},
    {RD_SEC_PLANE, "normal", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(normal), NULL, 0},
    {RD_SEC_PLANE, "material", RD_KT_NAME, 0, 0, 0, 0, ALL, ALL, O(material_name), NULL, 0},

    {RD_SEC_TRIANGLE, "v0", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(v[0]), NULL, 0},
    {RD_SEC_TRIANGLE, "v1", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(v[1]), NULL, 0},
    {RD_SEC_TRIANGLE, "v2", RD_KT_VEC3, -INF, INF, 0, 0, ALL, ALL, O(v[2]), NULL, 0},
    {RD_SEC_TRIANGLE, "n0", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, O(n[0]), NULL, 0},
    {RD_SEC_TRIANGLE, "n1", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, O(n[1]), NULL, 0},
    {RD_SEC_TRIANGLE, "n2", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, O(n[2]), NULL, 0},
    {RD_SEC_TRIANGLE, "uv0", RD_KT_VEC2, -INF, INF, 0, 0, ALL, 0, O(uv[0]), NULL, 0},
    {RD_SEC_TRIANGLE, "uv1", RD_KT_VEC2, -INF, INF, 0, 0, ALL, 0, O(uv[1]), NULL, 0},
    {RD_SEC_TRIANGLE, "uv2", RD_KT_VEC2, -INF, INF, 0, 0, ALL, 0, O(uv[2]), NULL, 0},
    {RD_SEC_TRIANGLE, "material", RD_KT_NAME, 0, 0, 0, 0, ALL, ALL, O(material_name), NULL, 0},

    {RD_SEC_MESH, "file", RD_KT_STRING, 0, 0, 0, 0, ALL, ALL, O(file), NULL, 0},
    {RD_SEC_MESH, "translate", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, O(translate), NULL, 0},
    {RD_SEC_MESH, "scale", RD_KT_REAL_OR_VEC3, -INF, INF, 0, 0, ALL, 0, O(scale), NULL, 0},
    {RD_SEC_MESH, "rotate", RD_KT_VEC3, -INF, INF, 0, 0, ALL, 0, O(rotate_deg), NULL, 0},
    {RD_SEC_MESH, "material", RD_KT_NAME, 0, 0, 0, 0, ALL, ALL, O(material_name), NULL, 0},
};

int rd_section_kind_find(const char *name, size_t len)
{
    for (int i = 0; i < RD_SEC_COUNT; i++)
        if (strlen(section_words[i]) == len && memcmp(section_words[i], name, len) == 0)
            return i;
    return -1;
}

const char *rd_section_kind_name(rd_section_kind k) { return (unsigned)k < RD_SEC_COUNT ? section_words[k] : "?"; }

const rd_key *rd_key_find(rd_section_kind sec, const char *name, size_t len)
{
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        if (keys[i].section == sec && strlen(keys[i].name) == len && memcmp(keys[i].name, name, len) == 0)
            return &keys[i];
    return NULL;
}

const rd_key *rd_keys_all(size_t *count)
{
    *count = sizeof keys / sizeof keys[0];
    return keys;
}

void rd_key_range_text(const rd_key *k, char *buf, size_t size)
{
    int has_lo = !isinf(k->lo), has_hi = !isinf(k->hi);
    if (has_lo && has_hi)
        snprintf(buf, size, " in %c%g, %g%c", k->lo_open ? '(' : '[', k->lo, k->hi, k->hi_open ? ')' : ']');
    else if (has_lo)
        snprintf(buf, size, " %s %g", k->lo_open ? ">" : ">=", k->lo);
    else if (has_hi)
        snprintf(buf, size, " %s %g", k->hi_open ? "<" : "<=", k->hi);
    else
        buf[0] = 0;
}

int rd_key_in_range(const rd_key *k, double v)
{
    if (k->lo_open ? !(v > k->lo) : !(v >= k->lo))
        return 0;
    if (k->hi_open ? !(v < k->hi) : !(v <= k->hi))
        return 0;
    return 1;
}
