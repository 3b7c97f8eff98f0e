#include "progress_bar.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "rayd/clock.h"

enum { QUIET_MS = 1000, REDRAW_MS = 100, BAR_CELLS = 20 };

void rd_progress_bar_init(rd_progress_bar *b, rd_bar_mode mode, const rd_progress_settings *goal, const char *label)
{
    memset(b, 0, sizeof *b);
    pthread_mutex_init(&b->mu, NULL);
    int tty = isatty(STDERR_FILENO);
    b->bar = mode == RD_BAR_ON || (mode == RD_BAR_AUTO && tty);
    b->lines = mode == RD_BAR_AUTO && !tty;
    b->goal = *goal;
    b->label = label;
    b->t0 = rd_now_ms();
}

/* Samples per pixel so far, counting the running pass's tiles done. */
static double spp_now(const rd_progress_bar *b)
{
    double part = b->tiles_per_pass > 0 ? (double)b->tiles_done / b->tiles_per_pass : 0;
    return b->spp_done + b->pass_samples * part;
}

/* Milliseconds left by the first stop rule expected to hold, from the time
 * per sample so far (the error falls as 1/sqrt(samples)); -1: unknown. */
static double ms_left(const rd_progress_bar *b, double elapsed)
{
    double spp = spp_now(b);
    if (spp <= 0)
        return -1;
    double per = elapsed / spp, cap = b->goal.max_samples > 0 ? b->goal.max_samples : spp;
    if (!rd_progress_is_progressive(&b->goal))
        cap = b->pass_samples;
    double left = (cap - spp) * per;
    if (b->goal.target_error > 0 && b->error > 0 && b->spp_done >= 2) {
        double need = b->spp_done * (b->error / b->goal.target_error) * (b->error / b->goal.target_error);
        if ((need - spp) * per < left)
            left = (need - spp) * per;
    }
    if (b->goal.time_budget_ms > 0 && b->goal.time_budget_ms - elapsed < left)
        left = b->goal.time_budget_ms - elapsed;
    return left > 0 ? left : 0;
}

/* Under b->mu. */
static void draw(rd_progress_bar *b, double now)
{
    double elapsed = now - b->t0, left = ms_left(b, elapsed);
    double done = left < 0 ? 0 : elapsed / (elapsed + left + 1e-9);
    char cells[BAR_CELLS + 1];
    for (int i = 0; i < BAR_CELLS; i++)
        cells[i] = i < (int)(done * BAR_CELLS + 0.5) ? '#' : '-';
    cells[BAR_CELLS] = 0;
    char eta[16] = "?", est[16] = "-";
    if (left >= 0)
        snprintf(eta, sizeof eta, "%.1fs", left / 1e3);
    if (b->spp_done >= 2) /* the estimate needs two samples of a pass ended */
        snprintf(est, sizeof est, "%.6f", b->error);
    fprintf(stderr, "\r%s [%s] %3.0f%% pass %d tiles %d/%d spp %.1f err %s %.1fs left %-8s", b->label, cells,
            done * 100, b->pass + 1, b->tiles_done, b->tiles_per_pass, spp_now(b), est, elapsed / 1e3, eta);
    fflush(stderr);
    b->drawn = 1;
    b->last_draw = now;
}

/* Under b->mu: redraws when it is time to. */
static void maybe_draw(rd_progress_bar *b)
{
    double now = rd_now_ms();
    if (b->bar && now - b->t0 >= QUIET_MS && now - b->last_draw >= REDRAW_MS)
        draw(b, now);
}

static void on_tile(void *user, int tiles_done, int tiles_total)
{
    rd_progress_bar *b = user;
    pthread_mutex_lock(&b->mu);
    /* Counts run on across passes; a pass is tiles_total of them. */
    int in_pass = tiles_total > 0 ? (tiles_done - 1) % tiles_total + 1 : 0;
    if (in_pass > b->tiles_done || tiles_total != b->tiles_per_pass)
        b->tiles_done = in_pass;
    b->tiles_per_pass = tiles_total;
    maybe_draw(b);
    pthread_mutex_unlock(&b->mu);
}

static void on_pass(void *user, int pass, int samples, const rd_curve_point *ended)
{
    rd_progress_bar *b = user;
    pthread_mutex_lock(&b->mu);
    /* A pass's line waits for the next pass to begin: a render of one pass
     * prints none. */
    if (b->lines && ended && (samples > 0 || pass >= 2))
        fprintf(stderr, "%s pass %d: samples=%g error=%.6f ms=%.3f\n", b->label, pass, ended->samples, ended->error,
                ended->ms);
    if (ended) {
        b->spp_done = ended->samples;
        b->error = ended->error;
    }
    b->pass = samples > 0 ? pass : b->pass;
    b->pass_samples = samples;
    b->tiles_done = samples > 0 ? 0 : b->tiles_done;
    maybe_draw(b);
    pthread_mutex_unlock(&b->mu);
}

void rd_progress_bar_attach(rd_progress_bar *b, rd_render_options *ro)
{
    ro->progress = on_tile;
    ro->pass = on_pass;
    ro->user = b;
}

void rd_progress_bar_end(rd_progress_bar *b)
{
    pthread_mutex_lock(&b->mu);
    if (b->drawn) {
        draw(b, rd_now_ms());
        fputc('\n', stderr);
    }
    pthread_mutex_unlock(&b->mu);
    pthread_mutex_destroy(&b->mu);
}
