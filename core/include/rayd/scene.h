/* The one scene model that the cfg and JSON readers fill and the core renders.
 *
 * Ownership: an rd_scene owns every array and string it points to.
 * rd_scene_init gives an empty scene with the format's defaults;
 * rd_scene_free releases everything the rd_scene_add_* functions allocated.
 * The core never modifies a scene it is given. */
#ifndef RD_SCENE_H
#define RD_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/vec3.h"

typedef struct {
    int width, height;
    int samples;   /* per pixel; 1 = the pixel centre */
    int max_depth; /* mirror/refraction bounces */
    rd_rgb background;
    double gamma;
    uint64_t seed;
} rd_render_settings;

typedef struct {
    rd_vec3 eye, target, up;
    double fov_deg; /* vertical */
} rd_camera;

/* up and the view direction must be at least this far from parallel (the
 * sine of the angle between them, about 2e-8 degrees): the scene readers
 * refuse a camera the tracer could not orient. */
#define RD_MIN_UP_SINE 1e-9

/* Every light type once, with the word the scene formats use for it. */
/* clang-format off */
#define RD_LIGHT_TYPES(X) \
    X(POINT, "point") \
    X(DIRECTIONAL, "directional") \
    X(SPOT, "spot") \
    X(AREA, "area")
/* clang-format on */

typedef enum {
#define RD_LIGHT_ENUM(id, word) RD_LIGHT_##id,
    RD_LIGHT_TYPES(RD_LIGHT_ENUM)
#undef RD_LIGHT_ENUM
        RD_LIGHT_COUNT
} rd_light_type;

typedef struct {
    char *name; /* may be NULL (anonymous) */
    rd_light_type type;
    rd_rgb color;
    rd_vec3 position;             /* point, spot */
    rd_vec3 direction;            /* directional, spot: the way the light travels */
    double angle_deg, falloff;    /* spot */
    rd_vec3 corner, edge1, edge2; /* area */
    int samples;                  /* area: samples² points */
} rd_light;

/* Every material type once (shading.md), with its word in the formats. */
/* clang-format off */
#define RD_MATERIAL_TYPES(X) \
    X(DIFFUSE, "diffuse") \
    X(PHONG, "phong") \
    X(BLINN_PHONG, "blinn_phong") \
    X(COOK_TORRANCE, "cook_torrance") \
    X(PERFECT_SPECULAR, "perfect_specular") \
    X(SPECULAR_REFRACTION, "specular_refraction") \
    X(PSEUDO_NORMAL_COLOR, "pseudo_normal_color") \
    X(TEXTURED_PHONG, "textured_phong")
/* clang-format on */

typedef enum {
#define RD_MAT_ENUM(id, word) RD_MAT_##id,
    RD_MATERIAL_TYPES(RD_MAT_ENUM)
#undef RD_MAT_ENUM
        RD_MAT_COUNT
} rd_material_type;

struct rd_material;

/* A material's reflected light computed elsewhere: the code grader's
 * student function (docs/grading.md, "Grading code"). n is the unit
 * shading normal at p, t the ray's distance; L and V as in
 * rd_reflected_light (shading.h). No scene reader sets one. */
typedef rd_rgb (*rd_reflect_fn)(void *user, const struct rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L,
                                rd_vec3 V);

typedef struct rd_material {
    char *name;
    rd_material_type type;
    rd_rgb kd, ks, ambient;
    double shininess;
    double roughness; /* cook_torrance */
    double ior;       /* specular_refraction */
    char *texture;    /* textured_phong: path as written in the scene */
    double uv_scale;
    int texture_index; /* into rd_scene.textures once loaded; -1 before */
    char *where;       /* where `texture` was written, for messages ("a.cfg:7:11") */
    /* NULL but in the code grader: replaces the type's reflected light;
     * its results are sanitized (a NaN, an infinity or a negative
     * channel counts as 0), so a scene stays finite whatever it returns. */
    rd_reflect_fn reflect;
    void *reflect_user;
} rd_material;

typedef enum { RD_OBJ_SPHERE, RD_OBJ_PLANE, RD_OBJ_TRIANGLE, RD_OBJ_MESH } rd_object_type;

typedef struct {
    rd_object_type type;
    char *name;   /* may be NULL */
    int material; /* index into materials; -1 until resolved */
    char *material_name;
    /* sphere */
    rd_vec3 center;
    double radius;
    /* plane */
    rd_vec3 point, normal;
    /* triangle */
    rd_vec3 v[3];
    rd_vec3 n[3];    /* shading normals, when has_normals */
    double uv[3][2]; /* when has_uv */
    int has_normals, has_uv;
    /* mesh: an OBJ file, loaded into rd_scene.meshes before rendering */
    char *file;
    rd_vec3 translate, scale, rotate_deg;
    int mesh;    /* into rd_scene.meshes once loaded; -1 before */
    char *where; /* where `file` was written, for messages */
} rd_object;

/* A decoded texture: RGB values in [0, 1] as stored in the PNG (8-bit
 * values / 255, 16-bit / 65535, no gamma conversion), top row first. */
typedef struct {
    int width, height;
    float *rgb;
} rd_texture;

/* One polygon of a mesh, fanned into a triangle: indices into the mesh's
 * arrays; n and t are -1 where the face gave none. */
typedef struct {
    uint32_t v[3];
    int32_t n[3], t[3];
} rd_mesh_face;

/* A triangle mesh from an OBJ file, already moved into world coordinates. */
typedef struct {
    rd_vec3 *positions;
    size_t npositions;
    rd_vec3 *normals;
    size_t nnormals;
    double (*uvs)[2];
    size_t nuvs;
    rd_mesh_face *faces;
    size_t nfaces;
} rd_mesh;

typedef struct {
    rd_render_settings render;
    rd_camera camera;
    rd_light *lights;
    size_t light_count, light_cap;
    rd_material *materials;
    size_t material_count, material_cap;
    rd_object *objects;
    size_t object_count, object_cap;
    rd_texture *textures; /* filled by the asset loader */
    size_t texture_count;
    rd_mesh *meshes; /* filled by the asset loader */
    size_t mesh_count;
} rd_scene;

/* An empty scene with every default of scene-format.md. */
void rd_scene_init(rd_scene *s);
void rd_scene_free(rd_scene *s);

/* Append a default-initialised element and return it, or NULL when out of
 * memory. The pointer is valid until the next add of the same kind. */
rd_light *rd_scene_add_light(rd_scene *s);
rd_material *rd_scene_add_material(rd_scene *s);
rd_object *rd_scene_add_object(rd_scene *s);

/* Default values for a material of the given type (kd 0.8, ks by type ...). */
void rd_material_defaults(rd_material *m, rd_material_type type);

/* Releases a mesh's arrays (not the struct itself). */
void rd_mesh_free(rd_mesh *m);

/* Bytes the scene holds: its arrays, decoded textures and loaded meshes
 * (names and strings aside). For memory budgets. */
size_t rd_scene_bytes(const rd_scene *s);

/* Index of the material with that name, or -1. */
int rd_scene_find_material(const rd_scene *s, const char *name);

#endif
