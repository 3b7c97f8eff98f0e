/* Wavefront OBJ meshes: v, vt, vn and f (polygons fanned into triangles;
 * v, v/t, v//n, v/t/n; negative indices count back from the last vertex). */
#ifndef RD_OBJ_LOAD_H
#define RD_OBJ_LOAD_H

#include <stddef.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "warnings.h"

/* Parses OBJ text into *out (the caller frees it with rd_mesh_free, also on
 * error). Errors read "SOURCE:LINE:COL: ..."; at most max_triangles
 * triangles (RD_ERR_LIMIT naming limit_flag). mtllib and usemtl are ignored
 * with a warning (the scene's material applies); o, g and s silently. */
rd_error_code rd_obj_parse(const char *text, size_t len, const char *source, size_t max_triangles,
                           const char *limit_flag, rd_mesh *out, rd_warnings *w, rd_error *err);

/* The same on up to `threads` threads for a text of a few MiB or more: the
 * same mesh, answer, messages and warnings. */
rd_error_code rd_obj_parse_threads(const char *text, size_t len, const char *source, size_t max_triangles,
                                   const char *limit_flag, int threads, rd_mesh *out, rd_warnings *w, rd_error *err);

/* Moves a mesh into the world: scale, then rotate about x, then y, then z
 * (degrees), then translate. Normals follow the inverse transpose.
 * RD_ERR_INVALID when a scale component is zero or not finite. */
rd_error_code rd_mesh_transform(rd_mesh *m, rd_vec3 translate, rd_vec3 scale, rd_vec3 rotate_deg, rd_error *err);

#endif
