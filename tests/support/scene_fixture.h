/* Scenes built in code for the Criterion suites, and rendering them.
 *
 * fixture_scene gives the frame most tests start from; the add_* helpers
 * append one element with its defaults and the given values, and fail the
 * test when out of memory. Materials are referred to by index, as objects
 * do (a pointer into s->materials is valid only until the next add). */
#ifndef RD_TEST_SCENE_FIXTURE_H
#define RD_TEST_SCENE_FIXTURE_H

#include <stdint.h>

#include "rayd/render.h"
#include "rayd/scene.h"

/* rd_scene_init, then width x height with what rd_scene_init sets spelled
 * out: 1 sample, gamma 1, max_depth 5, black background, the eye at
 * (0, 0, 5) looking at the origin, up +y, fov 45°. */
void fixture_scene(rd_scene *s, int width, int height);

/* A material of the type with its defaults (rd_material_defaults); its index. */
int add_material(rd_scene *s, rd_material_type type);

/* A diffuse material of the given kd and ambient; its index. */
int add_diffuse(rd_scene *s, rd_rgb kd, rd_rgb ambient);

rd_object *add_sphere(rd_scene *s, rd_vec3 centre, double radius, int material);
rd_object *add_plane(rd_scene *s, rd_vec3 point, rd_vec3 normal, int material);
rd_object *add_triangle(rd_scene *s, rd_vec3 v0, rd_vec3 v1, rd_vec3 v2, int material);

/* A light of the type and colour; the caller sets where it is. */
rd_light *add_light(rd_scene *s, rd_light_type type, rd_rgb color);
rd_light *add_point_light(rd_scene *s, rd_vec3 position, rd_rgb color);
rd_light *add_directional_light(rd_scene *s, rd_vec3 direction, rd_rgb color);
rd_light *add_area_light(rd_scene *s, rd_vec3 corner, rd_vec3 edge1, rd_vec3 edge2, int samples, rd_rgb color);

/* A 32x24 Phong ball on a diffuse floor under a 4x4 area light sampled at
 * 2x2 points: strong per-sample noise, for the error estimate and for
 * renders that take a while. Seed 3. */
void soft_shadow_scene(rd_scene *s, int samples);

/* Renders s and fails the test unless rd_render succeeds with an image of
 * the scene's size, no non-finite sample (stats.nonfinite == 0) and a
 * finite, non-negative error estimate. opt NULL: two threads, 8-pixel
 * tiles (the bytes do not depend on either). *img receives the linear
 * image (free it with rd_image_free); st may be NULL. */
void render_ok(const rd_scene *s, const rd_render_options *opt, rd_image *img, rd_render_stats *st);

/* The same, as bytes with the scene's gamma (rd_image_to_rgb8): a malloc'ed
 * width·height·3 buffer. img may be NULL, and the image is then freed. */
uint8_t *render_bytes(const rd_scene *s, const rd_render_options *opt, rd_image *img, rd_render_stats *st);

/* The bytes of a whole image with gamma (malloc'ed). */
uint8_t *image_bytes(const rd_image *img, double gamma);

#endif
