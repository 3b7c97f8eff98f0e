/* A small log-log line plot written as SVG text, for error-against-time
 * curves. No dependencies, no I/O. */
#ifndef RD_SVG_PLOT_H
#define RD_SVG_PLOT_H

#include <stddef.h>

typedef struct {
    const char *label;
    const char *color;
    int dashed;
    const double *x, *y;
    size_t n;
} rd_svg_series;

/* A malloc'ed SVG document (caller frees), or NULL. Points with x or y <= 0
 * are left out (log axes). */
char *rd_svg_loglog(const char *title, const char *xlabel, const char *ylabel, const rd_svg_series *series,
                    size_t nseries);

#endif
