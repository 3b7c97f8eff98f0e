/* Wavefront OBJ meshes (api/assets/obj_load.h), their transform, their rendering,
 * and the asset folder that supplies them (api/assets/asset_source.h).
 *
 * Error positions are 1-based line and character column of the offending
 * token, as in every other scene error ("cube.obj:3:7: ..."). */
#include <criterion/criterion.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "asset_source.h"
#include "obj_load.h"
#include "rayd/render.h"
#include "rayd/scene.h"
#include "scene_assets.h"
#include "scene_load.h"
#include "support/assert.h"
#include "support/load.h"
#include "support/scene_fixture.h"

/* ---- parsing ----------------------------------------------------------------- */

typedef struct {
    rd_mesh m;
    rd_warnings w;
    rd_error err;
    rd_error_code rc;
} parsed;

static void parse_n(parsed *p, const char *text, size_t len, size_t max_tris)
{
    memset(p, 0, sizeof *p);
    p->rc = rd_obj_parse(text, len, "t.obj", max_tris, "--limit-objects", &p->m, &p->w, &p->err);
}

static void parse(parsed *p, const char *text) { parse_n(p, text, strlen(text), 1000000); }

#define assert_face(m, i, a, b, c)                                                                                     \
    cr_assert((m).faces[i].v[0] == (a) && (m).faces[i].v[1] == (b) && (m).faces[i].v[2] == (c),                        \
              "face %d = (%u, %u, %u), expected (%d, %d, %d)", (int)(i), (m).faces[i].v[0], (m).faces[i].v[1],         \
              (m).faces[i].v[2], (int)(a), (int)(b), (int)(c))

Test(obj, parse_elements_and_the_four_corner_forms)
{
    const char *text = "# a comment line\n"
                       "v 0 0 0\n"
                       "v 1 0 0   # trailing comment\n"
                       "v 0 1 0\n"
                       "v 1.5 -2.25 3e2\n"
                       "vt 0 0\n"
                       "vt 1 0\n"
                       "vt 0.25 0.75 0\n"
                       "vn 0 0 1\n"
                       "vn 0 1 0\n"
                       "vn 1 0 0\n"
                       "f 1 2 3\n"
                       "f 1/1 2/2 3/3\n"
                       "f 1//3 2//2 4//1\n"
                       "f 4/3/2 3/2/1 2/1/3\n"
                       "\n"
                       "   \t\n";
    parsed p;
    parse(&p, text);
    cr_assert_eq(p.rc, RD_OK, "%s", p.err.message);
    cr_assert_eq(p.m.npositions, 4);
    cr_assert_eq(p.m.nuvs, 3);
    cr_assert_eq(p.m.nnormals, 3);
    cr_assert_eq(p.m.nfaces, 4);
    cr_assert(v3_eq(p.m.positions[3], v3(1.5, -2.25, 300)));
    cr_assert(p.m.uvs[2][0] == 0.25 && p.m.uvs[2][1] == 0.75);
    cr_assert(v3_eq(p.m.normals[2], v3(1, 0, 0)));
    /* f 1 2 3: no uv, no normal */
    assert_face(p.m, 0, 0, 1, 2);
    for (int k = 0; k < 3; k++)
        cr_assert(p.m.faces[0].t[k] == -1 && p.m.faces[0].n[k] == -1);
    /* f 1/1 2/2 3/3: uv only */
    assert_face(p.m, 1, 0, 1, 2);
    for (int k = 0; k < 3; k++)
        cr_assert(p.m.faces[1].t[k] == k && p.m.faces[1].n[k] == -1);
    /* f 1//3 2//2 4//1: normal only */
    assert_face(p.m, 2, 0, 1, 3);
    cr_assert(p.m.faces[2].n[0] == 2 && p.m.faces[2].n[1] == 1 && p.m.faces[2].n[2] == 0);
    for (int k = 0; k < 3; k++)
        cr_assert(p.m.faces[2].t[k] == -1);
    /* f 4/3/2 3/2/1 2/1/3: all three */
    assert_face(p.m, 3, 3, 2, 1);
    cr_assert(p.m.faces[3].t[0] == 2 && p.m.faces[3].t[1] == 1 && p.m.faces[3].t[2] == 0);
    cr_assert(p.m.faces[3].n[0] == 1 && p.m.faces[3].n[1] == 0 && p.m.faces[3].n[2] == 2);
    cr_assert_eq(p.w.count, 0, "warnings: %s", p.w.text);
    rd_mesh_free(&p.m);
}

Test(obj, parse_polygons_are_fanned)
{
    parsed p;
    parse(&p, "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nv 9 9 9\nf 1 2 3 4 5\nf 6/1 1/1 2/1 3/1\n"
              "vt 0.5 0.5\n");
    /* The vt comes after the face that uses it: out of range at that line. */
    cr_assert_eq(p.rc, RD_ERR_SYNTAX);
    rd_mesh_free(&p.m);
    parse(&p, "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nv 9 9 9\nvt 0.5 0.5\nf 1 2 3 4 5\nf 6/1 1/1 2/1 3/1\n");
    cr_assert_eq(p.rc, RD_OK, "%s", p.err.message);
    /* Pentagon 1..5 -> (1,2,3) (1,3,4) (1,4,5); quad 6,1,2,3 -> (6,1,2) (6,2,3). */
    cr_assert_eq(p.m.nfaces, 5);
    assert_face(p.m, 0, 0, 1, 2);
    assert_face(p.m, 1, 0, 2, 3);
    assert_face(p.m, 2, 0, 3, 4);
    assert_face(p.m, 3, 5, 0, 1);
    assert_face(p.m, 4, 5, 1, 2);
    for (int f = 3; f < 5; f++)
        for (int k = 0; k < 3; k++)
            cr_assert(p.m.faces[f].t[k] == 0);
    rd_mesh_free(&p.m);
}

Test(obj, parse_negative_indices_count_back)
{
    /* -1 is the last element defined so far, at the face's own line. */
    parsed p;
    parse(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\nf -3/-2/-1 -2/-1/-1 -1/-2/-1\n"
              "v 5 5 5\nf -4 -1 -2\n");
    cr_assert_eq(p.rc, RD_OK, "%s", p.err.message);
    cr_assert_eq(p.m.nfaces, 2);
    assert_face(p.m, 0, 0, 1, 2);
    cr_assert(p.m.faces[0].t[0] == 0 && p.m.faces[0].t[1] == 1 && p.m.faces[0].t[2] == 0);
    cr_assert(p.m.faces[0].n[0] == 0 && p.m.faces[0].n[1] == 0 && p.m.faces[0].n[2] == 0);
    assert_face(p.m, 1, 0, 3, 2);
    rd_mesh_free(&p.m);
}

Test(obj, parse_crlf_and_comments)
{
    const char *lf = "# cube corner\nv 0 0 0\nv 1 0 0 # x\nv 0 1 0\n\n# end\nf 1 2 3 # tri\n";
    const char *crlf = "# cube corner\r\nv 0 0 0\r\nv 1 0 0 # x\r\nv 0 1 0\r\n\r\n# end\r\nf 1 2 3 # tri\r\n";
    parsed a, b;
    parse(&a, lf);
    parse(&b, crlf);
    cr_assert_eq(a.rc, RD_OK, "%s", a.err.message);
    cr_assert_eq(b.rc, RD_OK, "%s", b.err.message);
    cr_assert_eq(b.m.npositions, 3);
    cr_assert_eq(b.m.nfaces, 1);
    cr_assert(memcmp(a.m.positions, b.m.positions, 3 * sizeof(rd_vec3)) == 0);
    assert_face(b.m, 0, 0, 1, 2);
    /* No final newline either. */
    parsed c;
    parse(&c, "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3");
    cr_assert_eq(c.rc, RD_OK, "%s", c.err.message);
    cr_assert_eq(c.m.nfaces, 1);
    rd_mesh_free(&a.m);
    rd_mesh_free(&b.m);
    rd_mesh_free(&c.m);
}

Test(obj, parse_material_statements_warn_and_groups_are_silent)
{
    const char *tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    char buf[256];
    parsed p;
    snprintf(buf, sizeof buf, "mtllib cube.mtl\n%s", tri);
    parse(&p, buf);
    cr_assert_eq(p.rc, RD_OK);
    cr_assert_eq(p.w.count, 1, "mtllib: %d warnings", p.w.count);
    cr_assert(strstr(p.w.text, "t.obj:1"), "the warning names the line: %s", p.w.text);
    cr_assert_eq(p.m.nfaces, 1);
    rd_mesh_free(&p.m);

    snprintf(buf, sizeof buf, "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n");
    parse(&p, buf);
    cr_assert_eq(p.rc, RD_OK);
    cr_assert_eq(p.w.count, 1, "usemtl: %d warnings", p.w.count);
    cr_assert(strstr(p.w.text, "t.obj:4"), "the warning names the line: %s", p.w.text);
    rd_mesh_free(&p.m);

    snprintf(buf, sizeof buf, "mtllib a.mtl\nusemtl red\n%s", tri);
    parse(&p, buf);
    cr_assert_eq(p.rc, RD_OK);
    cr_assert_geq(p.w.count, 1);
    rd_mesh_free(&p.m);

    snprintf(buf, sizeof buf, "o cube\ng side top\ns 1\ns off\n%sg\no x\n", tri);
    parse(&p, buf);
    cr_assert_eq(p.rc, RD_OK, "%s", p.err.message);
    cr_assert_eq(p.w.count, 0, "o/g/s must be silent: %s", p.w.text);
    cr_assert_eq(p.m.nfaces, 1);
    rd_mesh_free(&p.m);
}

/* Parses text and checks the error's code, line and column, and that the
 * message starts with "t.obj:LINE:COL: ". */
static void expect_error(const char *text, size_t len, size_t max_tris, rd_error_code code, int line, int col,
                         const char *needle)
{
    parsed p;
    parse_n(&p, text, len, max_tris);
    cr_assert_eq(p.rc, code, "%.*s: code %d (%s), expected %d", (int)len, text, p.rc, p.err.message, code);
    cr_assert(p.err.line == line && p.err.column == col, "%.*s\n -> at %d:%d (%s), expected %d:%d", (int)len, text,
              p.err.line, p.err.column, p.err.message, line, col);
    char prefix[64];
    snprintf(prefix, sizeof prefix, "t.obj:%d:%d: ", line, col);
    cr_assert(strncmp(p.err.message, prefix, strlen(prefix)) == 0, "message '%s' should start with '%s'", p.err.message,
              prefix);
    if (needle)
        cr_assert(strstr(p.err.message, needle), "message '%s' should mention '%s'", p.err.message, needle);
    rd_mesh_free(&p.m);
}

#define E(text, code, line, col, needle) expect_error(text, strlen(text), 1000000, code, line, col, needle)

Test(obj, parse_bad_numbers)
{
    E("v 0 0 0\nv 1 2x 3\n", RD_ERR_SYNTAX, 2, 5, NULL);
    E("v 0 0 0\nv 1 2 3\nvt 0.5 zz\n", RD_ERR_SYNTAX, 3, 8, NULL);
    E("vn 1 0 0x1\n", RD_ERR_SYNTAX, 1, 8, NULL);
    E("v 1 2\n", RD_ERR_SYNTAX, 1, 1, "3");
}

Test(obj, parse_non_finite_numbers)
{
    E("v 0 0 0\nv 1 nan 3\n", RD_ERR_SYNTAX, 2, 5, "finite");
    E("v 1 2 inf\n", RD_ERR_SYNTAX, 1, 7, "finite");
    E("vn 1e309 0 0\n", RD_ERR_SYNTAX, 1, 4, "finite");
    E("\n\nvt NaN 0\n", RD_ERR_SYNTAX, 3, 4, "finite");
}

Test(obj, parse_too_few_corners)
{
    /* Reported where the corners ran out. */
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", RD_ERR_SYNTAX, 4, 6, "3 corners");
    E("v 0 0 0\nf 1\n", RD_ERR_SYNTAX, 2, 4, NULL);
    E("v 0 0 0\nf\n", RD_ERR_SYNTAX, 2, 2, NULL);
}

Test(obj, parse_index_zero)
{
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 0 2\n", RD_ERR_SYNTAX, 4, 5, NULL);
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/0 2/1 3/1\n", RD_ERR_SYNTAX, 5, 3, NULL);
}

Test(obj, parse_index_out_of_range)
{
    /* Positive past the end, negative before the start, for v, vt, vn. */
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", RD_ERR_SYNTAX, 4, 7, "out of range");
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", RD_ERR_SYNTAX, 4, 3, "out of range");
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", RD_ERR_SYNTAX, 5, 7, "texture");
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//-2 3//1\n", RD_ERR_SYNTAX, 5, 8, "normal");
    /* A later vertex does not make an earlier face valid. */
    E("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", RD_ERR_SYNTAX, 3, 7, NULL);
    /* Huge indices do not wrap around. */
    E("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967297\n", RD_ERR_SYNTAX, 4, 7, NULL);
}

Test(obj, parse_bad_corner_syntax)
{
    const char *pre = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    char buf[256];
    struct {
        const char *f;
        int col;
    } cases[] = {
        {"f a 2 3", 3},        /* not an index */
        {"f 1 2x 3", 6},       /* junk after an index */
        {"f 1 2 3/1/1/1", 13}, /* a fourth component (at it) */
        {"f 1 -/1 3", 5},      /* a sign without digits */
        {"f 1 2 3 ,", 9},      /* junk corner */
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        snprintf(buf, sizeof buf, "%s%s\n", pre, cases[i].f);
        E(buf, RD_ERR_SYNTAX, 6, cases[i].col, NULL);
    }
}

Test(obj, parse_invalid_utf8)
{
    /* The column counts characters: "é" is one. */
    E("v 0 0 0\n# caf\xc3\xa9 \xff\n", RD_ERR_SYNTAX, 2, 8, "UTF-8");
    E("v 0 0 0\nv 1 0 0\nv 0 1 0 \xc3\n", RD_ERR_SYNTAX, 3, 9, "UTF-8");
    /* An overlong encoding of '/' and a surrogate. */
    E("g \xc0\xaf\n", RD_ERR_SYNTAX, 1, 3, "UTF-8");
    E("o a\xed\xa0\x80\n", RD_ERR_SYNTAX, 1, 4, "UTF-8");
}

Test(obj, parse_triangle_limit)
{
    const char *text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 3 4 5\n";
    /* 1 + 3 triangles: a limit of 4 passes, 3 does not, at the pentagon. */
    parsed p;
    parse_n(&p, text, strlen(text), 4);
    cr_assert_eq(p.rc, RD_OK, "%s", p.err.message);
    cr_assert_eq(p.m.nfaces, 4);
    rd_mesh_free(&p.m);
    expect_error(text, strlen(text), 3, RD_ERR_LIMIT, 7, 1, "--limit-objects");
    expect_error(text, strlen(text), 0, RD_ERR_LIMIT, 6, 1, "--limit-objects");
}

/* ---- rd_mesh_transform ------------------------------------------------------ */

static void one_point_mesh(rd_mesh *m, rd_vec3 p, rd_vec3 n)
{
    memset(m, 0, sizeof *m);
    m->positions = malloc(sizeof *m->positions);
    m->normals = malloc(sizeof *m->normals);
    cr_assert(m->positions && m->normals);
    m->positions[0] = p;
    m->npositions = 1;
    m->normals[0] = n;
    m->nnormals = 1;
}

Test(obj, mesh_transform_scale_then_rotate_xyz_then_translate)
{
    /* p = (1,2,3), scale (2,3,4) -> (2,6,12)
     *   rotate x +90° (y -> z):  (x, y cos - z sin, y sin + z cos) = (2, -12, 6)
     *   rotate y +90° (z -> x):  (x cos + z sin, y, -x sin + z cos) = (6, -12, -2)
     *   rotate z +90° (x -> y):  (x cos - y sin, x sin + y cos, z) = (12, 6, -2)
     *   translate (10,20,30)  -> (22, 26, 28).
     * Any other order of the three rotations gives another point, e.g.
     * z, y, x gives (12, 22, 37)... cos 90° = 6e-17 in double, hence 1e-14. */
    rd_mesh m;
    one_point_mesh(&m, v3(1, 2, 3), v3(0, 0, 1));
    rd_error err = {0};
    cr_assert_eq(rd_mesh_transform(&m, v3(10, 20, 30), v3(2, 3, 4), v3(90, 90, 90), &err), RD_OK);
    assert_vec_near(m.positions[0], 22, 26, 28, 1e-14);
    rd_mesh_free(&m);

    /* A single rotation by a non-right angle, for the sign convention:
     * +30° about z takes (1,0,0) to (cos 30°, sin 30°, 0). */
    one_point_mesh(&m, v3(1, 0, 0), v3(1, 0, 0));
    cr_assert_eq(rd_mesh_transform(&m, v3(0, 0, 0), v3(1, 1, 1), v3(0, 0, 30), &err), RD_OK);
    assert_vec_near(m.positions[0], sqrt(3) / 2, 0.5, 0, 1e-15);
    assert_vec_near(m.normals[0], sqrt(3) / 2, 0.5, 0, 1e-15);
    rd_mesh_free(&m);

    /* Identity leaves points bit for bit. */
    one_point_mesh(&m, v3(0.1, -0.7, 1e-300), v3(0.3, 0.4, 0.5));
    cr_assert_eq(rd_mesh_transform(&m, v3(0, 0, 0), v3(1, 1, 1), v3(0, 0, 0), &err), RD_OK);
    cr_assert(v3_eq(m.positions[0], v3(0.1, -0.7, 1e-300)));
    rd_mesh_free(&m);
}

Test(obj, mesh_transform_normals_by_inverse_transpose)
{
    /* The plane x + y = 1 has normal (1,1,0). Scaled by (2,1,1) it becomes
     * x/2 + y = 1, normal ∝ (1/2, 1, 0): the inverse transpose, not the
     * scale itself (which would give (2,1,0)). */
    rd_mesh m;
    one_point_mesh(&m, v3(1, 0, 0), v3(1, 1, 0));
    rd_error err = {0};
    cr_assert_eq(rd_mesh_transform(&m, v3(0, 0, 0), v3(2, 1, 1), v3(0, 0, 0), &err), RD_OK);
    rd_vec3 n = v3_normalize(m.normals[0]), want = v3_normalize(v3(0.5, 1, 0));
    assert_vec_near(n, want.x, want.y, want.z, 1e-15);
    rd_mesh_free(&m);

    /* In general: for any triangle, the transformed normal stays
     * perpendicular to the transformed edges, under non-uniform scale
     * (including a mirroring one) and rotation. */
    rd_vec3 tri[3] = {v3(0.3, -1.2, 0.7), v3(2.1, 0.4, -0.5), v3(-0.8, 1.9, 1.3)};
    rd_vec3 scales[] = {v3(2, 0.5, 3), v3(-1, 4, 0.25), v3(1e-3, 1, 1e3)};
    for (int k = 0; k < 3; k++) {
        rd_mesh t;
        memset(&t, 0, sizeof t);
        t.positions = malloc(3 * sizeof *t.positions);
        t.normals = malloc(sizeof *t.normals);
        cr_assert(t.positions && t.normals);
        memcpy(t.positions, tri, sizeof tri);
        t.npositions = 3;
        t.normals[0] = v3_cross(v3_sub(tri[1], tri[0]), v3_sub(tri[2], tri[0]));
        t.nnormals = 1;
        cr_assert_eq(rd_mesh_transform(&t, v3(5, -6, 7), scales[k], v3(30, -45, 60), &err), RD_OK);
        rd_vec3 e1 = v3_normalize(v3_sub(t.positions[1], t.positions[0]));
        rd_vec3 e2 = v3_normalize(v3_sub(t.positions[2], t.positions[0]));
        rd_vec3 nn = v3_normalize(t.normals[0]);
        cr_assert(fabs(v3_dot(nn, e1)) < 1e-12 && fabs(v3_dot(nn, e2)) < 1e-12, "scale %d: normal·edges = %.3g, %.3g",
                  k, v3_dot(nn, e1), v3_dot(nn, e2));
        /* And it still points to the same side as the corners' winding
         * says, flipped when the scale mirrors (det < 0). */
        rd_vec3 g = v3_normalize(v3_cross(e1, e2));
        double det = scales[k].x * scales[k].y * scales[k].z;
        cr_assert(fabs(v3_dot(nn, g) - (det > 0 ? 1 : -1)) < 1e-12, "scale %d: normal·winding = %.17g", k,
                  v3_dot(nn, g));
        rd_mesh_free(&t);
    }
}

Test(obj, mesh_transform_zero_or_non_finite_scale_is_an_error)
{
    rd_vec3 bad[] = {v3(0, 1, 1), v3(1, 0, 1), v3(1, 1, 0), v3(-0.0, 1, 1), v3(NAN, 1, 1), v3(1, INFINITY, 1)};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        rd_mesh m;
        one_point_mesh(&m, v3(1, 2, 3), v3(0, 0, 1));
        rd_error err = {0};
        rd_error_code rc = rd_mesh_transform(&m, v3(0, 0, 0), bad[i], v3(0, 0, 0), &err);
        cr_assert_eq(rc, RD_ERR_INVALID, "scale (%g, %g, %g): code %d", bad[i].x, bad[i].y, bad[i].z, rc);
        cr_assert(strstr(err.message, "scale"), "%s", err.message);
        rd_mesh_free(&m);
    }
}

/* ---- a cube from OBJ renders like 12 triangles ------------------------------ */

static const char cube_obj[] = "# unit cube, quads, counter-clockwise seen from outside\n"
                               "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n"
                               "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
                               "f 1 4 3 2\n"  /* z = -0.5 */
                               "f 5 6 7 8\n"  /* z = +0.5 */
                               "f 1 2 6 5\n"  /* y = -0.5 */
                               "f 4 8 7 3\n"  /* y = +0.5 */
                               "f 1 5 8 4\n"  /* x = -0.5 */
                               "f 2 3 7 6\n"; /* x = +0.5 */

static const int cube_quads[6][4] = {{1, 4, 3, 2}, {5, 6, 7, 8}, {1, 2, 6, 5},
                                     {4, 8, 7, 3}, {1, 5, 8, 4}, {2, 3, 7, 6}};

static rd_vec3 cube_corner(int i, rd_vec3 scale, rd_vec3 t)
{
    /* OBJ vertex i (1-based) of cube_obj, scaled and moved (no rotation, so
     * the arithmetic is the transform's own: p·s + t). */
    static const double c[8][3] = {{-0.5, -0.5, -0.5}, {0.5, -0.5, -0.5}, {0.5, 0.5, -0.5}, {-0.5, 0.5, -0.5},
                                   {-0.5, -0.5, 0.5},  {0.5, -0.5, 0.5},  {0.5, 0.5, 0.5},  {-0.5, 0.5, 0.5}};
    return v3_add(v3_mul(v3(c[i - 1][0], c[i - 1][1], c[i - 1][2]), scale), t);
}

static void cube_common(rd_scene *s)
{
    fixture_scene(s, 40, 30);
    s->render.background = v3(0.1, 0.1, 0.2);
    s->camera.eye = v3(2, 1.6, 3);
    s->camera.fov_deg = 40;
    int m = add_material(s, RD_MAT_PHONG);
    s->materials[m].name = strdup("m");
    s->materials[m].kd = v3(0.7, 0.4, 0.2);
    s->materials[m].ks = v3(0.3, 0.3, 0.3);
    s->materials[m].shininess = 12;
    s->materials[m].ambient = v3(0.05, 0.05, 0.05);
    int f = add_material(s, RD_MAT_DIFFUSE);
    s->materials[f].name = strdup("floor");
    add_plane(s, v3(0, -0.75, 0), v3(0, 1, 0), f);
    add_point_light(s, v3(3, 4, 2), v3(1, 1, 1));
}

static size_t count_not(const uint8_t *b, size_t n, const uint8_t *other)
{
    size_t d = 0;
    for (size_t i = 0; i < n; i += 3)
        d += memcmp(&b[i], &other[i], 3) != 0;
    return d;
}

Test(obj, render_cube_mesh_equals_twelve_triangles)
{
    rd_vec3 scale = v3(1.5, 1, 0.75), t = v3(0.25, -0.25, 0);
    /* The mesh, as rd_scene_load_assets puts it in a scene. */
    rd_scene a;
    cube_common(&a);
    a.meshes = calloc(1, sizeof *a.meshes);
    cr_assert(a.meshes);
    rd_warnings w = {0};
    rd_error err = {0};
    cr_assert_eq(rd_obj_parse(cube_obj, strlen(cube_obj), "cube.obj", 1000, "--limit-objects", &a.meshes[0], &w, &err),
                 RD_OK, "%s", err.message);
    a.mesh_count = 1;
    cr_assert_eq(a.meshes[0].nfaces, 12);
    cr_assert_eq(rd_mesh_transform(&a.meshes[0], t, scale, v3(0, 0, 0), &err), RD_OK);
    rd_object *o = rd_scene_add_object(&a);
    cr_assert(o);
    o->type = RD_OBJ_MESH;
    o->file = strdup("cube.obj");
    o->material = 0;
    o->mesh = 0;
    o->scale = scale;
    o->translate = t;
    /* The same 12 triangles, fanned by hand from the quads. */
    rd_scene b;
    cube_common(&b);
    for (int q = 0; q < 6; q++)
        for (int k = 1; k <= 2; k++)
            add_triangle(&b, cube_corner(cube_quads[q][0], scale, t), cube_corner(cube_quads[q][k], scale, t),
                         cube_corner(cube_quads[q][k + 1], scale, t), 0);
    /* And the floor alone, to show the cube is in view. */
    rd_scene c;
    cube_common(&c);
    uint8_t *ba = render_bytes(&a, NULL, NULL, NULL);
    uint8_t *bb = render_bytes(&b, NULL, NULL, NULL);
    uint8_t *bc = render_bytes(&c, NULL, NULL, NULL);
    size_t n = 40 * 30 * 3;
    cr_assert_eq(count_not(ba, n, bb), 0, "%zu pixels differ between the OBJ cube and 12 triangles",
                 count_not(ba, n, bb));
    cr_assert_gt(count_not(ba, n, bc), 100, "the cube covers only %zu pixels", count_not(ba, n, bc));
    free(ba);
    free(bb);
    free(bc);
    rd_scene_free(&a);
    rd_scene_free(&b);
    rd_scene_free(&c);
}

/* A private temp folder, removed by the caller. */
static char *make_tmpdir(void)
{
    char *d = strdup("/tmp/rayd-test-obj-XXXXXX");
    cr_assert(d && mkdtemp(d), "mkdtemp: %s", strerror(errno));
    return d;
}

static void write_file(const char *dir, const char *name, const char *text)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    cr_assert(f, "%s: %s", path, strerror(errno));
    cr_assert_eq(fwrite(text, 1, strlen(text), f), strlen(text));
    cr_assert_eq(fclose(f), 0);
}

static void remove_tree(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    cr_assert_eq(system(cmd), 0);
}

static uint8_t *load_and_render(const char *dir, const char *name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    rd_scene s;
    rd_warnings w = {0};
    rd_error err = {0};
    cr_assert_eq(load_scene(path, &s, &w, &err), RD_OK, "%s: %s", path, err.message);
    cr_assert_eq(w.count, 0, "%s", w.text);
    uint8_t *b = render_bytes(&s, NULL, NULL, NULL);
    rd_scene_free(&s);
    return b;
}

static const char cube_cfg_head[] = "[render]\nwidth = 40\nheight = 30\nbackground = 0.1 0.1 0.2\n"
                                    "[camera]\neye = 2 1.6 3\ntarget = 0 0 0\nfov = 40\n"
                                    "[light]\nposition = 3 4 2\n"
                                    "[material m]\ntype = phong\nkd = 0.7 0.4 0.2\nks = 0.3 0.3 0.3\n"
                                    "shininess = 12\nambient = 0.05 0.05 0.05\n"
                                    "[material floor]\ntype = diffuse\n"
                                    "[plane]\npoint = 0 -0.75 0\nnormal = 0 1 0\nmaterial = floor\n";

Test(obj, render_cube_file_through_the_loader_equals_twelve_triangles)
{
    char *dir = make_tmpdir();
    char sub[600];
    snprintf(sub, sizeof sub, "%s/meshes", dir);
    cr_assert_eq(mkdir(sub, 0700), 0);
    write_file(dir, "meshes/cube.obj", cube_obj);
    char text[8192];
    snprintf(text, sizeof text,
             "%s[mesh]\nfile = \"meshes/cube.obj\"\nmaterial = m\nscale = 1.5 1 0.75\ntranslate = 0.25 -0.25 0\n",
             cube_cfg_head);
    write_file(dir, "mesh.cfg", text);
    size_t used = (size_t)snprintf(text, sizeof text, "%s", cube_cfg_head);
    rd_vec3 scale = v3(1.5, 1, 0.75), t = v3(0.25, -0.25, 0);
    for (int q = 0; q < 6; q++)
        for (int k = 1; k <= 2; k++) {
            rd_vec3 v[3] = {cube_corner(cube_quads[q][0], scale, t), cube_corner(cube_quads[q][k], scale, t),
                            cube_corner(cube_quads[q][k + 1], scale, t)};
            /* %.17g round-trips every double exactly. */
            used += (size_t)snprintf(text + used, sizeof text - used,
                                     "[triangle]\nv0 = %.17g %.17g %.17g\nv1 = %.17g %.17g %.17g\n"
                                     "v2 = %.17g %.17g %.17g\nmaterial = m\n",
                                     v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z, v[2].x, v[2].y, v[2].z);
            cr_assert_lt(used, sizeof text);
        }
    write_file(dir, "tris.cfg", text);
    write_file(dir, "floor.cfg", cube_cfg_head);
    uint8_t *a = load_and_render(dir, "mesh.cfg"), *b = load_and_render(dir, "tris.cfg"),
            *c = load_and_render(dir, "floor.cfg");
    size_t n = 40 * 30 * 3;
    cr_assert_eq(count_not(a, n, b), 0, "%zu pixels differ between the OBJ cube and 12 triangles", count_not(a, n, b));
    cr_assert_gt(count_not(a, n, c), 100);
    free(a);
    free(b);
    free(c);
    remove_tree(dir);
    free(dir);
}

/* ---- the asset folder --------------------------------------------------------- */

Test(obj, asset_folder_names_that_could_leave_the_folder_are_refused)
{
    const char *bad[] = {"../x",  "/etc/passwd", "a/../../b", "a\\b", "",       "..", ".",
                         "a/./b", "a//b",        "./a",       "a/..", "x/../y", "\\x"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        cr_assert_not(rd_asset_name_ok(bad[i]), "'%s' accepted", bad[i]);
    cr_assert_not(rd_asset_name_ok(NULL));
    const char *good[] = {"cube.obj", "meshes/cube.obj", "a/b/c.png", "..a", "a..", ".hidden", "a/...b"};
    for (size_t i = 0; i < sizeof good / sizeof *good; i++)
        cr_assert(rd_asset_name_ok(good[i]), "'%s' refused", good[i]);
}

static rd_error_code folder_read(const char *dir, const char *name, rd_error *err, char **text, size_t *len)
{
    rd_asset_source src = rd_asset_folder(dir);
    unsigned char *data = NULL;
    rd_error_code rc = src.read(&src, name, 1 << 20, "--limit-mesh-bytes", &data, len, err);
    *text = (char *)data;
    return rc;
}

Test(obj, asset_folder_symlinks_leading_outside_are_refused)
{
    char *root = make_tmpdir();
    char scene[600], outside[600], link[700];
    snprintf(scene, sizeof scene, "%s/scene", root);
    snprintf(outside, sizeof outside, "%s/outside", root);
    cr_assert_eq(mkdir(scene, 0700), 0);
    cr_assert_eq(mkdir(outside, 0700), 0);
    write_file(root, "secret.obj", "v 0 0 0\n");
    write_file(outside, "x.obj", "v 1 1 1\n");
    write_file(scene, "in.obj", "v 2 2 2\n");
    /* A sibling whose name starts like the scene folder's. */
    char sibling[600];
    snprintf(sibling, sizeof sibling, "%s/scene2", root);
    cr_assert_eq(mkdir(sibling, 0700), 0);
    write_file(sibling, "y.obj", "v 3 3 3\n");

    snprintf(link, sizeof link, "%s/link.obj", scene);
    cr_assert_eq(symlink("../secret.obj", link), 0);
    snprintf(link, sizeof link, "%s/abs.obj", scene);
    cr_assert_eq(symlink("/etc/passwd", link), 0);
    snprintf(link, sizeof link, "%s/dir", scene);
    cr_assert_eq(symlink(outside, link), 0);
    snprintf(link, sizeof link, "%s/sib.obj", scene);
    cr_assert_eq(symlink("../scene2/y.obj", link), 0);
    snprintf(link, sizeof link, "%s/inside.obj", scene);
    cr_assert_eq(symlink("in.obj", link), 0);

    const char *refused[] = {"link.obj", "abs.obj", "dir/x.obj", "sib.obj", "../secret.obj"};
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        rd_error err = {0};
        char *text = NULL;
        size_t len = 0;
        rd_error_code rc = folder_read(scene, refused[i], &err, &text, &len);
        cr_assert_eq(rc, RD_ERR_INVALID, "'%s': code %d (%s)", refused[i], rc, err.message);
        cr_assert_null(text);
    }
    /* Inside the folder, directly or by a link that stays inside: read. */
    const char *ok[] = {"in.obj", "inside.obj"};
    for (size_t i = 0; i < 2; i++) {
        rd_error err = {0};
        char *text = NULL;
        size_t len = 0;
        cr_assert_eq(folder_read(scene, ok[i], &err, &text, &len), RD_OK, "'%s': %s", ok[i], err.message);
        cr_assert(len == 8 && memcmp(text, "v 2 2 2\n", 8) == 0);
        free(text);
    }
    /* A missing file is an I/O error naming the asset as written. */
    rd_error err = {0};
    char *text = NULL;
    size_t len = 0;
    cr_assert_eq(folder_read(scene, "missing.obj", &err, &text, &len), RD_ERR_IO);
    cr_assert(strstr(err.message, "missing.obj"), "%s", err.message);
    remove_tree(root);
    free(root);
}
