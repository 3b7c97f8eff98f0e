/* The reflected light across the plane of incidence (the LOBE
 * configurations of code_cases.h) as an SVG plot: rayd's curve and the
 * student's, against the eye's angle from the normal. */
#ifndef RD_CODE_LOBE_H
#define RD_CODE_LOBE_H

#include <stddef.h>

#include "code_check.h"

/* A self-contained SVG (no script), malloc'ed for the caller to free;
 * NULL when out of memory or when c has no LOBE configuration. Values
 * that did not return or are not finite are left out of the student's
 * curve, and the plot's scale is bounded so one huge value keeps the
 * reference readable. */
char *rd_code_lobe_svg(const rd_code_case *c, const rd_code_value *v, size_t n);

#endif
