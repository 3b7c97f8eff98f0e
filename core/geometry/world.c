#include "world.h"

#include "rayd/clock.h"
#include "rayd/memory.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "prim.h"
#include "rayd/parallel.h"
#include "sphere4.h"
#include "triangle.h"

void rd_world_free(rd_world *w)
{
    free(w->spheres);
    free(w->sphere4);
    free(w->sphere_mat);
    free(w->sphere_obj);
    free(w->planes);
    free(w->plane_mat);
    free(w->plane_obj);
    free(w->tris);
    free(w->tri_pos);
    free(w->sph);
    free(w->unit_n);
    free(w->mesh_n);
    rd_bvh_free(&w->bvh);
    rd_bvh4_free(&w->bvh4);
    memset(w, 0, sizeof *w);
}

static rd_error_code nomem(rd_world *w, rd_error *err)
{
    rd_world_free(w);
    return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory preparing the scene");
}

void rd_world_bounds_of(const rd_world *w, size_t first, size_t count, rd_vec3 *lo, rd_vec3 *hi)
{
    for (size_t k = 0; k < count; k++) {
        size_t i = first + k;
        if (i < w->nspheres) {
            rd_vec3 r = v3(w->spheres[i].r, w->spheres[i].r, w->spheres[i].r);
            lo[k] = v3_sub(w->spheres[i].c, r);
            hi[k] = v3_add(w->spheres[i].c, r);
            continue;
        }
        const rd_vec3 *v = rd_world_tri(w, i - w->nspheres)->v;
        lo[k] = v3(fmin(v[0].x, fmin(v[1].x, v[2].x)), fmin(v[0].y, fmin(v[1].y, v[2].y)),
                   fmin(v[0].z, fmin(v[1].z, v[2].z)));
        hi[k] = v3(fmax(v[0].x, fmax(v[1].x, v[2].x)), fmax(v[0].y, fmax(v[1].y, v[2].y)),
                   fmax(v[0].z, fmax(v[1].z, v[2].z)));
    }
}

void rd_world_bounds(const rd_world *w, rd_vec3 *lo, rd_vec3 *hi)
{
    rd_world_bounds_of(w, 0, w->nspheres + w->ntris, lo, hi);
}

static void bounds_fn(const void *ctx, size_t first, size_t count, rd_vec3 *lo, rd_vec3 *hi)
{
    rd_world_bounds_of(ctx, first, count, lo, hi);
}

/* A mesh's faces as world triangles, [first, first + count) of them. */
typedef struct {
    const rd_world *w;
    const rd_object *o;
    int32_t object;
    rd_wtri *tris;
} mesh_fill;

enum { FILL_MIN = 65536 };

static void fill_faces(void *arg, size_t first, size_t count)
{
    const mesh_fill *mf = arg;
    const rd_mesh *m = &mf->w->scene->meshes[mf->o->mesh];
    for (size_t f = first; f < first + count; f++) {
        rd_wtri *t = &mf->tris[f];
        for (int c = 0; c < 3; c++)
            t->v[c] = rd_world_local(mf->w, m->positions[m->faces[f].v[c]]);
        t->material = mf->o->material;
        t->object = mf->object;
        t->mesh = mf->o->mesh;
        t->face = (uint32_t)f;
    }
}

/* Room in unit_n for every normal: the [triangle]s' first, so that where
 * theirs start fits rd_wtri.face. */
static rd_error_code alloc_unit_normals(rd_world *w, rd_error *err)
{
    const rd_scene *s = w->scene;
    size_t objects = 0, all;
    for (size_t i = 0; i < s->object_count; i++)
        objects += s->objects[i].type == RD_OBJ_TRIANGLE && s->objects[i].has_normals ? 3 : 0;
    if (objects >= RD_WTRI_NO_NORMALS)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "more than 2^32 triangle normals");
    all = objects;
    for (size_t m = 0; m < s->mesh_count; m++)
        all += s->meshes[m].nnormals;
    if (!all)
        return RD_OK;
    w->unit_n = rd_big_malloc(all * sizeof *w->unit_n);
    w->mesh_n = malloc((s->mesh_count + 1) * sizeof *w->mesh_n);
    if (!w->unit_n || !w->mesh_n)
        return nomem(w, err);
    w->mesh_n[0] = objects;
    for (size_t m = 0; m < s->mesh_count; m++)
        w->mesh_n[m + 1] = w->mesh_n[m] + s->meshes[m].nnormals;
    return RD_OK;
}

static void mesh_unit_normals(rd_world *w)
{
    const rd_scene *s = w->scene;
    for (size_t m = 0; w->unit_n && m < s->mesh_count; m++) {
        const rd_mesh *mesh = &s->meshes[m];
        for (size_t i = 0; i < mesh->nnormals; i++)
            w->unit_n[w->mesh_n[m] + i] = v3_normalize(mesh->normals[i]);
    }
    w->nunit_n = w->unit_n ? w->mesh_n[s->mesh_count] : 0;
}

/* The first and last positions in bvh.prims of spheres (kind 0) or
 * triangles (kind 1). */
static void span_of(const rd_world *w, int kind, size_t *first, size_t *last)
{
    *first = SIZE_MAX;
    *last = 0;
    for (size_t p = 0; p < w->bvh.nprims; p++)
        if ((w->bvh.prims[p] >= w->nspheres) == kind) {
            *first = p < *first ? p : *first;
            *last = p;
        }
}

/* Moves the triangles in place, each to its slot tri_pos[k] (a
 * permutation of [0, ntris)), cycle by cycle: no second copy of them, whose
 * fresh pages cost a million-triangle build more than the moves. */
static int permute_tris(rd_world *w)
{
    size_t n = w->ntris;
    uint64_t *done = calloc(n / 64 + 1, sizeof *done);
    if (!done)
        return 0;
    for (size_t s = 0; s < n; s++) {
        if (done[s / 64] >> (s % 64) & 1)
            continue;
        rd_wtri carry = w->tris[s];
        for (size_t k = s;;) {
            done[k / 64] |= (uint64_t)1 << (k % 64);
            size_t to = w->tri_pos[k];
            rd_wtri next = w->tris[to];
            w->tris[to] = carry;
            if (to == s)
                break;
            carry = next;
            k = to;
        }
    }
    free(done);
    return 1;
}

/* The triangles moved into the order of bvh.prims (world.h). */
static int tris_in_leaf_order(rd_world *w)
{
    size_t lo, hi;
    span_of(w, 1, &lo, &hi);
    w->tri_pos = rd_big_malloc((w->ntris + 1) * sizeof *w->tri_pos);
    if (!w->tri_pos)
        return 0;
    for (size_t p = lo; p <= hi; p++)
        if (w->bvh.prims[p] >= w->nspheres)
            w->tri_pos[w->bvh.prims[p] - w->nspheres] = (uint32_t)(p - lo);
    w->tri_first = lo;
    w->tri_slots = hi - lo + 1;
    if (w->tri_slots == w->ntris)
        return permute_tris(w);
    /* Spheres lie between the triangles: a larger array, its spheres'
     * slots unused. */
    rd_wtri *moved = rd_big_malloc((w->tri_slots + 1) * sizeof *moved);
    if (!moved)
        return 0;
    memset(moved, 0, (w->tri_slots + 1) * sizeof *moved);
    for (size_t k = 0; k < w->ntris; k++)
        moved[w->tri_pos[k]] = w->tris[k];
    free(w->tris);
    w->tris = moved;
    return 1;
}

/* The spheres by position of bvh.prims (world.h). */
static int spheres_in_leaf_order(rd_world *w)
{
    size_t lo, hi;
    span_of(w, 0, &lo, &hi);
    size_t n = hi - lo + 1 + 4;
    w->sph = rd_big_malloc(4 * n * sizeof *w->sph);
    if (!w->sph)
        return 0;
    w->sph_first = lo;
    w->sph_n = n;
    for (size_t i = 0; i < n; i++) {
        size_t p = lo + i;
        uint32_t id = p < w->bvh.nprims ? w->bvh.prims[p] : UINT32_MAX;
        const rd_sphere *sp = id < w->nspheres ? &w->spheres[id] : NULL;
        w->sph[i] = sp ? sp->c.x : 0;
        w->sph[n + i] = sp ? sp->c.y : 0;
        w->sph[2 * n + i] = sp ? sp->c.z : 0;
        w->sph[3 * n + i] = sp ? sp->r : NAN;
    }
    return 1;
}

/* Each small leaf's kinds (rd_bvh4_node.spheres). */
static void leaf_kinds(rd_world *w)
{
    for (size_t i = 0; i < w->bvh4.nnodes; i++) {
        rd_bvh4_node *n = &w->bvh4.nodes[i];
        for (int c = 0; c < 4; c++) {
            n->spheres[c] = 0;
            for (uint32_t j = 0; n->count[c] <= RD_BVH4_KINDS && j < n->count[c]; j++)
                n->spheres[c] |= (uint16_t)((w->bvh.prims[n->child[c] + j] < w->nspheres) << j);
        }
    }
}

rd_error_code rd_world_build(rd_world *w, const rd_scene *s, rd_error *err)
{
    return rd_world_build_threads(w, s, 1, err);
}

rd_error_code rd_world_build_threads(rd_world *w, const rd_scene *s, int threads, rd_error *err)
{
    memset(w, 0, sizeof *w);
    w->scene = s;
    w->origin = s->camera.eye;
    size_t ns = 0, np = 0, nt = 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->material < 0 || (size_t)o->material >= s->material_count)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "object %zu has no material", i);
        if (o->type == RD_OBJ_SPHERE)
            ns++;
        else if (o->type == RD_OBJ_PLANE)
            np++;
        else if (o->type == RD_OBJ_TRIANGLE)
            nt++;
        else if (o->mesh < 0 || (size_t)o->mesh >= s->mesh_count)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "object %zu: mesh '%s' was not loaded", i,
                                o->file ? o->file : "?");
        else
            nt += s->meshes[o->mesh].nfaces;
    }
    w->spheres = malloc((ns + 1) * sizeof *w->spheres);
    w->sphere_mat = malloc((ns + 1) * sizeof(int32_t));
    w->sphere_obj = malloc((ns + 1) * sizeof(int32_t));
    w->planes = malloc((np + 1) * sizeof *w->planes);
    w->plane_mat = malloc((np + 1) * sizeof(int32_t));
    w->plane_obj = malloc((np + 1) * sizeof(int32_t));
    w->tris = rd_big_malloc((nt + 1) * sizeof *w->tris);
    if (!w->spheres || !w->sphere_mat || !w->sphere_obj || !w->planes || !w->plane_mat || !w->plane_obj || !w->tris)
        return nomem(w, err);
    rd_error_code rc = alloc_unit_normals(w, err);
    if (rc)
        return rc;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->type == RD_OBJ_SPHERE) {
            size_t k = w->nspheres++;
            w->spheres[k].c = rd_world_local(w, o->center);
            w->spheres[k].r = o->radius;
            w->sphere_mat[k] = o->material;
            w->sphere_obj[k] = (int32_t)i;
        } else if (o->type == RD_OBJ_PLANE) {
            size_t k = w->nplanes++;
            rd_plane_make(&w->planes[k], rd_world_local(w, o->point), o->normal);
            w->plane_mat[k] = o->material;
            w->plane_obj[k] = (int32_t)i;
        } else if (o->type == RD_OBJ_TRIANGLE) {
            rd_wtri *t = &w->tris[w->ntris++];
            for (int c = 0; c < 3; c++)
                t->v[c] = rd_world_local(w, o->v[c]);
            t->material = o->material;
            t->object = (int32_t)i;
            t->mesh = -1;
            t->face = RD_WTRI_NO_NORMALS;
            if (o->has_normals) {
                t->face = (uint32_t)w->nunit_n;
                for (int c = 0; c < 3; c++)
                    w->unit_n[w->nunit_n++] = v3_normalize(o->n[c]);
            }
        } else {
            mesh_fill mf = {w, o, (int32_t)i, w->tris + w->ntris};
            rd_parallel_runs(s->meshes[o->mesh].nfaces, FILL_MIN, threads, fill_faces, &mf);
            w->ntris += s->meshes[o->mesh].nfaces;
        }
    }
    mesh_unit_normals(w);
    size_t nb = w->nspheres + w->ntris;
    if (nb > RD_WORLD_BVH_MIN) {
        double t0 = rd_now_ms();
        rc = rd_bvh_build_from(&w->bvh, nb, bounds_fn, w, threads, err);
        if (!rc)
            rc = rd_bvh4_build(&w->bvh4, &w->bvh, err);
        if (rc) {
            rd_world_free(w);
            return rc;
        }
        /* Rays walk the four-wide tree; of the binary one only the
         * primitive order is kept. */
        free(w->bvh.nodes);
        w->bvh.nodes = NULL;
        w->bvh.nnodes = 0;
        if (w->bvh4.nnodes >= (size_t)1 << 30) {
            rd_world_free(w);
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "the scene's BVH has more than 2^30 nodes");
        }
        if ((w->ntris && !tris_in_leaf_order(w)) || (w->nspheres && !spheres_in_leaf_order(w)))
            return nomem(w, err);
        leaf_kinds(w);
        w->avx2 = rd_bvh4_cpu_has_avx2();
        w->avx512 = w->avx2 && rd_bvh4_cpu_has_avx512();
        w->use_bvh = 1;
        w->build_ms = rd_now_ms() - t0;
    } else if (w->nspheres) {
        w->avx2 = rd_bvh4_cpu_has_avx2();
        w->sphere4 = malloc((w->nspheres + 3) / 4 * sizeof *w->sphere4);
        if (!w->sphere4)
            return nomem(w, err);
        rd_sphere4_pack(w->spheres, w->nspheres, w->sphere4);
    }
    return RD_OK;
}

size_t rd_world_bytes(const rd_world *w)
{
    return w->nspheres * (sizeof *w->spheres + 2 * sizeof(int32_t)) +
           w->nplanes * (sizeof *w->planes + 2 * sizeof(int32_t)) +
           (w->tri_pos ? w->tri_slots * sizeof *w->tris + w->ntris * sizeof *w->tri_pos : w->ntris * sizeof *w->tris) +
           4 * w->sph_n * sizeof *w->sph + w->nunit_n * sizeof *w->unit_n +
           (w->mesh_n ? (w->scene->mesh_count + 1) * sizeof *w->mesh_n : 0) + w->bvh.nnodes * sizeof *w->bvh.nodes +
           w->bvh.nprims * sizeof *w->bvh.prims + w->bvh4.nnodes * sizeof *w->bvh4.nodes +
           (w->sphere4 ? (w->nspheres + 3) / 4 * sizeof *w->sphere4 : 0);
}

/* A node or leaf to visit, with the distance at which the ray enters it. */
typedef struct {
    uint32_t idx;
    uint16_t count, spheres;
    double t;
} visit;

/* The ray as a walk's box test takes it: the AVX2 walk of rays without a
 * flat axis has its own form (bvh4.h); the others test the plain one. */
static inline void plain_ray(const rd_bvh_ray *b, const rd_bvh_ray **q) { *q = b; }
#define RD_TEST_PLAIN_SSE2(n, q, tmax, tn) rd_bvh4_test_sse2(n, q, tmax, tn)
#define RD_TEST_PLAIN_AVX2(n, q, tmax, tn) rd_bvh4_test_avx2(n, q, tmax, tn)
#define RD_TEST_RAY_AVX2(n, q, tmax, tn) rd_bvh4_test_avx2_ray(n, &(q), tmax, tn)

/* The walks, written once and compiled for each box test: the test is
 * inlined into its loop. The ray comes by pointer and its triangle set-up
 * waits for the first triangle (prim.h). */
#define RD_WALK_CLOSEST(NAME, ATTR, QTYPE, QMAKE, TEST, LEAF)                                                          \
    ATTR static void NAME(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, rd_best *b)                        \
    {                                                                                                                  \
        QTYPE q;                                                                                                       \
        QMAKE(br, &q);                                                                                                 \
        rd_tri_lazy tr = rd_tri_lazy_none();                                                                           \
        visit stack[RD_BVH4_STACK];                                                                                    \
        int sp = 0;                                                                                                    \
        stack[sp++] = (visit){0, 0, 0, 0};                                                                             \
        while (sp > 0) {                                                                                               \
            visit v = stack[--sp];                                                                                     \
            /* Entered beyond the cut: nothing in it can win (prim.h). */                                              \
            if (v.t > b->cut)                                                                                          \
                continue;                                                                                              \
            if (v.count) {                                                                                             \
                double floor = rd_leaf_floor(v.t);                                                                     \
                LEAF(w, v.idx, v.count, v.spheres, r, &tr, floor, b);                                                  \
                continue;                                                                                              \
            }                                                                                                          \
            const rd_bvh4_node *n = &w->bvh4.nodes[v.idx];                                                             \
            double tn[4];                                                                                              \
            unsigned m = TEST(n, q, b->cut, tn);                                                                       \
            int base = sp;                                                                                             \
            for (int i = 0; i < 4; i++) {                                                                              \
                if (!(m >> i & 1))                                                                                     \
                    continue;                                                                                          \
                visit c = {n->child[i], n->count[i], n->spheres[i], tn[i]};                                            \
                RD_PUSH_NEAREST_ON_TOP(stack, sp, base, c);                                                            \
            }                                                                                                          \
        }                                                                                                              \
    }

#define RD_WALK_ANY(NAME, ATTR, QTYPE, QMAKE, TEST, LEAF)                                                              \
    ATTR static int NAME(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, double tmax, uint32_t *last)        \
    {                                                                                                                  \
        rd_tri_lazy tr = rd_tri_lazy_none();                                                                           \
        if (last && *last && rd_world_hint_blocks(w, r, br, &tr, tmax, *last))                                         \
            return 1;                                                                                                  \
        QTYPE q;                                                                                                       \
        QMAKE(br, &q);                                                                                                 \
        uint32_t stack[RD_BVH4_STACK];                                                                                 \
        int sp = 0;                                                                                                    \
        stack[sp++] = 0;                                                                                               \
        while (sp > 0) {                                                                                               \
            uint32_t node = stack[--sp];                                                                               \
            const rd_bvh4_node *n = &w->bvh4.nodes[node];                                                              \
            double tn[4];                                                                                              \
            unsigned m = TEST(n, q, tmax, tn);                                                                         \
            for (int i = 0; i < 4; i++) {                                                                              \
                if (!(m >> i & 1))                                                                                     \
                    continue;                                                                                          \
                if (!n->count[i]) {                                                                                    \
                    stack[sp++] = n->child[i];                                                                         \
                    continue;                                                                                          \
                }                                                                                                      \
                if (LEAF(w, n->child[i], n->count[i], n->spheres[i], r, &tr, tmax)) {                                  \
                    if (last)                                                                                          \
                        *last = rd_world_hint(node, i);                                                                \
                    return 1;                                                                                          \
                }                                                                                                      \
            }                                                                                                          \
        }                                                                                                              \
        return 0;                                                                                                      \
    }

/* Not inlined: their stacks would enlarge every caller's frame, also for
 * worlds without a BVH. */
#define RD_NOINLINE_AVX2 __attribute__((noinline, target("avx2")))

/* A leaf's tests, one call a leaf: inlined into the walks, they made the
 * walks' own loops spill (3.5% more instructions on 10,000 spheres). */
#define RD_LEAF_FNS(SUFFIX, ATTR)                                                                                      \
    ATTR static void leaf_closest_##SUFFIX(const rd_world *w, uint32_t first, uint32_t count, uint16_t spheres,        \
                                           const rd_ray *r, rd_tri_lazy *tr, double floor, rd_best *b)                 \
    {                                                                                                                  \
        rd_leaf_closest(w, first, count, spheres, r, tr, floor, b);                                                    \
    }                                                                                                                  \
    ATTR static int leaf_any_##SUFFIX(const rd_world *w, uint32_t first, uint32_t count, uint16_t spheres,             \
                                      const rd_ray *r, rd_tri_lazy *tr, double tmax)                                   \
    {                                                                                                                  \
        return rd_leaf_any(w, first, count, spheres, r, tr, tmax);                                                     \
    }
RD_LEAF_FNS(sse2, __attribute__((noinline)))

/* The next group of up to four of a leaf's spheres that lie together in
 * the leaf-order runs (world.h), taken off *spheres: its roots in q, its
 * place in the leaf in *g, the lanes that are its and hit. */
static inline __attribute__((always_inline, target("avx2"))) unsigned
leaf_sphere_group(const rd_world *w, uint32_t first, unsigned *spheres, const rd_ray *r, rd_sphere4_roots *q,
                  unsigned *g)
{
    *g = (unsigned)__builtin_ctz(*spheres);
    unsigned at = first + *g - (unsigned)w->sph_first, lanes = *spheres >> *g & 15;
    *spheres &= ~(15u << *g);
    const double *x = w->sph + at, *y = x + w->sph_n, *z = y + w->sph_n, *rad = z + w->sph_n;
    return rd_sphere4_roots_at(x, y, z, rad, r, q) & lanes;
}

/* A leaf's spheres four at a time from the leaf-order runs (world.h):
 * each group of up to four that lie together, its lanes taken in turn
 * with the limit of their turn, as rd_prim_closest would take them. */
static inline __attribute__((always_inline, target("avx2"))) void
leaf_spheres_closest(const rd_world *w, uint32_t first, unsigned spheres, const rd_ray *r, double floor, rd_best *b)
{
    while (spheres) {
        unsigned g;
        rd_sphere4_roots q;
        for (unsigned ok = leaf_sphere_group(w, first, &spheres, r, &q, &g); ok; ok &= ok - 1) {
            int lane = __builtin_ctz(ok);
            double t = rd_sphere4_pick(&q, lane, b->limit);
            if (!(t > 0 && t >= floor))
                continue;
            uint32_t id = w->bvh.prims[first + g + (unsigned)lane];
            if (rd_best_takes(b, t, id))
                rd_best_set(b, t, RD_K_SPHERE, id, id);
        }
    }
}

static inline __attribute__((always_inline, target("avx2"))) int
leaf_spheres_any(const rd_world *w, uint32_t first, unsigned spheres, const rd_ray *r, double tmax)
{
    while (spheres) {
        unsigned g;
        rd_sphere4_roots q;
        for (unsigned ok = leaf_sphere_group(w, first, &spheres, r, &q, &g); ok; ok &= ok - 1)
            if (rd_sphere4_pick(&q, __builtin_ctz(ok), tmax) > 0)
                return 1;
    }
    return 0;
}

/* A leaf's tests, one call a leaf: inlined into the walks, they made the
 * walks' own loops spill. */
RD_NOINLINE_AVX2 static void leaf_closest_avx2(const rd_world *w, uint32_t first, uint32_t count, uint16_t spheres,
                                               const rd_ray *r, rd_tri_lazy *tr, double floor, rd_best *b)
{
    if (count > RD_BVH4_KINDS) {
        rd_leaf_closest(w, first, count, spheres, r, tr, floor, b);
        return;
    }
    leaf_spheres_closest(w, first, spheres, r, floor, b);
    for (unsigned m = rd_leaf_tris(count, spheres); m; m &= m - 1)
        rd_leaf_tri_closest(w, first + (uint32_t)__builtin_ctz(m), r, tr, floor, b);
}

RD_NOINLINE_AVX2 static int leaf_any_avx2(const rd_world *w, uint32_t first, uint32_t count, uint16_t spheres,
                                          const rd_ray *r, rd_tri_lazy *tr, double tmax)
{
    if (count > RD_BVH4_KINDS)
        return rd_leaf_any(w, first, count, spheres, r, tr, tmax);
    return leaf_spheres_any(w, first, spheres, r, tmax) ||
           rd_leaf_tris_any(w, first, rd_leaf_tris(count, spheres), r, tr, tmax);
}

RD_WALK_CLOSEST(closest_sse2, __attribute__((noinline)), const rd_bvh_ray *, plain_ray, RD_TEST_PLAIN_SSE2,
                leaf_closest_sse2)
RD_WALK_CLOSEST(closest_avx2_flat, RD_NOINLINE_AVX2, const rd_bvh_ray *, plain_ray, RD_TEST_PLAIN_AVX2,
                leaf_closest_avx2)
RD_WALK_CLOSEST(closest_avx2, RD_NOINLINE_AVX2, rd_bvh4_ray_avx2, rd_bvh4_ray_avx2_make, RD_TEST_RAY_AVX2,
                leaf_closest_avx2)
RD_WALK_ANY(any_sse2, __attribute__((noinline)), const rd_bvh_ray *, plain_ray, RD_TEST_PLAIN_SSE2, leaf_any_sse2)
RD_WALK_ANY(any_avx2_flat, RD_NOINLINE_AVX2, const rd_bvh_ray *, plain_ray, RD_TEST_PLAIN_AVX2, leaf_any_avx2)
RD_WALK_ANY(any_avx2, RD_NOINLINE_AVX2, rd_bvh4_ray_avx2, rd_bvh4_ray_avx2_make, RD_TEST_RAY_AVX2, leaf_any_avx2)

static int has_flat(const rd_bvh_ray *br) { return br->flat[0] | br->flat[1] | br->flat[2]; }

/* Only the walks need rays turned away (rd_ray_finite): the plain loops'
 * tests already hit nothing with them. */
static void bvh_closest(const rd_world *w, const rd_ray *r, rd_best *b)
{
    if (!rd_ray_finite(*r))
        return;
    rd_bvh_ray br = rd_bvh_ray_make(*r);
    if (!w->avx2)
        closest_sse2(w, r, &br, b);
    else if (has_flat(&br))
        closest_avx2_flat(w, r, &br, b);
    else
        closest_avx2(w, r, &br, b);
}

int rd_world_hint_blocks(const rd_world *w, const rd_ray *r, const rd_bvh_ray *br, rd_tri_lazy *tr, double tmax,
                         uint32_t hint)
{
    uint32_t node = (hint - 1) >> 2;
    int slot = (int)((hint - 1) & 3);
    if (!w->use_bvh || node >= w->bvh4.nnodes)
        return 0;
    const rd_bvh4_node *n = &w->bvh4.nodes[node];
    double tn[4];
    /* The SSE2 test accepts exactly what the others accept (bvh4.h). */
    if (!n->count[slot] || !(rd_bvh4_test_sse2(n, br, tmax, tn) >> slot & 1))
        return 0;
    return rd_leaf_any(w, n->child[slot], n->count[slot], n->spheres[slot], r, tr, tmax);
}

static int bvh_any(const rd_world *w, const rd_ray *r, double tmax, uint32_t *last)
{
    if (!rd_ray_finite(*r))
        return 0;
    rd_bvh_ray br = rd_bvh_ray_make(*r);
    int blocked = !w->avx2        ? any_sse2(w, r, &br, tmax, last)
                  : has_flat(&br) ? any_avx2_flat(w, r, &br, tmax, last)
                                  : any_avx2(w, r, &br, tmax, last);
    /* A ray that reached its light forgets the occluder: in the light, the
     * next ray would test it in vain (world.h). */
    if (!blocked && last)
        *last = 0;
    return blocked;
}

static void fill_tri(const rd_world *w, const rd_best *b, rd_hit *h)
{
    const rd_wtri *t = &w->tris[b->idx];
    const double *bc = b->bary;
    h->p = v3_add(v3_add(v3_scale(t->v[0], bc[0]), v3_scale(t->v[1], bc[1])), v3_scale(t->v[2], bc[2]));
    h->ng = v3_normalize(v3_cross(v3_sub(t->v[1], t->v[0]), v3_sub(t->v[2], t->v[0])));
    h->perr = 8 * DBL_EPSILON * fmax(v3_max_abs(t->v[0]), fmax(v3_max_abs(t->v[1]), v3_max_abs(t->v[2])));
    h->n = h->ng;
    /* Unit normals first, for meshes and [triangle]s alike: the same
     * triangle shades the same whether written in the scene or loaded from
     * OBJ. */
    rd_vec3 n0, n1, n2;
    int normals = 0;
    if (t->mesh < 0) {
        if (t->face != RD_WTRI_NO_NORMALS) {
            n0 = w->unit_n[t->face];
            n1 = w->unit_n[t->face + 1];
            n2 = w->unit_n[t->face + 2];
            normals = 1;
        }
    } else {
        const rd_mesh_face *f = &w->scene->meshes[t->mesh].faces[t->face];
        if (f->n[0] >= 0 && f->n[1] >= 0 && f->n[2] >= 0) {
            const rd_vec3 *un = w->unit_n + w->mesh_n[t->mesh];
            n0 = un[f->n[0]];
            n1 = un[f->n[1]];
            n2 = un[f->n[2]];
            normals = 1;
        }
    }
    if (normals) {
        rd_vec3 n = v3_normalize(v3_add(v3_add(v3_scale(n0, bc[0]), v3_scale(n1, bc[1])), v3_scale(n2, bc[2])));
        /* Normals that cancel fall back to the geometric one. */
        if (v3_max_abs(n) > 0)
            h->n = n;
    }
    h->material = t->material;
    h->object = t->object;
    memcpy(h->bary, bc, sizeof h->bary);
}

void rd_world_planes_closest(const rd_world *w, rd_ray r, rd_best *b)
{
    for (size_t i = 0; i < w->nplanes; i++) {
        double t = rd_plane_intersect(&w->planes[i], r, b->t);
        if (t > 0)
            rd_best_set(b, t, RD_K_PLANE, i, UINT32_MAX);
    }
}

void rd_world_finish_hit(const rd_world *w, rd_ray r, const rd_best *b, rd_hit *h)
{
    h->t = b->t;
    h->u = h->v = 0;
    if (b->kind == RD_K_SPHERE) {
        rd_sphere_fill_hit(&w->spheres[b->idx], r, h);
        h->n = h->ng;
        h->material = w->sphere_mat[b->idx];
        h->object = w->sphere_obj[b->idx];
    } else if (b->kind == RD_K_PLANE) {
        rd_plane_fill_hit(&w->planes[b->idx], r, h);
        h->n = h->ng;
        h->material = w->plane_mat[b->idx];
        h->object = w->plane_obj[b->idx];
    } else {
        fill_tri(w, b, h);
    }
    h->prim_kind = b->kind;
    /* A triangle's idx is where the walks keep it; h names it by scene. */
    h->prim = b->kind == RD_K_TRI ? b->id - w->nspheres : b->idx;
    h->front = v3_dot(h->ng, r.d) < 0;
    if (v3_dot(h->n, r.d) > 0)
        h->n = v3_neg(h->n);
}

/* The spheres of a world without a BVH, four at a time, in id order (the
 * tie order): each lane's root chosen for the limit of its turn, as the
 * scalar loop would test it. */
__attribute__((noinline, target("avx2"))) static void spheres4_closest(const rd_world *w, const rd_ray *r, rd_best *b)
{
    for (size_t g = 0; g * 4 < w->nspheres; g++) {
        rd_sphere4_roots q;
        for (unsigned ok = rd_sphere4_roots_of(&w->sphere4[g], r, &q); ok; ok &= ok - 1) {
            int lane = __builtin_ctz(ok);
            uint32_t id = (uint32_t)(g * 4) + (uint32_t)lane;
            double t = rd_sphere4_pick(&q, lane, b->limit);
            if (t > 0 && rd_best_takes(b, t, id))
                rd_best_set(b, t, RD_K_SPHERE, id, id);
        }
    }
}

__attribute__((noinline, target("avx2"))) static int spheres4_any(const rd_world *w, const rd_ray *r, double tmax)
{
    for (size_t g = 0; g * 4 < w->nspheres; g++) {
        rd_sphere4_roots q;
        for (unsigned ok = rd_sphere4_roots_of(&w->sphere4[g], r, &q); ok; ok &= ok - 1)
            if (rd_sphere4_pick(&q, __builtin_ctz(ok), tmax) > 0)
                return 1;
    }
    return 0;
}

int rd_world_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h)
{
    rd_best b = rd_best_make(tmax);
    rd_world_planes_closest(w, r, &b);
    if (w->use_bvh) {
        bvh_closest(w, &r, &b);
    } else {
        /* A few primitives: one loop in id order, which is the tie order. */
        size_t first = 0;
        if (w->avx2 && w->sphere4) {
            spheres4_closest(w, &r, &b);
            first = w->nspheres;
        }
        rd_tri_lazy tr = rd_tri_lazy_none();
        for (size_t i = first; i < w->nspheres + w->ntris; i++)
            rd_prim_closest(w, (uint32_t)i, &r, &tr, 0, &b);
    }
    if (b.kind == RD_K_NONE)
        return 0;
    rd_world_finish_hit(w, r, &b, h);
    return 1;
}

void rd_world_hit_uv(const rd_world *w, rd_hit *h)
{
    if (h->prim_kind == RD_K_SPHERE) {
        rd_sphere_uv(&w->spheres[h->prim], h);
    } else if (h->prim_kind == RD_K_PLANE) {
        rd_plane_uv(&w->planes[h->prim], h);
    } else if (h->prim_kind == RD_K_TRI) {
        const rd_wtri *t = rd_world_tri(w, h->prim);
        const double *b = h->bary;
        double uv[3][2] = {{0, 0}, {1, 0}, {0, 1}};
        if (t->mesh < 0) {
            const rd_object *o = &w->scene->objects[t->object];
            if (o->has_uv)
                memcpy(uv, o->uv, sizeof uv);
        } else {
            const rd_mesh *m = &w->scene->meshes[t->mesh];
            const rd_mesh_face *f = &m->faces[t->face];
            if (f->t[0] >= 0 && f->t[1] >= 0 && f->t[2] >= 0)
                for (int c = 0; c < 3; c++) {
                    uv[c][0] = m->uvs[f->t[c]][0];
                    uv[c][1] = m->uvs[f->t[c]][1];
                }
        }
        h->u = b[0] * uv[0][0] + b[1] * uv[1][0] + b[2] * uv[2][0];
        h->v = b[0] * uv[0][1] + b[1] * uv[1][1] + b[2] * uv[2][1];
    }
}

int rd_world_any(const rd_world *w, rd_ray r, double tmax) { return rd_world_any_hint(w, r, tmax, NULL); }

int rd_world_planes_any(const rd_world *w, rd_ray r, double tmax)
{
    for (size_t i = 0; i < w->nplanes; i++)
        if (rd_plane_blocks(&w->planes[i], r, tmax))
            return 1;
    return 0;
}

int rd_world_any_hint(const rd_world *w, rd_ray r, double tmax, uint32_t *last)
{
    if (rd_world_planes_any(w, r, tmax))
        return 1;
    if (w->use_bvh)
        return bvh_any(w, &r, tmax, last);
    if (w->avx2 && w->sphere4) {
        if (spheres4_any(w, &r, tmax))
            return 1;
    } else {
        for (size_t i = 0; i < w->nspheres; i++)
            if (rd_sphere_intersect(&w->spheres[i], r, tmax) > 0)
                return 1;
    }
    if (!w->ntris)
        return 0;
    /* The ray's part of the triangle test once, not once a triangle. */
    rd_tri_ray tr = rd_tri_ray_make(r);
    double bary[3];
    for (size_t i = 0; i < w->ntris; i++)
        if (rd_tri_intersect_ray(w->tris[i].v, &tr, tmax, bary) > 0)
            return 1;
    return 0;
}
