#include "scene_assets.h"

#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "png_read.h"

/* Prefixes err's message with where the scene names the file. */
static rd_error_code located(rd_error *err, rd_error_code rc, const char *where, const char *what, const char *file)
{
    char inner[sizeof err->message];
    snprintf(inner, sizeof inner, "%s", err->message);
    rd_error_set(err, rc, 0, 0, "%s: %s '%.200s': %s", where ? where : "<scene>", what, file, inner);
    return rc;
}

rd_error_code rd_texture_from_png(const unsigned char *data, size_t len, size_t max_pixels, rd_texture *t,
                                  rd_error *err)
{
    rd_png_image img;
    memset(t, 0, sizeof *t);
    rd_error_code rc =
        rd_png_decode(data, len, max_pixels, rd_limit_flag(offsetof(rd_scene_limits, max_texture_pixels)), &img, err);
    if (rc)
        return rc;
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    t->rgb = malloc(n * sizeof(float));
    if (!t->rgb) {
        free(img.rgb);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for the texture");
    }
    for (size_t i = 0; i < n; i++)
        t->rgb[i] = (float)((double)img.rgb[i] / img.maxval);
    t->width = img.width;
    t->height = img.height;
    free(img.rgb);
    return RD_OK;
}

static int material_used(const rd_scene *s, size_t m)
{
    for (size_t i = 0; i < s->object_count; i++)
        if (s->objects[i].material == (int)m)
            return 1;
    return 0;
}

rd_error_code rd_scene_load_assets(rd_scene *s, const rd_asset_source *src, const rd_scene_limits *lim_in,
                                   rd_warnings *w, rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    const char *mesh_flag = rd_limit_flag(offsetof(rd_scene_limits, max_mesh_bytes));
    const char *tex_flag = rd_limit_flag(offsetof(rd_scene_limits, max_texture_bytes));
    const char *obj_flag = rd_limit_flag(offsetof(rd_scene_limits, max_objects));
    size_t nmesh = 0, ntex = 0, prims = 0;
    for (size_t i = 0; i < s->object_count; i++)
        nmesh += s->objects[i].type == RD_OBJ_MESH;
    for (size_t i = 0; i < s->material_count; i++)
        ntex += s->materials[i].type == RD_MAT_TEXTURED_PHONG && material_used(s, i);
    prims = s->object_count - nmesh;
    if (nmesh) {
        s->meshes = calloc(nmesh, sizeof *s->meshes);
        if (!s->meshes)
            return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    if (ntex) {
        s->textures = calloc(ntex, sizeof *s->textures);
        if (!s->textures)
            return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    for (size_t i = 0; i < s->object_count; i++) {
        rd_object *o = &s->objects[i];
        if (o->type != RD_OBJ_MESH || o->mesh >= 0)
            continue;
        unsigned char *data;
        size_t len;
        rd_error_code rc = src->read(src, o->file, lim.max_mesh_bytes, mesh_flag, &data, &len, err);
        if (rc)
            return located(err, rc, o->where, "mesh", o->file);
        rd_mesh *m = &s->meshes[s->mesh_count++];
        size_t room = lim.max_objects > prims ? lim.max_objects - prims : 0;
        rc = rd_obj_parse_threads((const char *)data, len, o->file, room, obj_flag, src->threads, m, w, err);
        free(data);
        if (!rc)
            rc = rd_mesh_transform(m, o->translate, o->scale, o->rotate_deg, err);
        if (rc)
            return located(err, rc, o->where, "mesh", o->file);
        prims += m->nfaces;
        o->mesh = (int)(s->mesh_count - 1);
    }
    for (size_t i = 0; i < s->material_count; i++) {
        rd_material *m = &s->materials[i];
        if (m->type != RD_MAT_TEXTURED_PHONG || m->texture_index >= 0 || !material_used(s, i))
            continue;
        unsigned char *data;
        size_t len;
        rd_error_code rc = src->read(src, m->texture, lim.max_texture_bytes, tex_flag, &data, &len, err);
        if (!rc) {
            rc = rd_texture_from_png(data, len, lim.max_texture_pixels, &s->textures[s->texture_count], err);
            free(data);
        }
        if (rc)
            return located(err, rc, m->where, "texture", m->texture);
        m->texture_index = (int)s->texture_count++;
    }
    return RD_OK;
}
