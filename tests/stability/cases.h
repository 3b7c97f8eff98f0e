/* The numerical-stability suite of rayd: a table of cases, each a scene (or
 * a few) under scenes/extreme/, a property in one sentence, and a function
 * that renders, measures the worst error against that property and decides
 * pass or fail against a stated tolerance. The cases are listed once, in
 * tests/stability/case_list.h; rd_cases is that list as a table.
 *
 * Used by tests/stability/test_stability.c (one Criterion test per case) and by
 * tests/stability/report.c (`make stability`: writes docs/stability.md).
 * No main() and no Criterion here. Scene paths are relative to
 * rd_stability_scene_dir, "scenes/extreme" by default: run from the
 * repository root. */
#ifndef RD_STABILITY_CASES_H
#define RD_STABILITY_CASES_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    double worst;        /* the measured worst error, in the case's unit */
    int pass;            /* worst <= tolerance, no error, nothing non-finite, no extra failure */
    int error;           /* a scene failed to load or render (message in detail) */
    int extra_fail;      /* a secondary condition of the property failed (said in detail) */
    uint64_t nonfinite;  /* sum of rd_render_stats.nonfinite over every render */
    uint64_t bad_values; /* non-finite values found in rendered images (rd_image.rgb) */
    int renders;         /* rd_render calls */
    double ms;           /* wall time of the case */
    char detail[2048];   /* what was measured, for the report and failure messages */
} rd_case_result;

typedef struct {
    const char *name;     /* identifier: the Criterion test's name */
    const char *group;    /* the case class (scale, geometry, triangles, ...) */
    const char *scenes;   /* scene files under scenes/extreme/, or what is called */
    const char *property; /* one sentence */
    const char *unit;     /* of worst and tolerance */
    double tolerance;     /* pass when worst <= tolerance */
    const char *why_tol;  /* why that tolerance */
    /* Known cause and proposed fix, printed in the report when the case
     * fails (NULL when none is known). */
    const char *analysis;
    void (*run)(rd_case_result *r);
} rd_case;

extern const rd_case rd_cases[];
extern const size_t rd_case_count;

/* Folder of the scenes; "scenes/extreme" unless set before running. */
extern const char *rd_stability_scene_dir;
/* Threads per render (the bytes do not depend on it); 1 unless set. */
extern int rd_stability_threads;

const rd_case *rd_case_find(const char *name);

/* Runs one case: fills *r (zeroed first), sets r->pass. */
void rd_case_run(const rd_case *c, rd_case_result *r);

#endif
