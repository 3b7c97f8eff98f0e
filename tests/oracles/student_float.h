/* A second, independent implementation of the course renderer, written the
 * way a student writes it from ../shared/spec/shading.md: single precision
 * everywhere (vectors, intersections, shading), a brute-force loop over the
 * objects, hard shadows that ignore hits closer than a small fixed epsilon
 * (the "t_min = 0.001" habit of ray tracing tutorials), per-material
 * ambient, Whitted recursion with exact Fresnel, and the output rule
 * clamp -> gamma -> floor(c·255 + 0.5).
 *
 * Only the scene reading is shared with rayd (rd_scene_load_file and
 * rd_scene_load_assets fill the rd_scene this takes); nothing of core/ is
 * called or copied. The grading calibration (test_grading_calibration.c)
 * uses it as "a correct student in float" and, with bug flags, as typical
 * wrong students.
 *
 * Where shading.md is silent a student has to guess; this one guesses like
 * rayd does (see the comments at plane_uv and texture_bilinear), so that the
 * calibration measures float error, not guesses. */
#ifndef SF_STUDENT_FLOAT_H
#define SF_STUDENT_FLOAT_H

#include <stdint.h>

#include "rayd/scene.h"

/* Typical student mistakes, one bit each; 0 is a correct student. */
typedef enum {
    SF_CORRECT = 0,
    /* kd·(-N·L) without max(·,0), and no "whole term 0 behind the surface"
     * early exit: a light behind the surface subtracts light. */
    SF_BUG_NO_MAX_COS = 1u << 0,
    /* Phong's R = -reflect(L, N) (the sign of the course's reflect() taken
     * the wrong way round). Only the Phong lobe (phong, textured_phong); the
     * mirror and glass directions stay right. */
    SF_BUG_REFLECT_SIGN = 1u << 1,
    /* max(N·H, 0)^n with Blinn's H = normalize(V - L) where Phong's
     * max(R·V, 0)^n belongs (phong, textured_phong). */
    SF_BUG_BLINN_FOR_PHONG = 1u << 2,
    /* shininess / 2 in every lobe that has one (phong, blinn_phong,
     * textured_phong). */
    SF_BUG_SHININESS_HALVED = 1u << 3,
    /* The unit vector from the surface to the light passed as incomingDir
     * (the course's incomingDir points from the light to the surface). */
    SF_BUG_LIGHT_REVERSED = 1u << 4,
    /* The material's ambient never added. */
    SF_BUG_NO_AMBIENT = 1u << 5,
    /* The ambient added inside the light loop: once per light (whether the
     * light is shadowed or not) instead of once per hit. */
    SF_BUG_AMBIENT_PER_LIGHT = 1u << 6,
    /* clamp(c)^(1/gamma) applied twice. */
    SF_BUG_GAMMA_TWICE = 1u << 7,
} sf_bug;

#define SF_BUG_COUNT 8

/* Short name of one bug bit ("no_max_cos"), "correct" for 0, NULL for
 * anything else. */
const char *sf_bug_name(unsigned bug);

/* Renders s (assets loaded) as its render section says, with the given
 * bugs, into *rgb: malloc'ed 8-bit RGB, rows top first, 3 bytes a pixel.
 * samples > 1 uses a regular grid of sub-pixel centres (not rayd's jitter;
 * the assignments use 1). Area lights use their cell centres (likewise).
 * Returns 0, or -1 when out of memory or the scene has an object without a
 * material or a textured material without its texture. */
int sf_render(const rd_scene *s, unsigned bugs, uint8_t **rgb, int *width, int *height);

/* The student's self-intersection guard: hits closer than this along any
 * ray are ignored, so shadow, reflected and refracted rays can start on the
 * surface they leave. 1e-3 is the tutorials' usual value; with 1e-4 a float
 * hit point, a few 1e-5 inside a sphere 9 units away, shadows itself in a
 * band along the terminator (shadow acne). */
#define SF_EPS_DEFAULT 1e-3f

/* sf_render with another guard (> 0). */
int sf_render_eps(const rd_scene *s, unsigned bugs, float eps, uint8_t **rgb, int *width, int *height);

#endif
