/* Loading the files a scene refers to: OBJ meshes and PNG textures. Only
 * what the render uses is read: a textured material no object uses costs
 * nothing, not even a file read. */
#ifndef RD_SCENE_ASSETS_H
#define RD_SCENE_ASSETS_H

#include "asset_source.h"
#include "obj_load.h"
#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"

/* Fills s->meshes and s->textures and points the objects and materials at
 * them. Messages start where the scene names the file ("a.cfg:12:8: mesh
 * 'bunny.obj': ..."). Counts mesh triangles against max_objects. */
rd_error_code rd_scene_load_assets(rd_scene *s, const rd_asset_source *src, const rd_scene_limits *lim, rd_warnings *w,
                                   rd_error *err);

/* Decodes PNG bytes into a texture (values / 255 or / 65535). */
rd_error_code rd_texture_from_png(const unsigned char *data, size_t len, size_t max_pixels, rd_texture *t,
                                  rd_error *err);

#endif
