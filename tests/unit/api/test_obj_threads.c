/* OBJ meshes read on threads (api/assets/obj_load.h, rd_obj_parse_threads):
 * for files big enough to be cut into ranges, every thread count gives the
 * one-thread answer exactly: the same vertices, faces and normals to the
 * bit, the same warnings (count and text, mtllib said once), and for a bad
 * file the same error with the same line and column. */
#include <criterion/criterion.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "obj_load.h"
#include "support/rng.h"

typedef struct {
    char *buf;
    size_t len, cap;
} text;

static void put(text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(text *t, const char *fmt, ...)
{
    va_list ap;
    if (!t->buf) {
        t->cap = 1 << 20;
        t->buf = malloc(t->cap);
        cr_assert(t->buf);
    }
    for (;;) {
        va_start(ap, fmt);
        int n = vsnprintf(t->buf + t->len, t->cap - t->len, fmt, ap);
        va_end(ap);
        if ((size_t)n < t->cap - t->len) {
            t->len += (size_t)n;
            return;
        }
        t->cap = t->cap ? t->cap * 2 : 1 << 20;
        t->buf = realloc(t->buf, t->cap);
        cr_assert(t->buf);
    }
}

/* About 8 MiB: vertices, normals and texture coordinates interleaved with
 * faces that use positive and negative indices (counting back over range
 * boundaries), comments, CRLF ends, groups, and statements that warn. */
static text big_obj(uint64_t seed)
{
    text t = {0};
    test_rng r = {seed};
    size_t nv = 0, nt = 0, nn = 0;
    put(&t, "# generated\nmtllib x.mtl\no thing\n");
    for (int block = 0; block < 9000; block++) {
        for (int i = 0; i < 8; i++, nv++)
            put(&t, "v %.6f %.17g %.3e\n", rng_range(&r, -1, 1), rng_range(&r, -1e3, 1e3), rng_range(&r, -5, 5));
        put(&t, "vt %.4f %.4f\r\nvn 0 %.5f 1\n", rng_uniform(&r), rng_uniform(&r), rng_uniform(&r));
        nt++, nn++;
        if (block % 1500 == 7)
            put(&t, "usemtl m%d\ncstype bezier\n", block);
        if (block % 3 == 0)
            put(&t, "s off\ng part%d\n", block);
        for (int f = 0; f < 10; f++) {
            long a = 1 + rng_int(&r, (int)nv), b = -1 - rng_int(&r, 8), c = 1 + rng_int(&r, (int)nv);
            if (f % 3 == 0)
                put(&t, "f %ld/%zu/%zu %ld//1 %ld/-1/-1 %ld\n", a, nt, nn, b, c, a);
            else
                put(&t, "f %ld %ld %ld   # a face\n", a, b, c);
        }
    }
    return t;
}

typedef struct {
    rd_mesh m;
    rd_warnings w;
    rd_error err;
    rd_error_code rc;
} parsed;

static void parse(parsed *p, const text *t, int threads, size_t max_tris)
{
    memset(p, 0, sizeof *p);
    p->rc =
        rd_obj_parse_threads(t->buf, t->len, "big.obj", max_tris, "--limit-objects", threads, &p->m, &p->w, &p->err);
}

static void same(const parsed *a, const parsed *b, int threads)
{
    cr_assert_eq(b->rc, a->rc, "%d threads: %s, one thread: %s", threads, b->err.message, a->err.message);
    cr_assert_str_eq(b->err.message, a->err.message, "%d threads: another message", threads);
    cr_assert(b->err.line == a->err.line && b->err.column == a->err.column, "%d threads: another place", threads);
    cr_assert_eq(b->w.count, a->w.count, "%d threads: %d warnings, one thread %d", threads, b->w.count, a->w.count);
    cr_assert_str_eq(b->w.text, a->w.text, "%d threads: other warnings", threads);
    const rd_mesh *x = &a->m, *y = &b->m;
    cr_assert(x->npositions == y->npositions && x->nnormals == y->nnormals && x->nuvs == y->nuvs &&
                  x->nfaces == y->nfaces,
              "%d threads: %zu/%zu/%zu/%zu, one thread %zu/%zu/%zu/%zu", threads, y->npositions, y->nnormals, y->nuvs,
              y->nfaces, x->npositions, x->nnormals, x->nuvs, x->nfaces);
    if (a->rc)
        return;
    cr_assert(memcmp(x->positions, y->positions, x->npositions * sizeof *x->positions) == 0, "positions differ");
    cr_assert(memcmp(x->normals, y->normals, x->nnormals * sizeof *x->normals) == 0, "normals differ");
    cr_assert(memcmp(x->uvs, y->uvs, x->nuvs * sizeof *x->uvs) == 0, "texture coordinates differ");
    cr_assert(memcmp(x->faces, y->faces, x->nfaces * sizeof *x->faces) == 0, "faces differ");
}

static void compare_threads(const text *t, size_t max_tris)
{
    parsed one;
    parse(&one, t, 1, max_tris);
    for (int threads = 2; threads <= 16; threads = threads < 4 ? threads + 1 : threads * 4) {
        parsed many;
        parse(&many, t, threads, max_tris);
        same(&one, &many, threads);
        rd_mesh_free(&many.m);
    }
    rd_mesh_free(&one.m);
}

Test(obj_threads, a_big_file_reads_the_same_on_every_thread_count)
{
    text t = big_obj(1);
    cr_assert(t.len > 4u << 20, "the file is %zu bytes, too small to be cut", t.len);
    parsed one;
    parse(&one, &t, 1, 10000000);
    cr_assert_eq(one.rc, RD_OK, "%s", one.err.message);
    cr_assert(one.m.nfaces > 100000 && one.w.count >= 3, "%zu faces, %d warnings", one.m.nfaces, one.w.count);
    rd_mesh_free(&one.m);
    compare_threads(&t, 10000000);
    free(t.buf);
}

/* The same error, wherever it is: a bad number late in the file, an index
 * past the vertices defined so far, more triangles than allowed. */
Test(obj_threads, errors_are_the_one_thread_errors)
{
    text t = big_obj(2);
    size_t at = t.len * 3 / 4;
    char *nl = memchr(t.buf + at, '\n', t.len - at);
    cr_assert(nl);
    memcpy(nl + 1, "v 1 2 x", 7); /* breaks the line that started there */
    compare_threads(&t, 10000000);
    free(t.buf);

    t = big_obj(3);
    at = t.len / 2;
    nl = memchr(t.buf + at, '\n', t.len - at);
    memcpy(nl + 1, "f 999999 1 2", 12);
    compare_threads(&t, 10000000);
    free(t.buf);

    t = big_obj(4);
    compare_threads(&t, 50000);
    free(t.buf);

    t = big_obj(5);
    t.buf[t.len * 2 / 3] = (char)0xff; /* not UTF-8 */
    compare_threads(&t, 10000000);
    free(t.buf);
}
