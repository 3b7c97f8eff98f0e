/* The scene's surfaces prepared for tracing: moved into camera-relative
 * coordinates (the eye at the origin, so a far-off scene keeps its
 * precision near the viewer) and answering closest-hit and any-hit queries.
 *
 * Ownership: rd_world_build allocates; rd_world_free releases. */
#ifndef RD_WORLD_H
#define RD_WORLD_H

#include <stddef.h>

#include "error.h"
#include "plane.h"
#include "scene.h"
#include "sphere.h"
#include "triangle.h"

typedef struct {
    rd_sphere *spheres;
    int *sphere_mat, *sphere_obj;
    size_t nspheres;
    rd_plane *planes;
    int *plane_mat, *plane_obj;
    size_t nplanes;
    rd_triangle *tris;
    int *tri_mat, *tri_obj;
    size_t ntris;
    rd_vec3 origin;     /* world position of the camera-relative origin */
} rd_world;

/* Fails (RD_ERR_INVALID) on unresolved materials or degenerate input that
 * validation should already have rejected. */
rd_error_code rd_world_build(rd_world *w, const rd_scene *s, rd_error *err);
void rd_world_free(rd_world *w);

/* A world position in the world's coordinates. */
static inline rd_vec3 rd_world_local(const rd_world *w, rd_vec3 p) { return v3_sub(p, w->origin); }

/* Closest hit with t in (0, tmax); fills h completely, with h->n facing the
 * ray. Returns 1 on a hit. */
int rd_world_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h);

/* 1 when anything lies on the ray at t in (0, tmax). */
int rd_world_any(const rd_world *w, rd_ray r, double tmax);

#endif
