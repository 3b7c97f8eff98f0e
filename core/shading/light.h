/* Lights prepared for shading: positions in world (camera-relative)
 * coordinates, directions unit, spot cut-offs as cosines. */
#ifndef RD_LIGHT_H
#define RD_LIGHT_H

#include "rayd/scene.h"

typedef struct {
    rd_light_type type;
    rd_rgb color;
    rd_vec3 pos, dir;
    double cos_cutoff, falloff;
    rd_vec3 corner, e1, e2;
    int samples; /* points per hit: 1, or samples² for area lights */
    int side;    /* area: samples per edge */
} rd_light_prep;

typedef struct {
    rd_vec3 L;        /* unit, from the light toward the hit: incomingDir */
    rd_vec3 to_light; /* from the hit to the light point (or -L if infinite) */
    int infinite;     /* directional: the shadow ray has no end */
    rd_rgb color;     /* the light's colour for this sample point */
} rd_light_sample;

/* `origin` is where the world's coordinates have their zero. */
void rd_light_prepare(rd_light_prep *lp, const rd_light *l, rd_vec3 origin);

/* Sample point k of lp->samples as seen from p; ux, uy in [0,1) jitter an
 * area light's cell. Returns 0 when the point gets no light from it (spot
 * cut-off, hit exactly at the light). */
int rd_light_sample_at(const rd_light_prep *lp, rd_vec3 p, int k, double ux, double uy, rd_light_sample *out);

#endif
