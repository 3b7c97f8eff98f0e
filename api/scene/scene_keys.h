/* The one table of scene keys of scene-format.md: for every section kind,
 * each key's type, range, default place in the scene model and which
 * subtypes (material or light types) it applies to or requires. */
#ifndef RD_SCENE_KEYS_H
#define RD_SCENE_KEYS_H

#include <stddef.h>

/* Every section kind once, with its cfg header word; the object kinds
 * (sphere to mesh) come last, in this order. */
/* clang-format off */
#define RD_SECTION_KINDS(X) \
    X(RENDER, "render") \
    X(CAMERA, "camera") \
    X(LIGHT, "light") \
    X(MATERIAL, "material") \
    X(SPHERE, "sphere") \
    X(PLANE, "plane") \
    X(TRIANGLE, "triangle") \
    X(MESH, "mesh")
/* clang-format on */

typedef enum {
#define RD_SEC_ENUM(id, word) RD_SEC_##id,
    RD_SECTION_KINDS(RD_SEC_ENUM)
#undef RD_SEC_ENUM
        RD_SEC_COUNT
} rd_section_kind;

typedef enum {
    RD_KT_INT,          /* int within [lo, hi] */
    RD_KT_SEED,         /* uint64_t */
    RD_KT_REAL,         /* finite double within the range */
    RD_KT_VEC2,         /* double[2] */
    RD_KT_VEC3,         /* rd_vec3 (also rgb) */
    RD_KT_REAL_OR_VEC3, /* rd_vec3; one number s means (s, s, s) */
    RD_KT_ENUM,         /* int index into words */
    RD_KT_NAME,         /* char *, owned by the scene */
    RD_KT_STRING        /* char *, owned by the scene */
} rd_key_type;

#define RD_ALL_SUBTYPES (~0u)

typedef struct {
    rd_section_kind section;
    const char *name;
    rd_key_type type;
    double lo, hi;            /* range; ±INFINITY when open-ended */
    int lo_open, hi_open;     /* 1 when the bound itself is excluded */
    unsigned applies;         /* bit t set: applies to subtype t (material/light type) */
    unsigned required;        /* bit t set: required for subtype t */
    size_t offset;            /* into the section's struct in rd_scene */
    const char *const *words; /* RD_KT_ENUM: NULL-terminated */
    int degenerate;           /* out of range means degenerate geometry */
} rd_key;

/* Section kind by name, or -1. */
int rd_section_kind_find(const char *name, size_t len);
const char *rd_section_kind_name(rd_section_kind k);

/* The key of that section kind, or NULL. */
const rd_key *rd_key_find(rd_section_kind sec, const char *name, size_t len);

/* Every key, for iteration (did-you-mean, required checks, writers). */
const rd_key *rd_keys_all(size_t *count);

/* Whether v lies in k's range (bounds open or closed as k says). */
int rd_key_in_range(const rd_key *k, double v);

/* k's range as messages write it after "expected a number": " in [0, 1]",
 * " > 0", or "" when unbounded. */
void rd_key_range_text(const rd_key *k, char *buf, size_t size);

/* The words of the light and material type enums, NULL-terminated. */
extern const char *const rd_light_type_words[];
extern const char *const rd_material_type_words[];

#endif
