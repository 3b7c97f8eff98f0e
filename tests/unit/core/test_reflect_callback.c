/* A material's reflected light from a callback (rd_material.reflect): the
 * code grader's way of putting a student's function into the renderer. */
#include <criterion/criterion.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/render.h"
#include "rayd/shading.h"
#include "support/scene_fixture.h"

/* Three Phong balls of rising shininess and a diffuse floor, two lights. */
static void balls(rd_scene *s)
{
    fixture_scene(s, 48, 32);
    int floor = add_diffuse(s, v3(0.5, 0.5, 0.5), v3(0.02, 0.02, 0.02));
    add_plane(s, v3(0, -1, 0), v3(0, 1, 0), floor);
    const double shininess[] = {2, 40, 4000};
    for (int i = 0; i < 3; i++) {
        int m = add_material(s, RD_MAT_PHONG);
        s->materials[m].kd = v3(0.6, 0.2 + 0.2 * i, 0.1);
        s->materials[m].ks = v3(0.4, 0.4, 0.4);
        s->materials[m].shininess = shininess[i];
        s->materials[m].ambient = v3(0.05, 0.01, 0.01);
        add_sphere(s, v3(-1.6 + 1.6 * i, 0, 0), 0.7, m);
    }
    add_point_light(s, v3(4, 6, 6), v3(0.8, 0.8, 0.8));
    add_point_light(s, v3(-6, 3, 4), v3(0.3, 0.3, 0.35));
}

static int calls;

static rd_rgb same_as_rayd(void *user, const rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L, rd_vec3 V)
{
    (void)user, (void)p, (void)t;
    calls++;
    return rd_reflected_light(m, n, L, V);
}

static rd_rgb poison(void *user, const rd_material *m, rd_vec3 n, rd_vec3 p, double t, rd_vec3 L, rd_vec3 V)
{
    (void)m, (void)n, (void)p, (void)t, (void)L, (void)V;
    const double *k = user;
    calls++;
    return v3(k[0], k[1], k[2]);
}

static void set_callback(rd_scene *s, rd_reflect_fn fn, void *user)
{
    for (size_t i = 0; i < s->material_count; i++)
        if (s->materials[i].type == RD_MAT_PHONG) {
            s->materials[i].reflect = fn;
            s->materials[i].reflect_user = user;
        }
}

Test(reflect_callback, reproducing_rayd_gives_the_same_bytes)
{
    rd_scene s;
    balls(&s);
    uint8_t *plain = render_bytes(&s, NULL, NULL, NULL);
    set_callback(&s, same_as_rayd, NULL);
    calls = 0;
    rd_render_options one = {0};
    one.threads = 1; /* calls counts on one thread */
    uint8_t *via = render_bytes(&s, &one, NULL, NULL);
    cr_assert_gt(calls, 100, "the callback is called at the balls' shading points (%d calls)", calls);
    cr_assert_eq(memcmp(plain, via, 48 * 32 * 3), 0, "the callback's render differs from rayd's");
    free(plain);
    free(via);
    rd_scene_free(&s);
}

/* NaN, infinities and negative light from a student's function count as
 * black; the floor and the ambient term stay as they are. */
Test(reflect_callback, nan_infinite_and_negative_values_are_black)
{
    static const double poisons[][3] = {{NAN, NAN, NAN}, {INFINITY, -INFINITY, NAN}, {-1, -5, -1e300}};
    rd_scene s;
    balls(&s);
    for (size_t i = 0; i < s.material_count; i++)
        if (s.materials[i].type == RD_MAT_PHONG)
            s.materials[i].ks = s.materials[i].kd = v3(0, 0, 0);
    uint8_t *black = render_bytes(&s, NULL, NULL, NULL); /* the balls: ambient only */
    for (size_t k = 0; k < sizeof poisons / sizeof *poisons; k++) {
        set_callback(&s, poison, (void *)poisons[k]);
        rd_image img;
        rd_render_stats st;
        render_ok(&s, NULL, &img, &st); /* no non-finite sample */
        uint8_t *b = image_bytes(&img, s.render.gamma);
        cr_assert_eq(memcmp(b, black, 48 * 32 * 3), 0, "poison %zu is not black", k);
        free(b);
        rd_image_free(&img);
    }
    free(black);
    rd_scene_free(&s);
}

/* A huge finite value saturates rather than overflowing to infinity. */
Test(reflect_callback, huge_values_saturate)
{
    static const double huge[3] = {1e308, 1e308, 1e308};
    rd_scene s;
    balls(&s);
    set_callback(&s, poison, (void *)huge);
    rd_image img;
    render_ok(&s, NULL, &img, NULL);
    uint8_t *b = image_bytes(&img, s.render.gamma);
    size_t white = 0;
    for (size_t i = 0; i < 48 * 32; i++)
        white += b[3 * i] == 255 && b[3 * i + 1] == 255 && b[3 * i + 2] == 255;
    cr_assert_gt(white, 48, "the lit parts of the balls are white (%zu pixels)", white);
    free(b);
    rd_image_free(&img);
    rd_scene_free(&s);
}
