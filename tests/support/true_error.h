/* The true error of a render as `rayd converge` measures it
 * (daemon/cli/cmd_converge.c): the RMSE of its display values against a
 * converged reference of the same scene, with the reference's own
 * estimated error taken out in quadrature. For the Criterion suites. */
#ifndef RD_TEST_TRUE_ERROR_H
#define RD_TEST_TRUE_ERROR_H

#include "rayd/render.h"
#include "rayd/scene.h"

/* The display values rd_display(v, gamma) of every channel (malloc'ed). */
double *display_values(const rd_image *img, double gamma);

/* RMSE of the image's display values against display values ref. */
double rmse_display(const rd_image *img, const double *ref, double gamma);

/* sqrt(rmse² - ref_estimate²), or 0 when the reference's own error
 * accounts for all of the RMSE. */
double true_error(const rd_image *img, const double *ref, double ref_estimate, double gamma);

/* Renders s with `samples` samples and seed + 0x5eed on two threads, then
 * puts the scene's samples and seed back. Another seed than the renders it
 * judges: with the same one a render and its reference would share the
 * area-light jitter of their first samples. Returns the reference's display
 * values (malloc'ed); *st gets its statistics (error_estimate, wall_ms). */
double *render_reference(rd_scene *s, int samples, rd_render_stats *st);

#endif
