/* Progressive rendering: which pass comes next, and when to stop.
 *
 * A fixed render is one pass of `samples` samples per pixel. A progressive
 * render (a time budget or a target error was asked for) runs passes of
 * 2, 2, 4, 8, ... samples per pixel (doubling the total each time, the
 * first pass giving every pixel the two samples an error estimate needs)
 * until one of the stop rules holds, whichever comes first:
 *   - `samples` per pixel have been taken;
 *   - not even one more sample per pixel fits in `time_budget_ms`
 *     (prediction: the last pass's time per sample); a doubled pass that
 *     would not fit is shrunk to the samples that do;
 *   - the error estimate is at or below `target_error`.
 * The first pass always runs. The decision uses only the numbers given, so
 * the same history gives the same schedule. */
#ifndef RD_PROGRESS_H
#define RD_PROGRESS_H

typedef enum {
    RD_STOP_NONE = 0,
    RD_STOP_SAMPLES,
    RD_STOP_TIME_BUDGET,
    RD_STOP_TARGET_ERROR,
    RD_STOP_CANCELLED
} rd_stop_reason;

const char *rd_stop_reason_name(rd_stop_reason r);

typedef struct {
    int max_samples;       /* the scene's samples: the cap */
    double time_budget_ms; /* <= 0: none */
    double target_error;   /* <= 0: none */
    int adaptive;          /* later passes follow the error */
} rd_progress_settings;

/* One point of the error-against-time curve, taken after a pass. */
typedef struct {
    double ms;      /* since the render started (plan included) */
    double samples; /* mean per pixel so far */
    double error;   /* the estimate then */
} rd_curve_point;

#define RD_CURVE_MAX 64

/* Whether settings ask for more than one fixed pass. */
int rd_progress_is_progressive(const rd_progress_settings *p);

/* Samples per pixel of the next pass, or 0 to stop (*why says which rule).
 * done: passes finished; spp: samples per pixel so far; last_pass_ms and
 * last_pass_spp: the latest pass's duration and samples; elapsed_ms since
 * the start; error: the estimate now. */
int rd_progress_next(const rd_progress_settings *p, int done, int spp, double last_pass_ms, int last_pass_spp,
                     double elapsed_ms, double error, rd_stop_reason *why);

#endif
