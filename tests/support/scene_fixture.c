/* Scenes built in code (scene_fixture.h). */
#include "scene_fixture.h"

#include <criterion/criterion.h>
#include <math.h>
#include <stdlib.h>

void fixture_scene(rd_scene *s, int width, int height)
{
    rd_scene_init(s);
    s->render.width = width;
    s->render.height = height;
    s->render.samples = 1;
    s->render.gamma = 1;
    s->render.max_depth = 5;
    s->render.background = v3(0, 0, 0);
    s->camera.eye = v3(0, 0, 5);
    s->camera.target = v3(0, 0, 0);
    s->camera.up = v3(0, 1, 0);
    s->camera.fov_deg = 45;
}

int add_material(rd_scene *s, rd_material_type type)
{
    rd_material *m = rd_scene_add_material(s);
    cr_assert(m, "out of memory adding a material");
    rd_material_defaults(m, type);
    return (int)s->material_count - 1;
}

int add_diffuse(rd_scene *s, rd_rgb kd, rd_rgb ambient)
{
    int m = add_material(s, RD_MAT_DIFFUSE);
    s->materials[m].kd = kd;
    s->materials[m].ambient = ambient;
    return m;
}

static rd_object *add_object(rd_scene *s, rd_object_type type, int material)
{
    rd_object *o = rd_scene_add_object(s);
    cr_assert(o, "out of memory adding an object");
    o->type = type;
    o->material = material;
    return o;
}

rd_object *add_sphere(rd_scene *s, rd_vec3 centre, double radius, int material)
{
    rd_object *o = add_object(s, RD_OBJ_SPHERE, material);
    o->center = centre;
    o->radius = radius;
    return o;
}

rd_object *add_plane(rd_scene *s, rd_vec3 point, rd_vec3 normal, int material)
{
    rd_object *o = add_object(s, RD_OBJ_PLANE, material);
    o->point = point;
    o->normal = normal;
    return o;
}

rd_object *add_triangle(rd_scene *s, rd_vec3 v0, rd_vec3 v1, rd_vec3 v2, int material)
{
    rd_object *o = add_object(s, RD_OBJ_TRIANGLE, material);
    o->v[0] = v0;
    o->v[1] = v1;
    o->v[2] = v2;
    return o;
}

rd_light *add_light(rd_scene *s, rd_light_type type, rd_rgb color)
{
    rd_light *l = rd_scene_add_light(s);
    cr_assert(l, "out of memory adding a light");
    l->type = type;
    l->color = color;
    return l;
}

rd_light *add_point_light(rd_scene *s, rd_vec3 position, rd_rgb color)
{
    rd_light *l = add_light(s, RD_LIGHT_POINT, color);
    l->position = position;
    return l;
}

rd_light *add_directional_light(rd_scene *s, rd_vec3 direction, rd_rgb color)
{
    rd_light *l = add_light(s, RD_LIGHT_DIRECTIONAL, color);
    l->direction = direction;
    return l;
}

rd_light *add_area_light(rd_scene *s, rd_vec3 corner, rd_vec3 edge1, rd_vec3 edge2, int samples, rd_rgb color)
{
    rd_light *l = add_light(s, RD_LIGHT_AREA, color);
    l->corner = corner;
    l->edge1 = edge1;
    l->edge2 = edge2;
    l->samples = samples;
    return l;
}

void soft_shadow_scene(rd_scene *s, int samples)
{
    fixture_scene(s, 32, 24);
    s->render.samples = samples;
    s->render.seed = 3;
    s->camera.eye = v3(0, 3, 6);
    s->camera.target = v3(0, 0, 0);
    int floor_m = add_material(s, RD_MAT_DIFFUSE);
    int ball = add_material(s, RD_MAT_PHONG);
    s->materials[ball].ks = v3(0.3, 0.3, 0.3);
    s->materials[ball].shininess = 30;
    add_plane(s, v3(0, 0, 0), v3(0, 1, 0), floor_m);
    add_sphere(s, v3(0, 1, 0), 1, ball);
    add_area_light(s, v3(-2, 4, -2), v3(4, 0, 0), v3(0, 0, 4), 2, v3(1, 1, 1));
}

void render_ok(const rd_scene *s, const rd_render_options *opt, rd_image *img, rd_render_stats *st)
{
    rd_render_options two = {.threads = 2, .tile = 8};
    rd_render_stats local;
    if (!st)
        st = &local;
    rd_error err = {0};
    rd_error_code rc = rd_render(s, opt ? opt : &two, img, st, &err);
    cr_assert_eq(rc, RD_OK, "rd_render failed (%d): %s", (int)rc, err.message);
    cr_assert(img->rgb && img->width == s->render.width && img->height == s->render.height,
              "rd_render gave a %dx%d image for a %dx%d scene", img->width, img->height, s->render.width,
              s->render.height);
    cr_assert_eq(st->nonfinite, 0, "%llu non-finite samples", (unsigned long long)st->nonfinite);
    cr_assert(isfinite(st->error_estimate) && st->error_estimate >= 0, "error estimate %g", st->error_estimate);
}

uint8_t *image_bytes(const rd_image *img, double gamma)
{
    uint8_t *b = malloc((size_t)img->width * (size_t)img->height * 3);
    cr_assert(b, "out of memory for the bytes of a %dx%d image", img->width, img->height);
    rd_image_to_rgb8(img, gamma, b);
    return b;
}

uint8_t *render_bytes(const rd_scene *s, const rd_render_options *opt, rd_image *img, rd_render_stats *st)
{
    rd_image local;
    render_ok(s, opt, img ? img : &local, st);
    uint8_t *b = image_bytes(img ? img : &local, s->render.gamma);
    if (!img)
        rd_image_free(&local);
    return b;
}
