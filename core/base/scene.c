#include "rayd/scene.h"

#include "rayd/memory.h"

#include <stdlib.h>
#include <string.h>

void rd_scene_init(rd_scene *s)
{
    memset(s, 0, sizeof *s);
    s->render.width = 640;
    s->render.height = 480;
    s->render.samples = 1;
    s->render.max_depth = 5;
    s->render.background = v3(0, 0, 0);
    s->render.gamma = 1.0;
    s->render.seed = 0;
    s->camera.eye = v3(0, 0, 5);
    s->camera.target = v3(0, 0, 0);
    s->camera.up = v3(0, 1, 0);
    s->camera.fov_deg = 45.0;
}

void rd_scene_free(rd_scene *s)
{
    for (size_t i = 0; i < s->light_count; i++)
        free(s->lights[i].name);
    for (size_t i = 0; i < s->material_count; i++) {
        free(s->materials[i].name);
        free(s->materials[i].texture);
        free(s->materials[i].where);
    }
    for (size_t i = 0; i < s->object_count; i++) {
        free(s->objects[i].material_name);
        free(s->objects[i].file);
        free(s->objects[i].name);
        free(s->objects[i].where);
    }
    for (size_t i = 0; i < s->texture_count; i++)
        free(s->textures[i].rgb);
    for (size_t i = 0; i < s->mesh_count; i++)
        rd_mesh_free(&s->meshes[i]);
    free(s->textures);
    free(s->meshes);
    free(s->lights);
    free(s->materials);
    free(s->objects);
    memset(s, 0, sizeof *s);
}

/* Grows *arr (of *cap elements of size sz) to hold one more; NULL on failure. */
static void *grow(void **arr, size_t *count, size_t *cap, size_t sz)
{
    if (!rd_grow_array(arr, cap, *count + 1, sz, 8))
        return NULL;
    char *slot = (char *)*arr + (*count)++ * sz;
    memset(slot, 0, sz);
    return slot;
}

rd_light *rd_scene_add_light(rd_scene *s)
{
    rd_light *l = grow((void **)&s->lights, &s->light_count, &s->light_cap, sizeof *l);
    if (l) {
        l->type = RD_LIGHT_POINT;
        l->color = v3(1, 1, 1);
        l->angle_deg = 30;
        l->falloff = 0;
        l->samples = 4;
    }
    return l;
}

void rd_material_defaults(rd_material *m, rd_material_type type)
{
    m->type = type;
    m->kd = v3(0.8, 0.8, 0.8);
    m->ambient = v3(0, 0, 0);
    m->shininess = 1;
    m->roughness = 0.3;
    m->ior = 1.5;
    m->uv_scale = 1;
    m->texture_index = -1;
    switch (type) {
    case RD_MAT_COOK_TORRANCE: m->ks = v3(0.04, 0.04, 0.04); break;
    case RD_MAT_PERFECT_SPECULAR:
    case RD_MAT_SPECULAR_REFRACTION: m->ks = v3(1, 1, 1); break;
    default: m->ks = v3(0, 0, 0); break;
    }
}

rd_material *rd_scene_add_material(rd_scene *s)
{
    rd_material *m = grow((void **)&s->materials, &s->material_count, &s->material_cap, sizeof *m);
    if (m)
        rd_material_defaults(m, RD_MAT_DIFFUSE);
    return m;
}

rd_object *rd_scene_add_object(rd_scene *s)
{
    rd_object *o = grow((void **)&s->objects, &s->object_count, &s->object_cap, sizeof *o);
    if (o) {
        o->material = -1;
        o->mesh = -1;
        o->scale = v3(1, 1, 1);
    }
    return o;
}

void rd_mesh_free(rd_mesh *m)
{
    free(m->positions);
    free(m->normals);
    free(m->uvs);
    free(m->faces);
    memset(m, 0, sizeof *m);
}

int rd_scene_find_material(const rd_scene *s, const char *name)
{
    for (size_t i = 0; i < s->material_count; i++)
        if (s->materials[i].name && strcmp(s->materials[i].name, name) == 0)
            return (int)i;
    return -1;
}

size_t rd_scene_bytes(const rd_scene *s)
{
    size_t n = s->light_cap * sizeof *s->lights + s->material_cap * sizeof *s->materials +
               s->object_cap * sizeof *s->objects + s->texture_count * sizeof *s->textures +
               s->mesh_count * sizeof *s->meshes;
    for (size_t i = 0; i < s->texture_count; i++)
        n += (size_t)s->textures[i].width * (size_t)s->textures[i].height * 3 * sizeof(float);
    for (size_t i = 0; i < s->mesh_count; i++) {
        const rd_mesh *m = &s->meshes[i];
        n += m->npositions * sizeof *m->positions + m->nnormals * sizeof *m->normals + m->nuvs * sizeof *m->uvs +
             m->nfaces * sizeof *m->faces;
    }
    return n;
}
