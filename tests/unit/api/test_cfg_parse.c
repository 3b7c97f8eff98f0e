/* What valid cfg text turns into (api/scene/cfg_parse.h, scene_load.h): every key
 * of scene-format.md's key table lands in its field of rd_scene with the
 * exact value written, absent keys and sections keep the spec's defaults,
 * and the spellings the spec treats alike (comments, quotes, section order,
 * CRLF, BOM) give the same scene.
 *
 * Numbers are compared with ==: a decimal literal in the test and the same
 * text through strtod round to the same double, so any difference is a real
 * one. */
#include <criterion/criterion.h>
#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cfg_parse.h"
#include "rayd/scene.h"
#include "scene_keys.h"
#include "scene_load.h"

/* Parses from an exact-size copy (no terminator) so that ASan sees any read
 * past len. */
static rd_error_code parse_len(const char *text, size_t len, rd_scene *s, rd_error *err)
{
    char *buf = malloc(len ? len : 1);
    cr_assert_not_null(buf);
    memcpy(buf, text, len);
    rd_scene_init(s);
    memset(err, 0, sizeof *err);
    rd_error_code rc = rd_cfg_parse(buf, len, "t.cfg", NULL, s, err);
    free(buf);
    return rc;
}

static void parse_ok(const char *text, rd_scene *s)
{
    rd_error err;
    rd_error_code rc = parse_len(text, strlen(text), s, &err);
    cr_assert_eq(rc, RD_OK, "parse failed: %s\n--- text ---\n%s", err.message, text);
}

#define expect_num(a, b)                                                                                               \
    cr_expect((double)(a) == (double)(b), "%s = %.17g, expected %.17g", #a, (double)(a), (double)(b))

#define expect_int(a, b)                                                                                               \
    cr_expect_eq((long long)(a), (long long)(b), "%s = %lld, expected %lld", #a, (long long)(a), (long long)(b))

#define expect_vec(v, ex, ey, ez)                                                                                      \
    do {                                                                                                               \
        rd_vec3 v_ = (v);                                                                                              \
        cr_expect(v_.x == (ex) && v_.y == (ey) && v_.z == (ez),                                                        \
                  "%s = (%.17g %.17g %.17g), expected (%.17g %.17g %.17g)", #v, v_.x, v_.y, v_.z, (double)(ex),        \
                  (double)(ey), (double)(ez));                                                                         \
    } while (0)

#define expect_str(a, b)                                                                                               \
    cr_expect((a) != NULL && strcmp((a), (b)) == 0, "%s = %s%s%s, expected '%s'", #a, (a) ? "'" : "",                  \
              (a) ? (a) : "NULL", (a) ? "'" : "", (b))

/* The defaults column of the key table. */
static void expect_default_render_and_camera(const rd_scene *s)
{
    expect_int(s->render.width, 640);
    expect_int(s->render.height, 480);
    expect_int(s->render.samples, 1);
    expect_int(s->render.max_depth, 5);
    expect_vec(s->render.background, 0, 0, 0);
    expect_num(s->render.gamma, 1);
    cr_expect_eq(s->render.seed, 0);
    expect_vec(s->camera.eye, 0, 0, 5);
    expect_vec(s->camera.target, 0, 0, 0);
    expect_vec(s->camera.up, 0, 1, 0);
    expect_num(s->camera.fov_deg, 45);
}

/* A reader that loops forever fails its test instead of hanging the suite. */
TestSuite(cfg_parse, .timeout = 60);

/* ---- defaults ---- */

Test(cfg_parse, empty_text_gives_spec_defaults)
{
    rd_scene s;
    parse_ok("", &s);
    expect_default_render_and_camera(&s);
    expect_int(s.light_count, 0);
    expect_int(s.material_count, 0);
    expect_int(s.object_count, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, comments_and_blank_lines_only)
{
    rd_scene s;
    parse_ok("# a comment\n; another\n\n   \t\n  # indented\n", &s);
    expect_default_render_and_camera(&s);
    expect_int(s.light_count + s.material_count + s.object_count, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, empty_sections_keep_defaults)
{
    rd_scene s;
    parse_ok("[render]\n[camera]\n", &s);
    expect_default_render_and_camera(&s);
    rd_scene_free(&s);
}

Test(cfg_parse, absent_render_keys_keep_defaults)
{
    rd_scene s;
    parse_ok("[render]\nwidth = 320\n[camera]\nfov = 30\n", &s);
    expect_int(s.render.width, 320);
    expect_int(s.render.height, 480);
    expect_int(s.render.samples, 1);
    expect_int(s.render.max_depth, 5);
    expect_num(s.render.gamma, 1);
    expect_num(s.camera.fov_deg, 30);
    expect_vec(s.camera.eye, 0, 0, 5);
    expect_vec(s.camera.up, 0, 1, 0);
    rd_scene_free(&s);
}

/* ---- render and camera ---- */

Test(cfg_parse, render_every_key)
{
    rd_scene s;
    parse_ok("[render]\nwidth = 800\nheight = 600\nsamples = 16\nmax_depth = 7\n"
             "background = 0.1 0.2 0.3\ngamma = 2.2\nseed = 12345\n",
             &s);
    expect_int(s.render.width, 800);
    expect_int(s.render.height, 600);
    expect_int(s.render.samples, 16);
    expect_int(s.render.max_depth, 7);
    expect_vec(s.render.background, 0.1, 0.2, 0.3);
    expect_num(s.render.gamma, 2.2);
    cr_expect_eq(s.render.seed, 12345);
    rd_scene_free(&s);
}

Test(cfg_parse, camera_every_key)
{
    rd_scene s;
    parse_ok("[camera]\neye = 0 2 8\ntarget = 0 1 0\nup = 0 0 1\nfov = 60.5\n", &s);
    expect_vec(s.camera.eye, 0, 2, 8);
    expect_vec(s.camera.target, 0, 1, 0);
    expect_vec(s.camera.up, 0, 0, 1);
    expect_num(s.camera.fov_deg, 60.5);
    rd_scene_free(&s);
}

/* The ends of every closed range are inside it. */
Test(cfg_parse, range_bounds_accepted)
{
    rd_scene s;
    parse_ok("[render]\nwidth = 1\nheight = 16384\nsamples = 65536\nmax_depth = 0\ngamma = 1e-3\n"
             "[camera]\nfov = 179.999\n"
             "[light s]\ntype = spot\nposition = 0 0 0\ndirection = 0 -1 0\nangle = 90\nfalloff = 0\n"
             "[light a]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\nedge2 = 0 0 1\nsamples = 64\n"
             "[light b]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\nedge2 = 0 0 1\nsamples = 1\n"
             "[material c]\ntype = cook_torrance\nroughness = 1\n"
             "[material p]\ntype = phong\nshininess = 0\n",
             &s);
    expect_int(s.render.width, 1);
    expect_int(s.render.height, 16384);
    expect_int(s.render.samples, 65536);
    expect_int(s.render.max_depth, 0);
    expect_num(s.render.gamma, 0.001);
    expect_num(s.camera.fov_deg, 179.999);
    cr_assert_eq(s.light_count, 3);
    expect_num(s.lights[0].angle_deg, 90);
    expect_num(s.lights[0].falloff, 0);
    expect_int(s.lights[1].samples, 64);
    expect_int(s.lights[2].samples, 1);
    cr_assert_eq(s.material_count, 2);
    expect_num(s.materials[0].roughness, 1);
    expect_num(s.materials[1].shininess, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, max_depth_64)
{
    rd_scene s;
    parse_ok("[render]\nmax_depth = 64\nwidth = 16384\n", &s);
    expect_int(s.render.max_depth, 64);
    rd_scene_free(&s);
}

/* ---- numbers ---- */

Test(cfg_parse, number_spellings)
{
    rd_scene s;
    parse_ok("[render]\nbackground = -0 1e-3 .5\nmax_depth = -0\nwidth = +320\ngamma = 5.\n"
             "[camera]\neye = 1E+2 -2.5e1 0.000\n",
             &s);
    expect_vec(s.render.background, 0, 0.001, 0.5);
    expect_int(s.render.max_depth, 0);
    expect_int(s.render.width, 320);
    expect_num(s.render.gamma, 5);
    expect_vec(s.camera.eye, 100, -25, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, seed_whole_range)
{
    rd_scene s;
    parse_ok("[render]\nseed = 18446744073709551615\n", &s);
    cr_expect_eq(s.render.seed, UINT64_MAX, "seed = %llu", (unsigned long long)s.render.seed);
    rd_scene_free(&s);
    parse_ok("[render]\nseed = 0\n", &s);
    cr_expect_eq(s.render.seed, 0);
    rd_scene_free(&s);
    /* Above 2^53 a double would round: the seed must be read as an integer. */
    parse_ok("[render]\nseed = 9007199254740993\n", &s);
    cr_expect_eq(s.render.seed, 9007199254740993ull, "seed = %llu", (unsigned long long)s.render.seed);
    rd_scene_free(&s);
}

/* ---- lights ---- */

Test(cfg_parse, point_light)
{
    rd_scene s;
    parse_ok("[light key]\ntype = point\nposition = 5 8 5\ncolor = 0.5 0.25 1\n", &s);
    cr_assert_eq(s.light_count, 1);
    const rd_light *l = &s.lights[0];
    expect_str(l->name, "key");
    expect_int(l->type, RD_LIGHT_POINT);
    expect_vec(l->position, 5, 8, 5);
    expect_vec(l->color, 0.5, 0.25, 1);
    rd_scene_free(&s);
}

Test(cfg_parse, light_defaults)
{
    rd_scene s;
    parse_ok("[light]\nposition = 1 2 3\n", &s);
    cr_assert_eq(s.light_count, 1);
    cr_expect_null(s.lights[0].name);
    expect_int(s.lights[0].type, RD_LIGHT_POINT);
    expect_vec(s.lights[0].color, 1, 1, 1);
    expect_vec(s.lights[0].position, 1, 2, 3);
    rd_scene_free(&s);
}

Test(cfg_parse, directional_light)
{
    rd_scene s;
    parse_ok("[light sun]\ntype = directional\ndirection = -1 -2 -3\ncolor = 0.9 0.8 0.7\n", &s);
    cr_assert_eq(s.light_count, 1);
    expect_int(s.lights[0].type, RD_LIGHT_DIRECTIONAL);
    expect_vec(s.lights[0].direction, -1, -2, -3);
    expect_vec(s.lights[0].color, 0.9, 0.8, 0.7);
    rd_scene_free(&s);
}

Test(cfg_parse, spot_light)
{
    rd_scene s;
    parse_ok("[light s]\ntype = spot\nposition = 0 4 0\ndirection = 0 -1 0\nangle = 25.5\nfalloff = 3\n"
             "[light t]\ntype = spot\nposition = 1 1 1\ndirection = 1 0 0\n",
             &s);
    cr_assert_eq(s.light_count, 2);
    expect_int(s.lights[0].type, RD_LIGHT_SPOT);
    expect_vec(s.lights[0].position, 0, 4, 0);
    expect_vec(s.lights[0].direction, 0, -1, 0);
    expect_num(s.lights[0].angle_deg, 25.5);
    expect_num(s.lights[0].falloff, 3);
    expect_num(s.lights[1].angle_deg, 30);
    expect_num(s.lights[1].falloff, 0);
    expect_vec(s.lights[1].color, 1, 1, 1);
    rd_scene_free(&s);
}

Test(cfg_parse, area_light)
{
    rd_scene s;
    parse_ok("[light panel]\ntype = area\ncorner = -1 5 -1\nedge1 = 2 0 0\nedge2 = 0 0 2\nsamples = 8\n"
             "color = 2 2 2\n[light q]\ntype = area\ncorner = 0 0 0\nedge1 = 1 0 0\nedge2 = 0 1 0\n",
             &s);
    cr_assert_eq(s.light_count, 2);
    expect_int(s.lights[0].type, RD_LIGHT_AREA);
    expect_vec(s.lights[0].corner, -1, 5, -1);
    expect_vec(s.lights[0].edge1, 2, 0, 0);
    expect_vec(s.lights[0].edge2, 0, 0, 2);
    expect_int(s.lights[0].samples, 8);
    expect_vec(s.lights[0].color, 2, 2, 2);
    expect_int(s.lights[1].samples, 4);
    rd_scene_free(&s);
}

/* Which light keys apply to which type, as the key table of the spec says,
 * and that an applicable key lands in its field. */
static const char *const light_types[] = {"point", "directional", "spot", "area"};
static const struct {
    const char *key, *value;
    const char *applies; /* initials of the light types: p d s a */
} light_keys[] = {
    {"color", "0.5 0.6 0.7", "pdsa"},
    {"position", "1 2 3", "ps"},
    {"direction", "0 -1 0", "ds"},
    {"angle", "45", "s"},
    {"falloff", "2", "s"},
    {"corner", "0 2 0", "a"},
    {"edge1", "1 0 0", "a"},
    {"edge2", "0 0 1", "a"},
    {"samples", "3", "a"},
};

static const char *light_required(int type)
{
    switch (type) {
    case 0: return "position";
    case 1: return "direction";
    case 2: return "position direction";
    default: return "corner edge1 edge2";
    }
}

static void check_light_field(const rd_light *l, const char *key)
{
    if (!strcmp(key, "color"))
        expect_vec(l->color, 0.5, 0.6, 0.7);
    else if (!strcmp(key, "position"))
        expect_vec(l->position, 1, 2, 3);
    else if (!strcmp(key, "direction"))
        expect_vec(l->direction, 0, -1, 0);
    else if (!strcmp(key, "angle"))
        expect_num(l->angle_deg, 45);
    else if (!strcmp(key, "falloff"))
        expect_num(l->falloff, 2);
    else if (!strcmp(key, "corner"))
        expect_vec(l->corner, 0, 2, 0);
    else if (!strcmp(key, "edge1"))
        expect_vec(l->edge1, 1, 0, 0);
    else if (!strcmp(key, "edge2"))
        expect_vec(l->edge2, 0, 0, 1);
    else if (!strcmp(key, "samples"))
        expect_int(l->samples, 3);
    else
        cr_expect_fail("no check for light key %s", key);
}

Test(cfg_parse, light_keys_by_type)
{
    for (int t = 0; t < 4; t++) {
        for (size_t k = 0; k < sizeof light_keys / sizeof light_keys[0]; k++) {
            char text[400];
            int n = snprintf(text, sizeof text, "[light l]\ntype = %s\n%s = %s\n", light_types[t], light_keys[k].key,
                             light_keys[k].value);
            /* The required keys this row does not already give, after the key under test. */
            char req[64];
            snprintf(req, sizeof req, "%s", light_required(t));
            for (char *w = strtok(req, " "); w; w = strtok(NULL, " "))
                if (strcmp(w, light_keys[k].key) != 0)
                    for (size_t j = 0; j < sizeof light_keys / sizeof light_keys[0]; j++)
                        if (!strcmp(light_keys[j].key, w))
                            n += snprintf(text + n, sizeof text - (size_t)n, "%s = %s\n", w, light_keys[j].value);
            int applies = strchr(light_keys[k].applies, light_types[t][0]) != NULL;
            rd_scene s;
            rd_error err;
            rd_error_code rc = parse_len(text, strlen(text), &s, &err);
            if (applies) {
                cr_expect_eq(rc, RD_OK, "%s on a %s light: %s", light_keys[k].key, light_types[t], err.message);
                if (rc == RD_OK && s.light_count == 1) {
                    expect_int(s.lights[0].type, t);
                    check_light_field(&s.lights[0], light_keys[k].key);
                }
            } else {
                char want[200];
                snprintf(want, sizeof want, "t.cfg:3:1: key '%s' does not apply to a %s light in [light l]",
                         light_keys[k].key, light_types[t]);
                cr_expect_eq(rc, RD_ERR_SYNTAX, "%s on a %s light: code %d", light_keys[k].key, light_types[t], rc);
                cr_expect_str_eq(err.message, want);
            }
            rd_scene_free(&s);
        }
    }
}

/* ---- materials ---- */

static const char *const mat_types[] = {"diffuse",
                                        "phong",
                                        "blinn_phong",
                                        "cook_torrance",
                                        "perfect_specular",
                                        "specular_refraction",
                                        "pseudo_normal_color",
                                        "textured_phong"};

/* Rows: the material table of the spec ("every material also takes ambient"). */
static const struct {
    const char *key, *value;
    unsigned applies; /* bit i: mat_types[i] */
} mat_keys[] = {
    {"ambient", "0.1 0.2 0.3", 0xff},
    {"kd", "0.4 0.5 0.6", 1u << 0 | 1u << 1 | 1u << 2 | 1u << 3},
    {"ks", "0.7 0.8 0.9", 1u << 1 | 1u << 2 | 1u << 3 | 1u << 4 | 1u << 5 | 1u << 7},
    {"shininess", "20", 1u << 1 | 1u << 2 | 1u << 7},
    {"roughness", "0.5", 1u << 3},
    {"ior", "1.33", 1u << 5},
    {"texture", "t.png", 1u << 7},
    {"uv_scale", "2", 1u << 7},
};

static void check_material_field(const rd_material *m, const char *key)
{
    if (!strcmp(key, "ambient"))
        expect_vec(m->ambient, 0.1, 0.2, 0.3);
    else if (!strcmp(key, "kd"))
        expect_vec(m->kd, 0.4, 0.5, 0.6);
    else if (!strcmp(key, "ks"))
        expect_vec(m->ks, 0.7, 0.8, 0.9);
    else if (!strcmp(key, "shininess"))
        expect_num(m->shininess, 20);
    else if (!strcmp(key, "roughness"))
        expect_num(m->roughness, 0.5);
    else if (!strcmp(key, "ior"))
        expect_num(m->ior, 1.33);
    else if (!strcmp(key, "texture"))
        expect_str(m->texture, "t.png");
    else if (!strcmp(key, "uv_scale"))
        expect_num(m->uv_scale, 2);
    else
        cr_expect_fail("no check for material key %s", key);
}

Test(cfg_parse, material_keys_by_type)
{
    for (int t = 0; t < RD_MAT_COUNT; t++) {
        for (size_t k = 0; k < sizeof mat_keys / sizeof mat_keys[0]; k++) {
            char text[300];
            snprintf(text, sizeof text, "[material m]\ntype = %s\n%s = %s\n%s", mat_types[t], mat_keys[k].key,
                     mat_keys[k].value,
                     t == RD_MAT_TEXTURED_PHONG && strcmp(mat_keys[k].key, "texture") ? "texture = t.png\n" : "");
            rd_scene s;
            rd_error err;
            rd_error_code rc = parse_len(text, strlen(text), &s, &err);
            if (mat_keys[k].applies & (1u << t)) {
                cr_expect_eq(rc, RD_OK, "%s on %s: %s", mat_keys[k].key, mat_types[t], err.message);
                if (rc == RD_OK && s.material_count == 1) {
                    expect_int(s.materials[0].type, t);
                    expect_str(s.materials[0].name, "m");
                    check_material_field(&s.materials[0], mat_keys[k].key);
                }
            } else {
                char want[200];
                snprintf(want, sizeof want, "t.cfg:3:1: key '%s' does not apply to a %s material in [material m]",
                         mat_keys[k].key, mat_types[t]);
                cr_expect_eq(rc, RD_ERR_SYNTAX, "%s on %s: code %d", mat_keys[k].key, mat_types[t], rc);
                cr_expect_str_eq(err.message, want);
            }
            rd_scene_free(&s);
        }
    }
}

/* The defaults column of the material table, for the keys each type takes. */
Test(cfg_parse, material_defaults_by_type)
{
    rd_scene s;
    parse_ok("[material a]\ntype = diffuse\n"
             "[material b]\ntype = phong\n"
             "[material c]\ntype = blinn_phong\n"
             "[material d]\ntype = cook_torrance\n"
             "[material e]\ntype = perfect_specular\n"
             "[material f]\ntype = specular_refraction\n"
             "[material g]\ntype = pseudo_normal_color\n"
             "[material h]\ntype = textured_phong\ntexture = wood.png\n",
             &s);
    cr_assert_eq(s.material_count, 8);
    const rd_material *m = s.materials;
    for (int i = 0; i < 8; i++) {
        expect_int(m[i].type, i);
        expect_vec(m[i].ambient, 0, 0, 0);
    }
    expect_vec(m[0].kd, 0.8, 0.8, 0.8);

    expect_vec(m[1].kd, 0.8, 0.8, 0.8);
    expect_vec(m[1].ks, 0, 0, 0);
    expect_num(m[1].shininess, 1);

    expect_vec(m[2].kd, 0.8, 0.8, 0.8);
    expect_vec(m[2].ks, 0, 0, 0);
    expect_num(m[2].shininess, 1);

    expect_vec(m[3].kd, 0.8, 0.8, 0.8);
    expect_vec(m[3].ks, 0.04, 0.04, 0.04);
    expect_num(m[3].roughness, 0.3);

    expect_vec(m[4].ks, 1, 1, 1);

    expect_num(m[5].ior, 1.5);
    expect_vec(m[5].ks, 1, 1, 1);

    expect_str(m[7].texture, "wood.png");
    expect_vec(m[7].ks, 0, 0, 0);
    expect_num(m[7].shininess, 1);
    expect_num(m[7].uv_scale, 1);
    rd_scene_free(&s);
}

/* ---- objects ---- */

Test(cfg_parse, sphere)
{
    rd_scene s;
    parse_ok("[material red]\ntype = diffuse\n[sphere]\ncenter = -2.2 1 0.5\nradius = 0.75\nmaterial = red\n", &s);
    cr_assert_eq(s.object_count, 1);
    const rd_object *o = &s.objects[0];
    expect_int(o->type, RD_OBJ_SPHERE);
    expect_vec(o->center, -2.2, 1, 0.5);
    expect_num(o->radius, 0.75);
    expect_str(o->material_name, "red");
    expect_int(o->material, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, plane)
{
    rd_scene s;
    parse_ok("[material floor]\ntype = diffuse\n[plane]\npoint = 0 -1 0\nnormal = 0 2 0\nmaterial = floor\n", &s);
    cr_assert_eq(s.object_count, 1);
    const rd_object *o = &s.objects[0];
    expect_int(o->type, RD_OBJ_PLANE);
    expect_vec(o->point, 0, -1, 0);
    /* Stored as written: normalising is the core's business. */
    expect_vec(o->normal, 0, 2, 0);
    expect_int(o->material, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, triangle_plain)
{
    rd_scene s;
    parse_ok("[material m]\ntype = diffuse\n[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nmaterial = m\n", &s);
    cr_assert_eq(s.object_count, 1);
    const rd_object *o = &s.objects[0];
    expect_int(o->type, RD_OBJ_TRIANGLE);
    expect_vec(o->v[0], 0, 0, 0);
    expect_vec(o->v[1], 1, 0, 0);
    expect_vec(o->v[2], 0, 1, 0);
    expect_int(o->has_normals, 0);
    expect_int(o->has_uv, 0);
    expect_int(o->material, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, triangle_with_normals_and_uvs)
{
    rd_scene s;
    parse_ok("[material m]\ntype = diffuse\n[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\n"
             "n0 = 0 0 1\nn1 = 0.5 0 1\nn2 = 0 0.5 1\nuv0 = 0 0\nuv1 = 1 0.25\nuv2 = 0.125 1\nmaterial = m\n",
             &s);
    cr_assert_eq(s.object_count, 1);
    const rd_object *o = &s.objects[0];
    expect_int(o->has_normals, 1);
    expect_int(o->has_uv, 1);
    expect_vec(o->n[0], 0, 0, 1);
    expect_vec(o->n[1], 0.5, 0, 1);
    expect_vec(o->n[2], 0, 0.5, 1);
    expect_num(o->uv[0][0], 0);
    expect_num(o->uv[0][1], 0);
    expect_num(o->uv[1][0], 1);
    expect_num(o->uv[1][1], 0.25);
    expect_num(o->uv[2][0], 0.125);
    expect_num(o->uv[2][1], 1);
    rd_scene_free(&s);
}

/* Only the keys are read here; the OBJ file itself is the asset loader's. */
Test(cfg_parse, mesh_keys)
{
    rd_scene s;
    parse_ok("[material m]\ntype = diffuse\n"
             "[mesh]\nfile = models/bunny.obj\ntranslate = 1 2 3\nscale = 0.5 2 4\nrotate = 0 90 -45\nmaterial = m\n"
             "[mesh]\nfile = \"my models/cube.obj\"\nscale = 3\nmaterial = m\n"
             "[mesh]\nfile = a.obj\nmaterial = m\n",
             &s);
    cr_assert_eq(s.object_count, 3);
    const rd_object *o = s.objects;
    expect_int(o[0].type, RD_OBJ_MESH);
    expect_str(o[0].file, "models/bunny.obj");
    expect_vec(o[0].translate, 1, 2, 3);
    expect_vec(o[0].scale, 0.5, 2, 4);
    expect_vec(o[0].rotate_deg, 0, 90, -45);
    expect_int(o[0].material, 0);
    expect_str(o[1].file, "my models/cube.obj");
    /* One number scales all three axes. */
    expect_vec(o[1].scale, 3, 3, 3);
    expect_vec(o[2].translate, 0, 0, 0);
    expect_vec(o[2].scale, 1, 1, 1);
    expect_vec(o[2].rotate_deg, 0, 0, 0);
    rd_scene_free(&s);
}

/* ---- spelling ---- */

Test(cfg_parse, comments_after_values_and_headers)
{
    rd_scene s;
    parse_ok("[render] # the image\nwidth = 320 # pixels\nheight = 200; pixels\nsamples = 4;no space\n"
             "[material \"a#b;c\"] ; quotes protect # and ;\ntype = diffuse\n"
             "[sphere]\ncenter = 0 0 0#glued\nradius = 1\nmaterial = \"a#b;c\" # the one above\n",
             &s);
    expect_int(s.render.width, 320);
    expect_int(s.render.height, 200);
    expect_int(s.render.samples, 4);
    cr_assert_eq(s.material_count, 1);
    expect_str(s.materials[0].name, "a#b;c");
    cr_assert_eq(s.object_count, 1);
    expect_vec(s.objects[0].center, 0, 0, 0);
    expect_int(s.objects[0].material, 0);
    rd_scene_free(&s);
}

Test(cfg_parse, spacing_around_keys)
{
    rd_scene s;
    parse_ok("  [ render ]  \nwidth=320\n\theight\t=\t200\t\n   samples =7   \n", &s);
    expect_int(s.render.width, 320);
    expect_int(s.render.height, 200);
    expect_int(s.render.samples, 7);
    rd_scene_free(&s);
}

Test(cfg_parse, quoted_names_with_spaces)
{
    rd_scene s;
    parse_ok("[material \"dark red\"]\ntype = diffuse\nkd = 0.5 0 0\n"
             "[material red]\ntype = diffuse\n"
             "[light \"key light\"]\nposition = 0 5 0\n"
             "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = \"dark red\"\n"
             "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = \"red\"\n",
             &s);
    cr_assert_eq(s.material_count, 2);
    expect_str(s.materials[0].name, "dark red");
    cr_assert_eq(s.light_count, 1);
    expect_str(s.lights[0].name, "key light");
    cr_assert_eq(s.object_count, 2);
    expect_str(s.objects[0].material_name, "dark red");
    expect_int(s.objects[0].material, 0);
    /* A quoted one-word name is the same name as the bare word. */
    expect_int(s.objects[1].material, 1);
    rd_scene_free(&s);
}

Test(cfg_parse, utf8_names)
{
    rd_scene s;
    parse_ok("[material rød]\ntype = diffuse\n[material \"grün glas\"]\ntype = diffuse\n"
             "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = \"grün glas\"\n"
             "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = rød\n",
             &s);
    cr_assert_eq(s.material_count, 2);
    expect_str(s.materials[0].name, "rød");
    expect_str(s.materials[1].name, "grün glas");
    cr_assert_eq(s.object_count, 2);
    expect_int(s.objects[0].material, 1);
    expect_int(s.objects[1].material, 0);
    rd_scene_free(&s);
}

/* Names are unique per kind, so one name may serve a light and a material. */
Test(cfg_parse, same_name_in_different_kinds)
{
    rd_scene s;
    parse_ok("[light red]\nposition = 0 1 0\n[material red]\ntype = diffuse\n"
             "[sphere red]\ncenter = 0 0 0\nradius = 1\nmaterial = red\n",
             &s);
    expect_int(s.light_count, 1);
    expect_int(s.material_count, 1);
    cr_assert_eq(s.object_count, 1);
    expect_int(s.objects[0].material, 0);
    rd_scene_free(&s);
}

/* Objects first, render last, materials between and after their uses: each
 * object still gets the index of the material it names, in definition order. */
Test(cfg_parse, sections_in_any_order)
{
    rd_scene s;
    parse_ok("[sphere]\ncenter = 1 0 0\nradius = 1\nmaterial = blue\n"
             "[material green]\ntype = phong\n"
             "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = green\n"
             "[camera]\neye = 0 0 9\n"
             "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nmaterial = red\n"
             "[material red]\ntype = diffuse\n"
             "[material blue]\ntype = blinn_phong\n"
             "[render]\nwidth = 100\n",
             &s);
    cr_assert_eq(s.material_count, 3);
    expect_str(s.materials[0].name, "green");
    expect_str(s.materials[1].name, "red");
    expect_str(s.materials[2].name, "blue");
    cr_assert_eq(s.object_count, 3);
    expect_int(s.objects[0].type, RD_OBJ_SPHERE);
    expect_int(s.objects[0].material, 2);
    expect_int(s.objects[1].type, RD_OBJ_PLANE);
    expect_int(s.objects[1].material, 0);
    expect_int(s.objects[2].type, RD_OBJ_TRIANGLE);
    expect_int(s.objects[2].material, 1);
    expect_vec(s.camera.eye, 0, 0, 9);
    expect_int(s.render.width, 100);
    rd_scene_free(&s);
}

/* More names and references than the builder's first allocations hold,
 * every object naming a material defined after it. */
Test(cfg_parse, many_forward_references)
{
    enum { N = 150 };
    size_t cap = (size_t)N * 120;
    char *text = malloc(cap);
    cr_assert_not_null(text);
    size_t n = 0;
    for (int i = 0; i < N; i++)
        n += (size_t)snprintf(text + n, cap - n, "[sphere]\ncenter = %d 0 0\nradius = 1\nmaterial = m%d\n", i,
                              N - 1 - i);
    for (int i = 0; i < N; i++)
        n += (size_t)snprintf(text + n, cap - n, "[material m%d]\ntype = diffuse\n", i);
    rd_scene s;
    parse_ok(text, &s);
    cr_assert_eq(s.object_count, N);
    cr_assert_eq(s.material_count, N);
    for (int i = 0; i < N; i++) {
        cr_expect_eq(s.objects[i].material, N - 1 - i, "object %d has material %d", i, s.objects[i].material);
        expect_num(s.objects[i].center.x, i);
    }
    rd_scene_free(&s);
    free(text);
}

/* ---- CRLF and BOM ---- */

static void expect_same_vec(rd_vec3 a, rd_vec3 b, const char *what)
{
    cr_expect(a.x == b.x && a.y == b.y && a.z == b.z, "%s differs", what);
}

static int same_str(const char *a, const char *b) { return (a == NULL && b == NULL) || (a && b && strcmp(a, b) == 0); }

static void expect_same_scene(const rd_scene *a, const rd_scene *b, const char *variant)
{
    cr_expect(memcmp(&a->render, &b->render, sizeof a->render) == 0, "%s: render differs", variant);
    cr_expect(memcmp(&a->camera, &b->camera, sizeof a->camera) == 0, "%s: camera differs", variant);
    cr_assert_eq(a->light_count, b->light_count, "%s: light count", variant);
    for (size_t i = 0; i < a->light_count; i++) {
        const rd_light *x = &a->lights[i], *y = &b->lights[i];
        cr_expect(same_str(x->name, y->name) && x->type == y->type && x->angle_deg == y->angle_deg &&
                      x->falloff == y->falloff && x->samples == y->samples,
                  "%s: light %zu differs", variant, i);
        expect_same_vec(x->color, y->color, "light color");
        expect_same_vec(x->position, y->position, "light position");
        expect_same_vec(x->direction, y->direction, "light direction");
        expect_same_vec(x->corner, y->corner, "light corner");
        expect_same_vec(x->edge1, y->edge1, "light edge1");
        expect_same_vec(x->edge2, y->edge2, "light edge2");
    }
    cr_assert_eq(a->material_count, b->material_count, "%s: material count", variant);
    for (size_t i = 0; i < a->material_count; i++) {
        const rd_material *x = &a->materials[i], *y = &b->materials[i];
        cr_expect(same_str(x->name, y->name) && same_str(x->texture, y->texture) && x->type == y->type &&
                      x->shininess == y->shininess && x->roughness == y->roughness && x->ior == y->ior &&
                      x->uv_scale == y->uv_scale,
                  "%s: material %zu differs", variant, i);
        expect_same_vec(x->kd, y->kd, "kd");
        expect_same_vec(x->ks, y->ks, "ks");
        expect_same_vec(x->ambient, y->ambient, "ambient");
    }
    cr_assert_eq(a->object_count, b->object_count, "%s: object count", variant);
    for (size_t i = 0; i < a->object_count; i++) {
        const rd_object *x = &a->objects[i], *y = &b->objects[i];
        cr_expect(x->type == y->type && x->material == y->material && same_str(x->material_name, y->material_name) &&
                      same_str(x->file, y->file) && x->radius == y->radius && x->has_normals == y->has_normals &&
                      x->has_uv == y->has_uv && memcmp(x->uv, y->uv, sizeof x->uv) == 0,
                  "%s: object %zu differs", variant, i);
        expect_same_vec(x->center, y->center, "center");
        expect_same_vec(x->point, y->point, "point");
        expect_same_vec(x->normal, y->normal, "normal");
        for (int k = 0; k < 3; k++) {
            expect_same_vec(x->v[k], y->v[k], "vertex");
            expect_same_vec(x->n[k], y->n[k], "shading normal");
        }
        expect_same_vec(x->translate, y->translate, "translate");
        expect_same_vec(x->scale, y->scale, "scale");
        expect_same_vec(x->rotate_deg, y->rotate_deg, "rotate");
    }
}

static const char everything[] =
    "# every section kind\n"
    "[render]\nwidth = 320\nheight = 200 ; small\nsamples = 4\nmax_depth = 3\nbackground = 0.1 0.2 0.3\n"
    "gamma = 2.2\nseed = 42\n\n"
    "[camera]\neye = 0 2 8\ntarget = 0 1 0\nup = 0 1 0\nfov = 40\n\n"
    "[light \"key light\"]\ntype = spot\nposition = 0 5 0\ndirection = 0 -1 0\nangle = 20\nfalloff = 1\n"
    "[light sun]\ntype = directional\ndirection = 1 -1 0\ncolor = 0.5 0.5 0.5\n"
    "[light panel]\ntype = area\ncorner = 0 4 0\nedge1 = 1 0 0\nedge2 = 0 0 1\nsamples = 2\n\n"
    "[material \"dark red\"]\ntype = phong\nkd = 0.5 0 0\nks = 0.2 0.2 0.2\nshininess = 30\n"
    "[material wood]\ntype = textured_phong\ntexture = \"textures/wood grain.png\"\nuv_scale = 2\n"
    "[material glass]\ntype = specular_refraction\nior = 1.33\n\n"
    "[sphere]\ncenter = 0 1 0\nradius = 1\nmaterial = \"dark red\"\n"
    "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = wood\n"
    "[triangle]\nv0 = 0 0 0\nv1 = 1 0 0\nv2 = 0 1 0\nn0 = 0 0 1\nn1 = 0 0 1\nn2 = 0 0 1\n"
    "uv0 = 0 0\nuv1 = 1 0\nuv2 = 0 1\nmaterial = glass\n"
    "[mesh]\nfile = bunny.obj\nscale = 2\nmaterial = glass";

Test(cfg_parse, crlf_and_bom_give_the_same_scene)
{
    size_t n = sizeof everything - 1;
    rd_scene ref;
    rd_error err;
    cr_assert_eq(parse_len(everything, n, &ref, &err), RD_OK, "%s", err.message);
    cr_assert_eq(ref.object_count, 4);

    char *crlf = malloc(2 * n + 3);
    cr_assert_not_null(crlf);
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        if (everything[i] == '\n')
            crlf[m++] = '\r';
        crlf[m++] = everything[i];
    }
    char *bom = malloc(n + 3);
    char *both = malloc(m + 3);
    cr_assert(bom && both);
    memcpy(bom, "\xef\xbb\xbf", 3);
    memcpy(bom + 3, everything, n);
    memcpy(both, "\xef\xbb\xbf", 3);
    memcpy(both + 3, crlf, m);

    struct {
        const char *name, *text;
        size_t len;
    } variants[] = {{"CRLF", crlf, m}, {"BOM", bom, n + 3}, {"BOM+CRLF", both, m + 3}};
    for (int v = 0; v < 3; v++) {
        rd_scene s;
        rd_error_code rc = parse_len(variants[v].text, variants[v].len, &s, &err);
        cr_expect_eq(rc, RD_OK, "%s: %s", variants[v].name, err.message);
        if (rc == RD_OK)
            expect_same_scene(&ref, &s, variants[v].name);
        rd_scene_free(&s);
    }
    /* The last line has no line end: its value must not carry a '\r' or
     * lose a byte. */
    expect_str(ref.objects[3].file, "bunny.obj");
    expect_str(ref.materials[1].texture, "textures/wood grain.png");
    rd_scene_free(&ref);
    free(crlf);
    free(bom);
    free(both);
}

/* ---- the spec's own example ---- */

Test(cfg_parse, spec_example)
{
    rd_scene s;
    parse_ok("# phong.cfg: three Phong spheres on a diffuse floor\n[render]\nwidth = 640\nheight = 480\n\n"
             "[camera]\neye = 0 2 8\ntarget = 0 1 0\nfov = 45\n\n"
             "[light key]\ntype = point\nposition = 5 8 5\ncolor = 1 1 1\n\n"
             "[material red]\ntype = phong\nkd = 0.6 0.1 0.1\nks = 0.4 0.4 0.4\nshininess = 50\n"
             "ambient = 0.05 0.05 0.05\n\n"
             "[sphere]\ncenter = 0 1 0\nradius = 1\nmaterial = red\n\n"
             "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = floor\n\n"
             "[material floor]\ntype = diffuse\n",
             &s);
    expect_int(s.render.width, 640);
    expect_int(s.render.height, 480);
    expect_vec(s.camera.eye, 0, 2, 8);
    expect_vec(s.camera.target, 0, 1, 0);
    expect_num(s.camera.fov_deg, 45);
    cr_assert_eq(s.light_count, 1);
    expect_vec(s.lights[0].position, 5, 8, 5);
    cr_assert_eq(s.material_count, 2);
    const rd_material *red = &s.materials[0];
    expect_int(red->type, RD_MAT_PHONG);
    expect_vec(red->kd, 0.6, 0.1, 0.1);
    expect_vec(red->ks, 0.4, 0.4, 0.4);
    expect_num(red->shininess, 50);
    expect_vec(red->ambient, 0.05, 0.05, 0.05);
    cr_assert_eq(s.object_count, 2);
    expect_int(s.objects[0].material, 0);
    expect_int(s.objects[1].material, 1);
    rd_scene_free(&s);
}

/* ---- the key table itself ---- */

/* The keys of scene-format.md, section by section, copied from its table. */
static const struct {
    rd_section_kind sec;
    const char *keys;
} spec_keys[] = {
    {RD_SEC_RENDER, "width height samples max_depth background gamma seed"},
    {RD_SEC_CAMERA, "eye target up fov"},
    {RD_SEC_LIGHT, "type color position direction angle falloff corner edge1 edge2 samples"},
    {RD_SEC_MATERIAL, "type ambient kd ks shininess roughness ior texture uv_scale"},
    {RD_SEC_SPHERE, "center radius material"},
    {RD_SEC_PLANE, "point normal material"},
    {RD_SEC_TRIANGLE, "v0 v1 v2 n0 n1 n2 uv0 uv1 uv2 material"},
    {RD_SEC_MESH, "file translate scale rotate material"},
};

static int in_words(const char *words, const char *w)
{
    size_t n = strlen(w);
    for (const char *p = words; (p = strstr(p, w)) != NULL; p++)
        if ((p == words || p[-1] == ' ') && (p[n] == ' ' || p[n] == 0))
            return 1;
    return 0;
}

/* The tests above cover the spec's keys; this keeps the table from growing
 * keys the spec does not have, or losing one. */
Test(cfg_parse, key_table_matches_spec)
{
    size_t nk;
    const rd_key *keys = rd_keys_all(&nk);
    size_t expected = 0;
    for (size_t i = 0; i < sizeof spec_keys / sizeof spec_keys[0]; i++) {
        const char *w = spec_keys[i].keys;
        for (const char *p = w; *p; p++)
            expected += (p == w || p[-1] == ' ');
        char buf[200];
        snprintf(buf, sizeof buf, "%s", w);
        for (char *k = strtok(buf, " "); k; k = strtok(NULL, " "))
            cr_expect_not_null(rd_key_find(spec_keys[i].sec, k, strlen(k)), "[%s] %s is not in the key table",
                               rd_section_kind_name(spec_keys[i].sec), k);
    }
    for (size_t i = 0; i < nk; i++)
        cr_expect(in_words(spec_keys[keys[i].section].keys, keys[i].name), "[%s] %s is not in the spec",
                  rd_section_kind_name(keys[i].section), keys[i].name);
    cr_expect_eq(nk, expected, "%zu keys in the table, %zu in the spec", nk, expected);
}

/* ---- files ---- */

/* Every example scene parses; tests run from the repository root. */
Test(cfg_parse, example_scenes_load)
{
    DIR *d = opendir("scenes");
    cr_assert_not_null(d, "scenes/ not found: run from the repository root");
    int count = 0, saw_phong = 0, saw_diffuse = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".cfg") != 0)
            continue;
        char path[512];
        snprintf(path, sizeof path, "scenes/%s", e->d_name);
        rd_scene s;
        rd_scene_init(&s);
        rd_error err;
        memset(&err, 0, sizeof err);
        rd_error_code rc = rd_scene_load_file(path, NULL, &s, &err);
        cr_expect_eq(rc, RD_OK, "%s: %s", path, err.message);
        if (rc == RD_OK) {
            cr_expect_gt(s.object_count, 0, "%s has no objects", path);
            for (size_t i = 0; i < s.object_count; i++)
                cr_expect(s.objects[i].material >= 0 && (size_t)s.objects[i].material < s.material_count,
                          "%s: object %zu has material %d", path, i, s.objects[i].material);
        }
        rd_scene_free(&s);
        count++;
        saw_phong |= !strcmp(e->d_name, "phong.cfg");
        saw_diffuse |= !strcmp(e->d_name, "diffuse.cfg");
    }
    closedir(d);
    cr_expect(saw_phong && saw_diffuse, "scenes/phong.cfg and scenes/diffuse.cfg were not found (%d .cfg files)",
              count);
}

/* Values of one example checked, so that "parses" means "parses right". */
Test(cfg_parse, phong_scene_values)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_error err;
    memset(&err, 0, sizeof err);
    cr_assert_eq(rd_scene_load_file("scenes/phong.cfg", NULL, &s, &err), RD_OK, "%s", err.message);
    expect_vec(s.render.background, 0.05, 0.05, 0.1);
    expect_vec(s.camera.eye, 0, 2.5, 9);
    cr_assert_eq(s.light_count, 2);
    expect_str(s.lights[1].name, "fill");
    expect_vec(s.lights[1].position, -8, 6, 4);
    int blue = rd_scene_find_material(&s, "blue");
    cr_assert_geq(blue, 0);
    expect_int(s.materials[blue].type, RD_MAT_PHONG);
    expect_num(s.materials[blue].shininess, 200);
    rd_scene_free(&s);
}

Test(cfg_parse, missing_file_is_io_error)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_scene_load_file("scenes/no-such-scene.cfg", NULL, &s, &err);
    cr_expect_eq(rc, RD_ERR_IO);
    cr_expect_eq(err.code, RD_ERR_IO);
    cr_expect_str_eq(err.message, "scenes/no-such-scene.cfg: cannot open: No such file or directory");
    cr_expect_eq(err.line, 0);
    rd_scene_free(&s);
}
