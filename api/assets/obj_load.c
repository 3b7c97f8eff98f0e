#include "obj_load.h"

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/memory.h"
#include "rayd/parallel.h"
#include "scene_value.h"
#include "utf8.h"
#include "value_parse.h"

typedef struct {
    const char *source;
    int line;
    const char *ls;
    rd_mesh *m;
    size_t capv, capn, capt, capf;
    int fixed; /* the vertex arrays are shared and exactly sized: never grown */
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
    return rd_grow_array(arr, cap, count + 1, sz, 256);
}

/* Room for one more vertex entry: grown, or for a shared array only
 * checked (a range that finds more than it counted is parsed again on one
 * thread). */
static int room(obj *o, void **arr, size_t *cap, size_t count, size_t sz)
{
    return o->fixed ? count < *cap : grow(arr, cap, count, sz);
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

/* Warnings of a range of lines: said at once (one thread), or kept with
 * their line and said in line order after the ranges parsed on threads
 * are joined, so that both ways say the same. mtllib and usemtl are said
 * once per file. */
enum { KEPT_WARNINGS = 6 };

typedef struct {
    int line, mtl;
    char kw[24];
    int kl;
} warning_rec;

typedef struct {
    rd_warnings *w; /* NULL: keep them */
    const char *source;
    int mtl_seen;
    warning_rec kept[KEPT_WARNINGS];
    int nkept, unsupported; /* unsupported: all of them, kept or not */
    int first_mtl;          /* line of the first mtllib or usemtl; 0: none */
    warning_rec mtl;
} warn_sink;

static void say(rd_warnings *w, const char *source, const warning_rec *r)
{
    if (r->mtl)
        rd_warn(w, "%s:%d: %.*s ignored: the mesh takes the scene's material", source, r->line, r->kl, r->kw);
    else
        rd_warn(w, "%s:%d: '%.*s' statements are not supported and were ignored", source, r->line, r->kl, r->kw);
}

static void warn_at(warn_sink *ws, int line, const char *kw, size_t kl, int mtl)
{
    warning_rec r = {line, mtl, "", (int)(kl > 20 ? 20 : kl)};
    memcpy(r.kw, kw, (size_t)r.kl);
    if (mtl && ws->mtl_seen++)
        return;
    if (ws->w) {
        say(ws->w, ws->source, &r);
        return;
    }
    if (mtl) {
        ws->first_mtl = line;
        ws->mtl = r;
        return;
    }
    ws->unsupported++;
    if (ws->nkept < KEPT_WARNINGS)
        ws->kept[ws->nkept++] = r;
}

/* One line's statement, p just past the keyword kw (kl bytes). */
static rd_error_code statement(obj *o, const char *kw, size_t kl, const char *p, const char *le, size_t max_tris,
                               const char *flag, warn_sink *ws)
{
    rd_mesh *out = o->m;
    double v[3] = {0, 0, 0};
    const char *badat = NULL;
    int nonfinite = 0;
    if (kl == 0 || kw[0] == '#') {
        /* blank or comment */
    } else if (kl == 1 && kw[0] == 'v') {
        int n = numbers(&p, le, v, 3, &badat, &nonfinite);
        if (n < 0)
            return fail(o, badat, RD_ERR_SYNTAX, "v: expected a %snumber", nonfinite ? "finite " : "");
        if (n != 3 && n != 4 && n != 6 && n != 7)
            return fail(o, kw, RD_ERR_SYNTAX, "v: expected 3 coordinates, got %d numbers", n);
        if (!room(o, (void **)&out->positions, &o->capv, out->npositions, sizeof *out->positions))
            return fail(o, kw, RD_ERR_NOMEM, "out of memory");
        out->positions[out->npositions++] = v3(v[0], v[1], v[2]);
    } else if (kl == 2 && kw[0] == 'v' && kw[1] == 'n') {
        int n = numbers(&p, le, v, 3, &badat, &nonfinite);
        if (n < 0)
            return fail(o, badat, RD_ERR_SYNTAX, "vn: expected a %snumber", nonfinite ? "finite " : "");
        if (n != 3)
            return fail(o, kw, RD_ERR_SYNTAX, "vn: expected 3 numbers, got %d", n);
        if (!room(o, (void **)&out->normals, &o->capn, out->nnormals, sizeof *out->normals))
            return fail(o, kw, RD_ERR_NOMEM, "out of memory");
        out->normals[out->nnormals++] = v3(v[0], v[1], v[2]);
    } else if (kl == 2 && kw[0] == 'v' && kw[1] == 't') {
        int n = numbers(&p, le, v, 3, &badat, &nonfinite);
        if (n < 0)
            return fail(o, badat, RD_ERR_SYNTAX, "vt: expected a %snumber", nonfinite ? "finite " : "");
        if (n < 1 || n > 3)
            return fail(o, kw, RD_ERR_SYNTAX, "vt: expected 1 to 3 numbers, got %d", n);
        if (!room(o, (void **)&out->uvs, &o->capt, out->nuvs, sizeof *out->uvs))
            return fail(o, kw, RD_ERR_NOMEM, "out of memory");
        out->uvs[out->nuvs][0] = v[0];
        out->uvs[out->nuvs][1] = v[1];
        out->nuvs++;
    } else if (kl == 1 && kw[0] == 'f') {
        return face(o, p, le, max_tris, flag);
    } else if ((kl == 6 && memcmp(kw, "mtllib", 6) == 0) || (kl == 6 && memcmp(kw, "usemtl", 6) == 0)) {
        warn_at(ws, o->line, kw, kl, 1);
    } else if (!(kl == 1 && (kw[0] == 'o' || kw[0] == 'g' || kw[0] == 's'))) {
        /* o, g and s (names, groups, smoothing) do not change the surface */
        warn_at(ws, o->line, kw, kl, 0);
    }
    return RD_OK;
}

/* The lines of [p, end): o->line counts from the line before p. */
static rd_error_code parse_lines(obj *o, const char *text, const char *p, const char *end, size_t bad, size_t max_tris,
                                 const char *flag, warn_sink *ws)
{
    while (p < end) {
        o->line++;
        o->ls = p;
        const char *le = memchr(p, '\n', (size_t)(end - p));
        const char *next = le ? le + 1 : end;
        if (!le)
            le = end;
        if ((size_t)(le - text) > bad)
            return fail(o, text + bad, RD_ERR_SYNTAX, text[bad] ? "invalid UTF-8" : "NUL byte");
        while (p < le && is_space(*p))
            p++;
        const char *kw = p;
        while (p < le && !is_space(*p))
            p++;
        rd_error_code rc = statement(o, kw, (size_t)(p - kw), p, le, max_tris, flag, ws);
        if (rc)
            return rc;
        p = next;
    }
    return RD_OK;
}

static rd_error_code parse_one_thread(const char *text, size_t len, const char *source, size_t max_tris,
                                      const char *flag, rd_mesh *out, rd_warnings *w, rd_error *err)
{
    obj o;
    memset(&o, 0, sizeof o);
    o.source = source;
    o.m = out;
    o.err = err;
    size_t bad = rd_utf8_invalid_at(text, len);
    warn_sink ws = {w, source, 0, {{0}}, 0, 0, 0, {0}};
    rd_error_code rc = parse_lines(&o, text, text, text + len, bad, max_tris, flag, &ws);
    if (rc)
        return rc;
    if (bad < len) {
        o.ls = text;
        return fail(&o, text + bad, RD_ERR_SYNTAX, "invalid UTF-8");
    }
    return RD_OK;
}

/* On threads: the text cut at line ends into one range per thread; a
 * first pass counts each range's lines and v, vn and vt statements, so
 * that each range knows where its vertices go and what its relative
 * indices count back from; the second parses the ranges at once into the
 * shared vertex arrays and their own faces, joined in order. Anything
 * unusual (an error, a file past a limit, bad UTF-8) is parsed again on one
 * thread, whose answer and messages are the reference. */
enum { MAX_RANGES = RD_PIECES_MAX, RANGE_MIN_BYTES = 1 << 20 };

typedef struct {
    const char *begin, *end;
    int line0;
    size_t v, vn, vt; /* statements in the range (first pass) */
    size_t v0, vn0, vt0;
    obj o;
    rd_mesh m;
    warn_sink ws;
    rd_error err;
    rd_error_code rc;
    const char *text;
    size_t bad, max_tris;
    const char *flag;
    rd_mesh_face *dest; /* where the join puts its faces */
} range;

static void count_range(range *r)
{
    int lines = 0;
    for (const char *p = r->begin; p < r->end; lines++) {
        const char *le = memchr(p, '\n', (size_t)(r->end - p));
        const char *next = le ? le + 1 : r->end;
        while (p < next && is_space(*p))
            p++;
        if (p + 1 < next && p[0] == 'v' && (is_space(p[1]) || p[1] == '\n'))
            r->v++;
        else if (p + 2 < next && p[0] == 'v' && p[1] == 'n' && (is_space(p[2]) || p[2] == '\n'))
            r->vn++;
        else if (p + 2 < next && p[0] == 'v' && p[1] == 't' && (is_space(p[2]) || p[2] == '\n'))
            r->vt++;
        p = next;
    }
    r->line0 = lines; /* until the prefix sum: this range's own line count */
}

/* The passes over the ranges, each range on its own thread
 * (rd_run_each). */
static void parse_range(void *ctx, int i)
{
    range *r = &((range *)ctx)[i];
    r->rc = parse_lines(&r->o, r->text, r->begin, r->end, r->bad, r->max_tris, r->flag, &r->ws);
}

static void count_main(void *ctx, int i) { count_range(&((range *)ctx)[i]); }

/* A range's faces into the joined array: the copy is the first write of
 * those pages, so each range makes its own. */
static void copy_main(void *ctx, int i)
{
    range *r = &((range *)ctx)[i];
    if (r->m.nfaces)
        memcpy(r->dest, r->m.faces, r->m.nfaces * sizeof *r->dest);
}

static int cut(const char *text, size_t len, int threads, range *rs)
{
    int n = 0;
    const char *p = text, *end = text + len;
    for (int i = 0; i < threads && p < end; i++) {
        const char *e = i == threads - 1 ? end : text + len / (size_t)threads * (size_t)(i + 1);
        if (e < p)
            e = p;
        const char *nl = e < end ? memchr(e, '\n', (size_t)(end - e)) : NULL;
        e = nl ? nl + 1 : end;
        memset(&rs[n], 0, sizeof rs[n]);
        rs[n].begin = p;
        rs[n].end = e;
        n++;
        p = e;
    }
    return n;
}

/* Sets up each range's view of the shared arrays; 0 when out of memory. */
static int prepare_ranges(range *rs, int n, const char *text, size_t bad, const char *source, size_t max_tris,
                          const char *flag, rd_mesh *out)
{
    size_t v = 0, vn = 0, vt = 0;
    int line = 0;
    for (int i = 0; i < n; i++) {
        int own = rs[i].line0;
        rs[i].line0 = line;
        line += own;
        rs[i].v0 = v, rs[i].vn0 = vn, rs[i].vt0 = vt;
        v += rs[i].v, vn += rs[i].vn, vt += rs[i].vt;
    }
    out->positions = rd_big_malloc((v + 1) * sizeof *out->positions);
    out->normals = rd_big_malloc((vn + 1) * sizeof *out->normals);
    out->uvs = rd_big_malloc((vt + 1) * sizeof *out->uvs);
    if (!out->positions || !out->normals || !out->uvs)
        return 0;
    for (int i = 0; i < n; i++) {
        range *r = &rs[i];
        r->text = text, r->bad = bad, r->max_tris = max_tris, r->flag = flag;
        /* A range sees the vertices before it as defined; it writes its own
         * after them, and never grows the arrays: the counts are exact. */
        r->m.positions = out->positions, r->m.npositions = r->v0;
        r->m.normals = out->normals, r->m.nnormals = r->vn0;
        r->m.uvs = out->uvs, r->m.nuvs = r->vt0;
        r->o.source = source, r->o.m = &r->m, r->o.err = &r->err, r->o.line = r->line0;
        r->o.capv = r->v0 + r->v, r->o.capn = r->vn0 + r->vn, r->o.capt = r->vt0 + r->vt;
        r->o.fixed = 1;
        r->ws.source = source;
    }
    return 1;
}

/* The faces joined in order, and the warnings said in line order. */
static int join_ranges(range *rs, int n, size_t max_tris, rd_mesh *out, rd_warnings *w)
{
    size_t nf = 0;
    for (int i = 0; i < n; i++)
        nf += rs[i].m.nfaces;
    if (nf > max_tris)
        return 0;
    out->faces = rd_big_malloc((nf + 1) * sizeof *out->faces);
    if (!out->faces)
        return 0;
    for (int i = 0; i < n; i++) {
        rs[i].dest = out->faces + out->nfaces;
        out->nfaces += rs[i].m.nfaces;
    }
    rd_run_each(n, copy_main, rs);
    const range *last = &rs[n - 1];
    out->npositions = last->m.npositions, out->nnormals = last->m.nnormals, out->nuvs = last->m.nuvs;
    const warning_rec *mtl = NULL;
    for (int i = 0; i < n && !mtl; i++)
        mtl = rs[i].ws.first_mtl ? &rs[i].ws.mtl : NULL;
    for (int i = 0; i < n; i++) {
        const warn_sink *ws = &rs[i].ws;
        for (int k = 0; k < ws->nkept; k++) {
            if (mtl && mtl->line < ws->kept[k].line) {
                say(w, ws->source, mtl);
                mtl = NULL;
            }
            say(w, ws->source, &ws->kept[k]);
        }
        /* Those not kept are only counted, as rd_warn counts past five. */
        if (w)
            w->count += ws->unsupported - ws->nkept;
    }
    if (mtl)
        say(w, rs[0].ws.source, mtl);
    return 1;
}

static void free_ranges(range *rs, int n)
{
    for (int i = 0; i < n; i++)
        free(rs[i].m.faces);
}

rd_error_code rd_obj_parse_threads(const char *text, size_t len, const char *source, size_t max_tris, const char *flag,
                                   int threads, rd_mesh *out, rd_warnings *w, rd_error *err)
{
    memset(out, 0, sizeof *out);
    if (threads > MAX_RANGES)
        threads = MAX_RANGES;
    size_t bad = rd_utf8_invalid_at(text, len);
    if (threads < 2 || len < 2 * (size_t)RANGE_MIN_BYTES || bad < len)
        return parse_one_thread(text, len, source, max_tris, flag, out, w, err);
    if ((size_t)threads > len / RANGE_MIN_BYTES)
        threads = (int)(len / RANGE_MIN_BYTES);
    range rs[MAX_RANGES];
    int n = cut(text, len, threads, rs);
    rd_run_each(n, count_main, rs);
    int ok = prepare_ranges(rs, n, text, bad, source, max_tris, flag, out);
    if (ok) {
        rd_run_each(n, parse_range, rs);
        for (int i = 0; i < n; i++)
            ok = ok && rs[i].rc == RD_OK;
    }
    rd_warnings kept = w ? *w : (rd_warnings){0};
    ok = ok && join_ranges(rs, n, max_tris, out, w);
    free_ranges(rs, n);
    if (ok)
        return RD_OK;
    if (w)
        *w = kept;
    rd_mesh_free(out);
    memset(out, 0, sizeof *out);
    return parse_one_thread(text, len, source, max_tris, flag, out, w, err);
}

rd_error_code rd_obj_parse(const char *text, size_t len, const char *source, size_t max_tris, const char *flag,
                           rd_mesh *out, rd_warnings *w, rd_error *err)
{
    return rd_obj_parse_threads(text, len, source, max_tris, flag, 1, out, w, err);
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
