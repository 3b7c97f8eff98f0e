/* libFuzzer target for the OBJ reader (api/assets/obj_load.c). Meshes come with
 * uploaded scenes' folders and with the scenes folder of a daemon, so any
 * bytes must give a mesh or an error, never a crash, hang or leak.
 *
 * Each input is read twice: by rd_obj_parse itself, where the properties
 * below are checked, and as the file of a [mesh] through the loader a scene
 * uses (rd_scene_load_assets: triangle budget, scale, rotation and
 * translation). Rendering is left out: it would cost a thousand times more
 * per input than reading does. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cfg_parse.h"
#include "fuzz_check.h"
#include "obj_load.h"
#include "scene_assets.h"

#define SOURCE "<fuzz>"

/* Small enough that the fuzzer meets the limit, large enough not to meet it
 * on every input. */
#define MAX_TRIANGLES 4096

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int finite3(rd_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

/* What rd_scene_load_assets and the renderer take for granted. Numbers
 * are finite as read; a transform may still overflow them to infinity
 * (1e308 scaled by 2), which the renderer survives, so only the parser's
 * output is held to that. */
static void check_mesh(const rd_mesh *m, size_t max_triangles, int finite)
{
    if (m->nfaces > max_triangles)
        rd_fuzz_fail("%zu triangles, over the limit of %zu", m->nfaces, max_triangles);
    for (size_t i = 0; i < m->npositions && finite; i++)
        if (!finite3(m->positions[i]))
            rd_fuzz_fail("vertex %zu is not finite", i);
    for (size_t i = 0; i < m->nnormals && finite; i++)
        if (!finite3(m->normals[i]))
            rd_fuzz_fail("normal %zu is not finite", i);
    for (size_t i = 0; i < m->nuvs && finite; i++)
        if (!isfinite(m->uvs[i][0]) || !isfinite(m->uvs[i][1]))
            rd_fuzz_fail("texture coordinate %zu is not finite", i);
    for (size_t f = 0; f < m->nfaces; f++)
        for (int c = 0; c < 3; c++) {
            const rd_mesh_face *fc = &m->faces[f];
            if (fc->v[c] >= m->npositions)
                rd_fuzz_fail("face %zu corner %d: vertex %u of %zu", f, c, (unsigned)fc->v[c], m->npositions);
            if (fc->n[c] < -1 || (fc->n[c] >= 0 && (size_t)fc->n[c] >= m->nnormals))
                rd_fuzz_fail("face %zu corner %d: normal %d of %zu", f, c, (int)fc->n[c], m->nnormals);
            if (fc->t[c] < -1 || (fc->t[c] >= 0 && (size_t)fc->t[c] >= m->nuvs))
                rd_fuzz_fail("face %zu corner %d: texture coordinate %d of %zu", f, c, (int)fc->t[c], m->nuvs);
        }
}

/* The loader reads the mesh through its asset source: this one hands out
 * the fuzz input under any name. */
typedef struct {
    const uint8_t *data;
    size_t size;
} input;

static rd_error_code read_input(const rd_asset_source *src, const char *name, size_t max_bytes, const char *flag,
                                unsigned char **out, size_t *len, rd_error *err)
{
    const input *in = src->user;
    (void)name;
    if (in->size > max_bytes)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "over %zu bytes (%s)", max_bytes, flag);
    /* Exactly size bytes (malloc(0) may give NULL; 1 byte is never read). */
    *out = malloc(in->size ? in->size : 1);
    if (!*out)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (in->size)
        memcpy(*out, in->data, in->size);
    *len = in->size;
    return RD_OK;
}

/* A mesh moved by every transform the loader applies, beside a sphere so
 * that the triangle budget is shared. */
static const char scene_text[] = "[render]\nwidth = 8\nheight = 8\n"
                                 "[camera]\neye = 0 0 5\ntarget = 0 0 0\n"
                                 "[light]\ntype = point\nposition = 0 5 5\n"
                                 "[material m]\ntype = diffuse\n"
                                 "[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n"
                                 "[mesh]\nfile = fuzz.obj\nmaterial = m\n"
                                 "scale = 2 0.5 -1\nrotate = 10 -20 30\ntranslate = 1 2 3\n";

static void through_the_loader(const uint8_t *data, size_t size)
{
    rd_scene_limits lim = rd_fuzz_limits();
    lim.max_objects = MAX_TRIANGLES + 1;
    rd_scene s;
    rd_error err;
    rd_scene_init(&s);
    rd_fuzz_error_init(&err);
    if (rd_cfg_parse(scene_text, sizeof scene_text - 1, "fuzz.cfg", &lim, &s, &err) != RD_OK)
        rd_fuzz_fail("the fixed scene does not parse: %s", err.message);
    input in = {data, size};
    rd_asset_source src = {read_input, NULL, &in, 1};
    rd_warnings w = {0, ""};
    rd_error_code rc = rd_scene_load_assets(&s, &src, &lim, &w, &err);
    if (rc == RD_OK) {
        if (s.mesh_count != 1)
            rd_fuzz_fail("loaded %zu meshes, expected 1", s.mesh_count);
        check_mesh(&s.meshes[0], MAX_TRIANGLES, 0);
    } else if (err.code != rc || !err.message[0]) {
        rd_fuzz_fail("loader returned code %d with error code %d, message '%s'", (int)rc, (int)err.code, err.message);
    }
    rd_scene_free(&s);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* An exact-size copy that is not NUL-terminated: AddressSanitizer
     * catches a reader that runs past the end. */
    char *text = malloc(size ? size : 1);
    if (!text)
        return 0;
    if (size)
        memcpy(text, data, size);
    rd_mesh m;
    rd_warnings w = {0, ""};
    rd_error err;
    rd_fuzz_error_init(&err);
    rd_error_code rc = rd_obj_parse(text, size, SOURCE, MAX_TRIANGLES, "--limit-objects", &m, &w, &err);
    if (rc == RD_OK)
        check_mesh(&m, MAX_TRIANGLES, 1);
    else
        rd_fuzz_check_error(rc, &err, SOURCE);
    if (w.count < 0 || strlen(w.text) >= sizeof w.text)
        rd_fuzz_fail("warnings out of shape: count %d", w.count);
    /* The header says free it also on error. */
    rd_mesh_free(&m);
    free(text);
    through_the_loader(data, size);
    return 0;
}
