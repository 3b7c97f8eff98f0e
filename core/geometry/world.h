/* The scene's surfaces prepared for tracing: moved into camera-relative
 * coordinates (the eye at the origin, so a far-off scene keeps its
 * precision near the viewer), bounded ones (spheres, triangles) in a BVH
 * once there are more than a few, planes tested on their own.
 *
 * Ownership: rd_world_build allocates; rd_world_free releases. The scene
 * must outlive the world (triangles refer back to its meshes). */
#ifndef RD_WORLD_H
#define RD_WORLD_H

#include <stddef.h>
#include <stdint.h>

#include "bvh.h"
#include "bvh4.h"
#include "plane.h"
#include "rayd/error.h"
#include "rayd/scene.h"
#include "sphere.h"
#include "triangle.h"

/* Below this many bounded primitives a plain loop beats the BVH. */
#define RD_WORLD_BVH_MIN 8

/* A triangle as the tracer needs it: its corners, and where its shading
 * attributes live (an explicit [triangle] object, or a mesh face). */
typedef struct {
    rd_vec3 v[3];
    int32_t material;
    int32_t object; /* the scene object it came from */
    int32_t mesh;   /* -1 for a [triangle]; else index into scene->meshes */
    /* The mesh face; for a [triangle], where its three normals start in
     * rd_world.unit_n, or RD_WTRI_NO_NORMALS. */
    uint32_t face;
} rd_wtri;

#define RD_WTRI_NO_NORMALS UINT32_MAX

typedef struct {
    const rd_scene *scene;
    rd_sphere *spheres;
    struct rd_sphere4_s *sphere4; /* without a BVH: the spheres in packs of four (sphere4.h), or NULL */
    int32_t *sphere_mat, *sphere_obj;
    size_t nspheres;
    rd_plane *planes;
    int32_t *plane_mat, *plane_obj;
    size_t nplanes;
    /* Without a BVH, in scene order. With one, in the order its leaves
     * name them: the triangle at position p of bvh.prims is tris[p -
     * tri_first], so a leaf's triangles lie together and are read without
     * an index (tri_first is the first triangle's position; slots of
     * spheres between triangles, in a world of both, are unused);
     * tri_pos[k] is where scene triangle k went, of tri_slots slots.
     * rd_world_tri finds one by scene index. */
    rd_wtri *tris;
    size_t ntris;
    uint32_t *tri_pos;
    size_t tri_first, tri_slots;
    /* With a BVH and spheres: the same for sphere4.h, from position
     * sph_first on: centres' x, y, z and radii in four runs of sph_n
     * (the last lanes of the last leaf included) from sph; a triangle's
     * slot has a NaN radius. */
    double *sph;
    size_t sph_first, sph_n;
    /* The shading normals at unit length, normalized once here instead of
     * on every hit (the same bits: the same function of the same input,
     * once for a normal that faces share): three per [triangle] that has
     * them, then every mesh's, mesh m's from unit_n + mesh_n[m] on in its
     * own order. Both the world's, freed by rd_world_free; NULL when the
     * scene has none. */
    rd_vec3 *unit_n;
    size_t nunit_n;
    size_t *mesh_n;
    rd_bvh bvh;   /* over spheres (ids < nspheres) then triangles; only its prims are kept */
    rd_bvh4 bvh4; /* the same, four children a node: what rays walk */
    int avx2;     /* walk it with the AVX2 box test, test spheres four at a time */
    int avx512;   /* and packets with eight rays to an AVX-512 register */
    int use_bvh;
    rd_vec3 origin;  /* world position of the camera-relative origin */
    double build_ms; /* time spent building the BVH */
} rd_world;

/* Fails (RD_ERR_INVALID) on unresolved materials or meshes the loader has
 * not filled in. */
rd_error_code rd_world_build(rd_world *w, const rd_scene *s, rd_error *err);

/* The same, building the BVH on up to `threads` threads (the same tree). */
rd_error_code rd_world_build_threads(rd_world *w, const rd_scene *s, int threads, rd_error *err);

/* The bounds the BVH is built over, of spheres then triangles (nspheres +
 * ntris entries each, the caller's). */
void rd_world_bounds(const rd_world *w, rd_vec3 *lo, rd_vec3 *hi);
/* Of primitives [first, first + count) only, into lo[0..count). */
void rd_world_bounds_of(const rd_world *w, size_t first, size_t count, rd_vec3 *lo, rd_vec3 *hi);
void rd_world_free(rd_world *w);

/* Bytes the world holds (surfaces, BVH nodes and indices). */
size_t rd_world_bytes(const rd_world *w);

/* Where scene triangle k (its BVH id less nspheres) is in w->tris. */
static inline size_t rd_world_tri_slot(const rd_world *w, size_t k) { return w->tri_pos ? w->tri_pos[k] : k; }

static inline const rd_wtri *rd_world_tri(const rd_world *w, size_t k) { return &w->tris[rd_world_tri_slot(w, k)]; }

/* A world position in the world's coordinates. */
static inline rd_vec3 rd_world_local(const rd_world *w, rd_vec3 p) { return v3_sub(p, w->origin); }

/* Closest hit with t in (0, tmax); fills h except u and v (see
 * rd_world_hit_uv), with h->n facing the ray. Returns 1 on a hit. */
int rd_world_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h);

/* Texture coordinates of a hit, computed only for materials that use them. */
void rd_world_hit_uv(const rd_world *w, rd_hit *h);

/* 1 when anything lies on the ray at t in (0, tmax); stops at the first. */
int rd_world_any(const rd_world *w, rd_ray r, double tmax);

/* The same, trying first the leaf *last names (0: none; else a value this
 * function left there) and leaving there the leaf that blocked this ray,
 * or 0 when the BVH held none. Shadow rays towards one light from
 * neighbouring points are mostly blocked by the same occluder (POV-Ray's
 * light buffer), and mostly not at all where the previous one was not. A
 * leaf is tried only when the ray's own box test accepts it, as the walk
 * would, so the answer is the same with or without the hint: a primitive's
 * test can report a grazing hit outside its box, which the walk never
 * asks for. */
int rd_world_any_hint(const rd_world *w, rd_ray r, double tmax, uint32_t *last);

/* The hint naming child `slot` of four-wide node `node`. */
static inline uint32_t rd_world_hint(uint32_t node, int slot) { return (node << 2 | (uint32_t)slot) + 1; }

/* Packets of coherent rays (packet.c): camera rays through neighbouring
 * pixels, or shadow rays from neighbouring hits towards one light. Each
 * ray's answer is exactly the one the single-ray function gives it; a
 * packet saves the walk of the nodes all its rays pass through. */
#define RD_PACKET_MAX 16

/* rd_world_closest for r[0..n), n at most RD_PACKET_MAX: bit i of the
 * result set when ray i hit, and h[i] filled then. */
unsigned rd_world_closest_packet(const rd_world *w, const rd_ray *r, int n, double tmax, rd_hit *h);

/* rd_world_any_hint for r[0..n) within tmax[0..n): bit i set when ray i is
 * blocked. *last (may be NULL) is tried first by every ray and left at a
 * leaf that blocked one of them, or 0 when none did. */
unsigned rd_world_any_packet(const rd_world *w, const rd_ray *r, const double *tmax, int n, uint32_t *last);

#endif
