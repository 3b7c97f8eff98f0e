/* Checking a student's calcReflectedLight from its values at the fixed
 * configurations (code_cases.h; docs/grading.md, "Grading code: the
 * configurations"): each value against rayd's (rd_reflected_light), and
 * the failures explained by at most a few named causes, each in words for
 * the student with an example. */
#ifndef RD_CODE_CHECK_H
#define RD_CODE_CHECK_H

#include <cJSON.h>
#include <stddef.h>

#include "code_cases.h"

/* How the call of one configuration ended. */
typedef enum { RD_CODE_RETURNED, RD_CODE_CRASHED, RD_CODE_EXITED, RD_CODE_TIMED_OUT, RD_CODE_NOT_RUN } rd_code_status;

typedef struct {
    rd_rgb got; /* what it returned (RETURNED only) */
    int status; /* rd_code_status */
} rd_code_value;

/* A value is right when every channel is finite and within
 * RD_CODE_ABS_TOL + RD_CODE_REL_TOL * |expected| (code_check.c says why). */
#define RD_CODE_ABS_TOL 2e-5
#define RD_CODE_REL_TOL 1e-3

#define RD_CODE_MAX_CAUSES 4

typedef struct {
    const char *cause; /* a stable id: "missing_max", "crashed", ... (static) */
    const char *words; /* what is wrong and what to write instead (static) */
    size_t count;      /* configurations it explains */
    size_t example;    /* index of one of them */
} rd_code_cause;

typedef struct {
    int pass; /* every configuration right */
    size_t configurations, failed;
    size_t not_finite, crashed, exited, timed_out, not_run;
    size_t group_total[RD_CODE_GROUPS], group_failed[RD_CODE_GROUPS];
    rd_code_cause causes[RD_CODE_MAX_CAUSES]; /* the most urgent first */
    int ncauses;
} rd_code_report;

/* Checks n values against their configurations; fills *r. */
void rd_code_check(const rd_code_case *c, const rd_code_value *v, size_t n, rd_code_report *r);

/* Whether one value is right (finite and within the tolerance). */
int rd_code_value_ok(const rd_code_case *c, const rd_code_value *v);

/* The report as JSON, each cause's example with its configuration, the
 * expected and the returned values; NULL when out of memory. c and v are
 * the report's. The caller deletes it. */
cJSON *rd_code_report_json(const rd_code_report *r, const rd_code_case *c, const rd_code_value *v);

#endif
