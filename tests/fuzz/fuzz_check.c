#include "fuzz_check.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cfg_parse.h"
#include "json_parse.h"
#include "scene_write.h"

/* Texts in failure reports are cut here: enough to see the broken part of a
 * minimised input, short enough not to bury the sanitizer's own report. */
#define SHOW_MAX 4000

void rd_fuzz_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("fuzz property failed: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    abort();
}

rd_scene_limits rd_fuzz_limits(void)
{
    rd_scene_limits l = rd_scene_limits_default();
    l.max_bytes = RD_FUZZ_MAX_BYTES;
    return l;
}

void rd_fuzz_error_init(rd_error *err)
{
    /* RD_OK and an empty message mean "not filled in": no error path may
     * leave them like that. */
    memset(err, 0, sizeof *err);
    err->code = RD_OK;
}

void rd_fuzz_check_error(rd_error_code rc, const rd_error *err, const char *source)
{
    size_t n = strlen(source);
    if (err->code != rc)
        rd_fuzz_fail("parser returned code %d but the error holds code %d (message '%s')", (int)rc, (int)err->code,
                     err->message);
    if (!err->message[0])
        rd_fuzz_fail("parser returned code %d without a message", (int)rc);
    /* The daemon sends the message as is: the spec wants every error to name
     * its input, and callers rely on the prefix to tell inputs apart. */
    if (strncmp(err->message, source, n) != 0 || err->message[n] != ':')
        rd_fuzz_fail("error message does not start with '%s:': '%s'", source, err->message);
    if (err->line < 0 || err->column < 0)
        rd_fuzz_fail("negative position %d:%d in '%s'", err->line, err->column, err->message);
}

/* ---- scene equality, field for field ---------------------------------- */

/* Each comparison returns 1 when equal; otherwise it describes the first
 * difference in out (an rd_scene path such as "objects[2].radius") and
 * returns 0, so that a failure report says what changed, not only that
 * something did. Doubles compare bit for bit: -0 and 0 are different
 * values to a writer that omits defaults by memcmp (scene_write.c). */
typedef struct {
    char text[300];
} diff;

static int same_d(diff *d, const char *where, const char *field, double a, double b)
{
    if (memcmp(&a, &b, sizeof a) == 0)
        return 1;
    snprintf(d->text, sizeof d->text, "%s.%s: %.17g became %.17g", where, field, a, b);
    return 0;
}

static int same_v(diff *d, const char *where, const char *field, rd_vec3 a, rd_vec3 b)
{
    char f[64];
    snprintf(f, sizeof f, "%s.x", field);
    if (!same_d(d, where, f, a.x, b.x))
        return 0;
    snprintf(f, sizeof f, "%s.y", field);
    if (!same_d(d, where, f, a.y, b.y))
        return 0;
    snprintf(f, sizeof f, "%s.z", field);
    return same_d(d, where, f, a.z, b.z);
}

static int same_i(diff *d, const char *where, const char *field, unsigned long long a, unsigned long long b)
{
    if (a == b)
        return 1;
    snprintf(d->text, sizeof d->text, "%s.%s: %llu became %llu", where, field, a, b);
    return 0;
}

static int same_s(diff *d, const char *where, const char *field, const char *a, const char *b)
{
    if ((!a && !b) || (a && b && strcmp(a, b) == 0))
        return 1;
    snprintf(d->text, sizeof d->text, "%s.%s: '%.60s' became '%.60s'", where, field, a ? a : "(null)",
             b ? b : "(null)");
    return 0;
}

static int same_light(diff *d, const char *w, const rd_light *a, const rd_light *b)
{
    return same_s(d, w, "name", a->name, b->name) && same_i(d, w, "type", (unsigned)a->type, (unsigned)b->type) &&
           same_v(d, w, "color", a->color, b->color) && same_v(d, w, "position", a->position, b->position) &&
           same_v(d, w, "direction", a->direction, b->direction) &&
           same_d(d, w, "angle_deg", a->angle_deg, b->angle_deg) && same_d(d, w, "falloff", a->falloff, b->falloff) &&
           same_v(d, w, "corner", a->corner, b->corner) && same_v(d, w, "edge1", a->edge1, b->edge1) &&
           same_v(d, w, "edge2", a->edge2, b->edge2) &&
           same_i(d, w, "samples", (unsigned)a->samples, (unsigned)b->samples);
}

static int same_material(diff *d, const char *w, const rd_material *a, const rd_material *b)
{
    return same_s(d, w, "name", a->name, b->name) && same_i(d, w, "type", (unsigned)a->type, (unsigned)b->type) &&
           same_v(d, w, "kd", a->kd, b->kd) && same_v(d, w, "ks", a->ks, b->ks) &&
           same_v(d, w, "ambient", a->ambient, b->ambient) && same_d(d, w, "shininess", a->shininess, b->shininess) &&
           same_d(d, w, "roughness", a->roughness, b->roughness) && same_d(d, w, "ior", a->ior, b->ior) &&
           same_s(d, w, "texture", a->texture, b->texture) && same_d(d, w, "uv_scale", a->uv_scale, b->uv_scale);
}

static int same_object(diff *d, const char *w, const rd_object *a, const rd_object *b)
{
    if (!(same_i(d, w, "type", (unsigned)a->type, (unsigned)b->type) && same_s(d, w, "name", a->name, b->name) &&
          same_i(d, w, "material", (unsigned)a->material, (unsigned)b->material) &&
          same_s(d, w, "material_name", a->material_name, b->material_name) &&
          same_v(d, w, "center", a->center, b->center) && same_d(d, w, "radius", a->radius, b->radius) &&
          same_v(d, w, "point", a->point, b->point) && same_v(d, w, "normal", a->normal, b->normal) &&
          same_i(d, w, "has_normals", (unsigned)a->has_normals, (unsigned)b->has_normals) &&
          same_i(d, w, "has_uv", (unsigned)a->has_uv, (unsigned)b->has_uv) && same_s(d, w, "file", a->file, b->file) &&
          same_v(d, w, "translate", a->translate, b->translate) && same_v(d, w, "scale", a->scale, b->scale) &&
          same_v(d, w, "rotate_deg", a->rotate_deg, b->rotate_deg)))
        return 0;
    for (int i = 0; i < 3; i++) {
        char f[16];
        snprintf(f, sizeof f, "v[%d]", i);
        if (!same_v(d, w, f, a->v[i], b->v[i]))
            return 0;
        snprintf(f, sizeof f, "n[%d]", i);
        if (!same_v(d, w, f, a->n[i], b->n[i]))
            return 0;
        snprintf(f, sizeof f, "uv[%d][0]", i);
        if (!same_d(d, w, f, a->uv[i][0], b->uv[i][0]))
            return 0;
        snprintf(f, sizeof f, "uv[%d][1]", i);
        if (!same_d(d, w, f, a->uv[i][1], b->uv[i][1]))
            return 0;
    }
    return 1;
}

static int same_scene(diff *d, const rd_scene *a, const rd_scene *b)
{
    const rd_render_settings *ra = &a->render, *rb = &b->render;
    const rd_camera *ca = &a->camera, *cb = &b->camera;
    if (!(same_i(d, "render", "width", (unsigned)ra->width, (unsigned)rb->width) &&
          same_i(d, "render", "height", (unsigned)ra->height, (unsigned)rb->height) &&
          same_i(d, "render", "samples", (unsigned)ra->samples, (unsigned)rb->samples) &&
          same_i(d, "render", "max_depth", (unsigned)ra->max_depth, (unsigned)rb->max_depth) &&
          same_v(d, "render", "background", ra->background, rb->background) &&
          same_d(d, "render", "gamma", ra->gamma, rb->gamma) && same_i(d, "render", "seed", ra->seed, rb->seed) &&
          same_v(d, "camera", "eye", ca->eye, cb->eye) && same_v(d, "camera", "target", ca->target, cb->target) &&
          same_v(d, "camera", "up", ca->up, cb->up) && same_d(d, "camera", "fov_deg", ca->fov_deg, cb->fov_deg) &&
          same_i(d, "scene", "light_count", a->light_count, b->light_count) &&
          same_i(d, "scene", "material_count", a->material_count, b->material_count) &&
          same_i(d, "scene", "object_count", a->object_count, b->object_count)))
        return 0;
    char w[48];
    for (size_t i = 0; i < a->light_count; i++) {
        snprintf(w, sizeof w, "lights[%zu]", i);
        if (!same_light(d, w, &a->lights[i], &b->lights[i]))
            return 0;
    }
    for (size_t i = 0; i < a->material_count; i++) {
        snprintf(w, sizeof w, "materials[%zu]", i);
        if (!same_material(d, w, &a->materials[i], &b->materials[i]))
            return 0;
    }
    for (size_t i = 0; i < a->object_count; i++) {
        snprintf(w, sizeof w, "objects[%zu]", i);
        if (!same_object(d, w, &a->objects[i], &b->objects[i]))
            return 0;
    }
    return 1;
}

/* ---- round trips ------------------------------------------------------- */

/* scene_write.h: the cfg writer fails when a name cannot be spelled in cfg
 * (a '"' or a line end). Any other refusal is a bug. */
static int unspellable(const char *s) { return s && strpbrk(s, "\"\r\n") != NULL; }

static int has_unspellable(const rd_scene *s)
{
    for (size_t i = 0; i < s->light_count; i++)
        if (unspellable(s->lights[i].name))
            return 1;
    for (size_t i = 0; i < s->material_count; i++)
        if (unspellable(s->materials[i].name) || unspellable(s->materials[i].texture))
            return 1;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (unspellable(o->name) || unspellable(o->material_name) || unspellable(o->file))
            return 1;
    }
    return 0;
}

typedef struct {
    const char *name;
    rd_error_code (*write)(const rd_scene *s, char **out, rd_error *err);
    rd_error_code (*parse)(const char *text, size_t len, const char *source, const rd_scene_limits *lim, rd_scene *s,
                           rd_error *err);
    int may_refuse; /* may refuse unspellable names (cfg) */
} format;

static const format formats[] = {
    {"cfg", rd_scene_write_cfg, rd_cfg_parse, 1},
    {"json", rd_scene_write_json, rd_json_parse, 0},
};

static void roundtrip(const format *f, const rd_scene *s)
{
    rd_error err;
    char *t1 = NULL, *t2 = NULL;
    rd_fuzz_error_init(&err);
    rd_error_code rc = f->write(s, &t1, &err);
    if (rc) {
        if (f->may_refuse && rc == RD_ERR_INVALID && has_unspellable(s))
            return;
        rd_fuzz_fail("the %s writer refused a scene that parsed: %s", f->name, err.message);
    }
    if (!t1)
        rd_fuzz_fail("the %s writer succeeded without text", f->name);

    /* Default limits here, not the fuzz input's 64 KiB: the written text may
     * legitimately be longer than the input (JSON spells out what cfg says
     * with line ends), and every other limit is the same as the first parse. */
    rd_scene s2;
    rd_scene_init(&s2);
    rd_fuzz_error_init(&err);
    rc = f->parse(t1, strlen(t1), "<written>", NULL, &s2, &err);
    if (rc)
        rd_fuzz_fail("%s written from a valid scene does not parse again: %s\n--- written text ---\n%.*s", f->name,
                     err.message, SHOW_MAX, t1);

    rd_fuzz_error_init(&err);
    rc = f->write(&s2, &t2, &err);
    if (rc || !t2)
        rd_fuzz_fail("the %s writer refused a scene it wrote itself: %s\n--- written text ---\n%.*s", f->name,
                     err.message, SHOW_MAX, t1);

    /* Both properties are computed before failing so one report says
     * whether the text, the scene or both changed. */
    int same_text = strcmp(t1, t2) == 0;
    diff d = {""};
    int same = same_scene(&d, s, &s2);
    if (!same_text || !same)
        rd_fuzz_fail("%s round trip: text %s, scene %s%s\n--- first text ---\n%.*s\n--- second text ---\n%.*s", f->name,
                     same_text ? "identical" : "CHANGED", same ? "identical" : "CHANGED: ", same ? "" : d.text,
                     SHOW_MAX, t1, SHOW_MAX, t2);
    free(t1);
    free(t2);
    rd_scene_free(&s2);
}

void rd_fuzz_check_roundtrip(const rd_scene *s)
{
    for (size_t i = 0; i < sizeof formats / sizeof formats[0]; i++)
        roundtrip(&formats[i], s);
}

void rd_fuzz_scene_text(const uint8_t *data, size_t size, rd_fuzz_reader parse)
{
    static const char source[] = "<fuzz>";
    rd_scene_limits lim = rd_fuzz_limits();
    rd_scene s;
    rd_error err;
    rd_scene_init(&s);
    rd_fuzz_error_init(&err);
    rd_error_code rc = parse((const char *)data, size, source, &lim, &s, &err);
    if (rc == RD_OK) {
        /* Also on the daemon's path after every parse; pure arithmetic. */
        rd_fuzz_error_init(&err);
        rc = rd_scene_check_limits(&s, &lim, source, &err);
        if (rc)
            rd_fuzz_check_error(rc, &err, source);
        rd_fuzz_check_roundtrip(&s);
    } else {
        rd_fuzz_check_error(rc, &err, source);
    }
    rd_scene_free(&s);
}
