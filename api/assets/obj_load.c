#include "obj_load.h"

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_value.h"
#include "utf8.h"
#include "value_parse.h"

typedef struct {
    const char *source;
    int line;
    const char *ls;
    rd_mesh *m;
    size_t capv, capn, capt, capf;
    rd_error *err;
} obj;

static rd_error_code fail(obj *o, const char *at, rd_error_code code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static rd_error_code fail(obj *o, const char *at, rd_error_code code, const char *fmt, ...)
{
    char msg[300];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return rd_error_set(o->err, code, o->line, rd_utf8_column(o->ls, at), "%s:%d:%d: %s", o->source, o->line,
                        rd_utf8_column(o->ls, at), msg);
}

static int grow(void **arr, size_t *cap, size_t count, size_t sz)
{
    if (count < *cap)
        return 1;
    size_t nc = *cap ? *cap * 2 : 256;
    void *p = realloc(*arr, nc * sz);
    if (!p)
        return 0;
    *arr = p;
    *cap = nc;
    return 1;
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/* Reads up to max numbers from p; returns how many, or -1 on a bad one
 * (bad points at it; nonfinite says why). */
static int numbers(const char **pp, const char *le, double *out, int max, const char **bad, int *nonfinite)
{
    const char *p = *pp;
    int n = 0;
    for (;;) {
        while (p < le && is_space(*p))
            p++;
        if (p >= le || *p == '#')
            break;
        const char *t = p;
        while (p < le && !is_space(*p) && *p != '#')
            p++;
        rd_token tok = {t, (size_t)(p - t), 0, 0, 0, 0};
        double v;
        int r = rd_parse_real(&tok, &v);
        if (r) {
            *bad = t;
            *nonfinite = r == 2;
            return -1;
        }
        if (n < max)
            out[n] = v;
        n++;
    }
    *pp = p;
    return n;
}

/* One index of a face corner: 1-based, or negative from the end; 0 = absent. */
static rd_error_code resolve(obj *o, const char *at, long raw, size_t count, const char *what, int32_t *out)
{
    long long idx = raw > 0 ? raw - 1 : (long long)count + raw;
    if (raw == 0 || idx < 0 || (size_t)idx >= count)
        return fail(o, at, RD_ERR_SYNTAX, "f: %s index %ld out of range (%zu defined so far)", what, raw, count);
    *out = (int32_t)idx;
    return RD_OK;
}

static rd_error_code face(obj *o, const char *p, const char *le, size_t max_tris, const char *flag)
{
    enum { MAXC = 256 };
    int32_t cv[MAXC], cn[MAXC], ct[MAXC];
    int n = 0;
    rd_mesh *m = o->m;
    while (1) {
        while (p < le && is_space(*p))
            p++;
        if (p >= le || *p == '#')
            break;
        if (n == MAXC)
            return fail(o, p, RD_ERR_LIMIT, "f: more than %d corners", MAXC);
        const char *at = p;
        long raw[3] = {0, 0, 0};
        int have[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++) {
            if (p < le && (*p == '-' || (*p >= '0' && *p <= '9'))) {
                /* Parsed by hand: the text need not end in a NUL. */
                int neg = *p == '-';
                const char *d = p + neg;
                long v = 0;
                while (d < le && *d >= '0' && *d <= '9' && v < 100000000000L)
                    v = v * 10 + (*d++ - '0');
                if (d == p + neg || (d < le && *d >= '0' && *d <= '9'))
                    return fail(o, p, RD_ERR_SYNTAX, "f: expected an index");
                raw[k] = neg ? -v : v;
                have[k] = 1;
                p = d;
            } else if (k == 0) {
                {
                    const char *e = at;
                    while (e < le && !is_space(*e) && e - at < 40)
                        e++;
                    return fail(o, at, RD_ERR_SYNTAX, "f: expected a vertex index, got '%.*s'", (int)(e - at), at);
                }
            }
            if (p < le && *p == '/')
                p++;
            else
                break;
        }
        if (p < le && !is_space(*p) && *p != '#')
            return fail(o, p, RD_ERR_SYNTAX, "f: unexpected '%c' in a face corner", *p);
        rd_error_code rc = resolve(o, at, raw[0], m->npositions, "vertex", &cv[n]);
        if (rc)
            return rc;
        ct[n] = cn[n] = -1;
        if (have[1] && (rc = resolve(o, at, raw[1], m->nuvs, "texture coordinate", &ct[n])))
            return rc;
        if (have[2] && (rc = resolve(o, at, raw[2], m->nnormals, "normal", &cn[n])))
            return rc;
        n++;
    }
    if (n < 3)
        return fail(o, p, RD_ERR_SYNTAX, "f: a face needs at least 3 corners, got %d", n);
    for (int i = 1; i + 1 < n; i++) {
        if (m->nfaces >= max_tris)
            return fail(o, o->ls, RD_ERR_LIMIT, "more than %zu triangles (%s)", max_tris, flag);
        if (!grow((void **)&m->faces, &o->capf, m->nfaces, sizeof *m->faces))
            return fail(o, o->ls, RD_ERR_NOMEM, "out of memory");
        rd_mesh_face *f = &m->faces[m->nfaces++];
        int c[3] = {0, i, i + 1};
        for (int k = 0; k < 3; k++) {
            f->v[k] = (uint32_t)cv[c[k]];
            f->n[k] = cn[c[k]];
            f->t[k] = ct[c[k]];
        }
    }
    return RD_OK;
}

rd_error_code rd_obj_parse(const char *text, size_t len, const char *source, size_t max_tris, const char *flag,
                           rd_mesh *out, rd_warnings *w, rd_error *err)
{
    memset(out, 0, sizeof *out);
    obj o;
    memset(&o, 0, sizeof o);
    o.source = source;
    o.m = out;
    o.err = err;
    size_t bad = rd_utf8_invalid_at(text, len);
    const char *p = text, *end = text + len;
    int warned_mtl = 0;
    while (p < end) {
        o.line++;
        o.ls = p;
        const char *le = memchr(p, '\n', (size_t)(end - p));
        const char *next = le ? le + 1 : end;
        if (!le)
            le = end;
        if ((size_t)(le - text) > bad)
            return fail(&o, text + bad, RD_ERR_SYNTAX, text[bad] ? "invalid UTF-8" : "NUL byte");
        while (p < le && is_space(*p))
            p++;
        const char *kw = p;
        while (p < le && !is_space(*p))
            p++;
        size_t kl = (size_t)(p - kw);
        double v[3] = {0, 0, 0};
        const char *badat = NULL;
        int nonfinite = 0;
        if (kl == 0 || kw[0] == '#') {
            /* blank or comment */
        } else if (kl == 1 && kw[0] == 'v') {
            int n = numbers(&p, le, v, 3, &badat, &nonfinite);
            if (n < 0)
                return fail(&o, badat, RD_ERR_SYNTAX, "v: expected a %snumber", nonfinite ? "finite " : "");
            if (n != 3 && n != 4 && n != 6 && n != 7)
                return fail(&o, kw, RD_ERR_SYNTAX, "v: expected 3 coordinates, got %d numbers", n);
            if (!grow((void **)&out->positions, &o.capv, out->npositions, sizeof *out->positions))
                return fail(&o, kw, RD_ERR_NOMEM, "out of memory");
            out->positions[out->npositions++] = v3(v[0], v[1], v[2]);
        } else if (kl == 2 && kw[0] == 'v' && kw[1] == 'n') {
            int n = numbers(&p, le, v, 3, &badat, &nonfinite);
            if (n < 0)
                return fail(&o, badat, RD_ERR_SYNTAX, "vn: expected a %snumber", nonfinite ? "finite " : "");
            if (n != 3)
                return fail(&o, kw, RD_ERR_SYNTAX, "vn: expected 3 numbers, got %d", n);
            if (!grow((void **)&out->normals, &o.capn, out->nnormals, sizeof *out->normals))
                return fail(&o, kw, RD_ERR_NOMEM, "out of memory");
            out->normals[out->nnormals++] = v3(v[0], v[1], v[2]);
        } else if (kl == 2 && kw[0] == 'v' && kw[1] == 't') {
            int n = numbers(&p, le, v, 3, &badat, &nonfinite);
            if (n < 0)
                return fail(&o, badat, RD_ERR_SYNTAX, "vt: expected a %snumber", nonfinite ? "finite " : "");
            if (n < 1 || n > 3)
                return fail(&o, kw, RD_ERR_SYNTAX, "vt: expected 1 to 3 numbers, got %d", n);
            if (!grow((void **)&out->uvs, &o.capt, out->nuvs, sizeof *out->uvs))
                return fail(&o, kw, RD_ERR_NOMEM, "out of memory");
            out->uvs[out->nuvs][0] = v[0];
            out->uvs[out->nuvs][1] = v[1];
            out->nuvs++;
        } else if (kl == 1 && kw[0] == 'f') {
            rd_error_code rc = face(&o, p, le, max_tris, flag);
            if (rc)
                return rc;
        } else if ((kl == 6 && memcmp(kw, "mtllib", 6) == 0) || (kl == 6 && memcmp(kw, "usemtl", 6) == 0)) {
            if (!warned_mtl++)
                rd_warn(w, "%s:%d: %.*s ignored: the mesh takes the scene's material", source, o.line, (int)kl, kw);
        } else if ((kl == 1 && (kw[0] == 'o' || kw[0] == 'g' || kw[0] == 's'))) {
            /* names, groups and smoothing groups do not change the surface */
        } else {
            rd_warn(w, "%s:%d: '%.*s' statements are not supported and were ignored", source, o.line,
                    (int)(kl > 20 ? 20 : kl), kw);
        }
        p = next;
    }
    if (bad < len) {
        o.ls = text;
        return fail(&o, text + bad, RD_ERR_SYNTAX, "invalid UTF-8");
    }
    return RD_OK;
}

static rd_vec3 rotate(rd_vec3 p, double cx, double sx, double cy, double sy, double cz, double sz)
{
    rd_vec3 a = v3(p.x, cx * p.y - sx * p.z, sx * p.y + cx * p.z);
    rd_vec3 b = v3(cy * a.x + sy * a.z, a.y, -sy * a.x + cy * a.z);
    return v3(cz * b.x - sz * b.y, sz * b.x + cz * b.y, b.z);
}

rd_error_code rd_mesh_transform(rd_mesh *m, rd_vec3 t, rd_vec3 s, rd_vec3 r, rd_error *err)
{
    if (!(s.x != 0 && s.y != 0 && s.z != 0) || !v3_is_finite(s))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "scale: every component must be non-zero");
    double k = M_PI / 180.0;
    double cx = cos(r.x * k), sx = sin(r.x * k), cy = cos(r.y * k), sy = sin(r.y * k);
    double cz = cos(r.z * k), sz = sin(r.z * k);
    int identity_rot = r.x == 0 && r.y == 0 && r.z == 0;
    for (size_t i = 0; i < m->npositions; i++) {
        rd_vec3 p = v3_mul(m->positions[i], s);
        if (!identity_rot)
            p = rotate(p, cx, sx, cy, sy, cz, sz);
        m->positions[i] = v3_add(p, t);
    }
    for (size_t i = 0; i < m->nnormals; i++) {
        rd_vec3 n = v3(m->normals[i].x / s.x, m->normals[i].y / s.y, m->normals[i].z / s.z);
        if (!identity_rot)
            n = rotate(n, cx, sx, cy, sy, cz, sz);
        m->normals[i] = n;
    }
    return RD_OK;
}
