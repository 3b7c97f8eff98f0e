/* A render's progress on stderr, for rayd render and rayd converge.
 *
 * As a bar (stderr a terminal, or --progress): nothing for the first
 * second, then one line redrawn with '\r' at most ten times a second:
 * tiles of the pass done, samples per pixel, the error estimate, time
 * spent and time left; rd_progress_bar_end finishes it with a newline.
 * As lines (stderr not a terminal): one line per pass ended, "LABEL pass
 * N: samples=S error=E ms=T", only when the render has more than one pass,
 * so a fixed render's stderr is only its statistics. --quiet: nothing.
 *
 * Ownership: the caller owns the struct; rd_progress_bar_end releases
 * what init took. The callbacks may run on several render threads. */
#ifndef RD_PROGRESS_BAR_H
#define RD_PROGRESS_BAR_H

#include <pthread.h>

#include "rayd/render.h"

typedef enum { RD_BAR_AUTO, RD_BAR_ON, RD_BAR_OFF } rd_bar_mode;

typedef struct {
    pthread_mutex_t mu;
    int bar, lines;            /* which of the two, or neither */
    const char *label;         /* the line's first word */
    rd_progress_settings goal; /* when the render stops: for the time left */
    double t0, last_draw;
    int drawn;              /* the bar is on screen */
    int pass, pass_samples; /* the pass running */
    int tiles_done, tiles_per_pass;
    double spp_done, error; /* after the passes ended */
} rd_progress_bar;

/* goal: the render's max_samples (its scene's samples), budget and target. */
void rd_progress_bar_init(rd_progress_bar *b, rd_bar_mode mode, const rd_progress_settings *goal, const char *label);

/* Makes ro report to b (its progress, pass and user). */
void rd_progress_bar_attach(rd_progress_bar *b, rd_render_options *ro);

/* Ends the bar's line, if one was drawn. */
void rd_progress_bar_end(rd_progress_bar *b);

#endif
