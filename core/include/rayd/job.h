/* A render cut into tiles and passes, for callers that schedule the work
 * themselves (rd_render's threads, the daemon's shared pool).
 *
 * Each pixel keeps a running mean of its samples' colour and, for the error
 * estimate, a Welford mean and sum of squared deviations of their display
 * values. A pass adds a number of samples to every pixel of a tile; the
 * samples of pass p depend only on (seed, pixel, p), so the result does not
 * depend on which thread renders which tile or in what order.
 *
 * Ownership: rd_job_create allocates; rd_job_free releases. The scene must
 * outlive the job. Distinct tiles of one pass may be rendered concurrently;
 * a tile's passes must run in order. */
#ifndef RD_JOB_H
#define RD_JOB_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"
#include "rayd/image.h"
#include "rayd/progress.h"
#include "rayd/scene.h"
#include "rayd/stats.h"

typedef struct rd_job rd_job;

typedef struct {
    uint64_t camera, shadow, secondary, nonfinite;
} rd_job_counts;

/* The default tile edge in pixels: the grain of scheduling and of fair
 * share between jobs. */
#define RD_JOB_TILE 16

typedef struct {
    int tile; /* edge in pixels; < 1 means RD_JOB_TILE */
    /* The schedule of passes (progress.h); all zero: one pass of the
     * scene's samples. max_samples < 1 means the scene's samples. A
     * progressive schedule jitters every pass, even a first pass of one
     * sample; an adaptive one gives later passes' samples to noisier
     * pixels. */
    rd_progress_settings progress;
    /* Threads that may build the BVH (the same tree whatever the number);
     * < 1 means 1. */
    int build_threads;
    /* Rays traced in packets of the pixels of a 4x4 block (RD_PACKETS_*
     * bits; 0: ray by ray): the same image and counts to the bit, at
     * another speed (bench/README.md measures it). Only a world with a
     * BVH is walked in packets. */
    unsigned packets;
    /* Optional (NULL: none): the caller's width·height·3 bytes, which it
     * frees after the job. A render of one pass of one sample, neither
     * progressive nor adaptive, then writes each pixel's 8-bit value
     * straight into them and keeps no linear image and no per-pixel
     * counts (28 bytes a pixel, fresh pages the kernel must clear): it has
     * no image to take, no tile state and only a first pass. Other renders
     * leave the bytes alone until rd_job_rgb8 is asked for them. */
    uint8_t *rgb8;
} rd_job_options;

/* The camera rays' closest hits, and the shadow rays towards each point,
 * spot or directional light. */
enum { RD_PACKETS_CAMERA = 1, RD_PACKETS_SHADOW = 2 };

/* The most memory a job of this scene holds, in bytes: the scene itself,
 * its world and BVH (with what building them needs), the per-pixel state
 * the options call for, and an 8-bit copy of the image. Computed from the
 * layouts before anything is allocated, for admission against a budget;
 * the scene's meshes must be loaded. */
size_t rd_job_estimate_bytes(const rd_scene *s, const rd_job_options *opt);

rd_error_code rd_job_create(const rd_scene *s, const rd_job_options *opt, rd_job **out, rd_error *err);
void rd_job_free(rd_job *j);

int rd_job_tile_count(const rd_job *j);
int rd_job_width(const rd_job *j);
int rd_job_height(const rd_job *j);

/* The passes, for every caller that schedules tiles (rd_render's threads,
 * the daemon's pool): rd_job_first_pass starts the first and returns its
 * samples per pixel; once every tile of a pass is rendered (and none is
 * being rendered: it reads every pixel), rd_job_end_pass takes the error
 * estimate, adds a point to the error-against-time curve (time since
 * rd_job_create began), and starts the next pass as the schedule says,
 * returning its samples, or 0 when the render is complete. A pass's
 * samples are per pixel, on average when adaptive. */
int rd_job_first_pass(rd_job *j);
int rd_job_end_pass(rd_job *j);

/* Samples per pixel of the current pass, and of the passes ended. */
int rd_job_pass_samples(const rd_job *j);
int rd_job_samples_done(const rd_job *j);

/* What the job measured: the plan's figures, the passes ended, the curve,
 * the last error estimate, the mean samples (0 before a pass has ended)
 * and the stop rule that held.
 * Rays, threads and wall time are the caller's (rd_stats_add_counts). */
void rd_job_stats(const rd_job *j, rd_render_stats *st);

/* Rays traced and the time they took, with the rays per second. */
void rd_stats_add_counts(rd_render_stats *st, const rd_job_counts *c, double wall_ms);

/* Adds the current pass's samples to every pixel of tile t; returns 1, or
 * 0 when the deadline passed before it finished. With one pass of
 * one sample and not progressive, the sample goes through the pixel centre;
 * otherwise a pixel's samples in a pass are correlated multi-jittered.
 * Adaptive passes after the first give pixel i about
 * samples·(1/2 + 1/2·w_i/mean(w)) samples, w_i = s_i²/n_i² (the drop in its
 * variance one more sample buys), at most 64·samples. */
int rd_job_render_tile(rd_job *j, int t, rd_job_counts *counts);

/* Stops rendering once the monotonic clock passes deadline_ms (see
 * rd_now_ms; 0 = never), or once *cancel becomes non-zero (NULL = never;
 * the flag must outlive the job). Both are looked at about once a
 * millisecond of tracing, inside the sample, light and recursion loops
 * (trace.h), so a stop takes effect within a few milliseconds whatever the
 * scene. rd_job_render_tile then returns 0 and the tile is incomplete. */
void rd_job_set_deadline(rd_job *j, double deadline_ms);
void rd_job_set_cancel(rd_job *j, const atomic_int *cancel);

/* Mean samples per pixel so far. */
double rd_job_mean_samples(const rd_job *j);

/* Moves the mean colours out as the image (no copy; free it with
 * rd_image_free). Pixels with no sample yet are black. The job then has no
 * pixels left: it still answers its size, samples, estimate and statistics,
 * but must not render tiles or give bytes (rd_job_rgb8, rd_job_tile_rgb8).
 * A job writing 8-bit pixels straight (rd_job_options.rgb8) gives an
 * empty image. */
void rd_job_take_image(rd_job *j, rd_image *out);

/* 8-bit RGB of the image so far, without a linear copy: width·height·3
 * bytes (rd_image_to_rgb8's). out may be the job's rd_job_options.rgb8. */
void rd_job_rgb8(const rd_job *j, uint8_t *out);

/* Writes tile t's pixels into out, a whole width·height·3 RGB8 image. */
void rd_job_tile_rgb8(const rd_job *j, int t, uint8_t *out);

/* Root-mean-square standard error of the pixel means (see render.h), over
 * every pixel, summed in pixel order. Pixels with fewer than 2 samples
 * contribute 0. */
double rd_job_error_estimate(const rd_job *j);

/* A tile's pixels as bytes, so that another process holding a job of the
 * same scene and options goes on rendering it or assembles the image (a
 * render farm, a job resumed after a crash). The layout is the core's
 * per-pixel arrays in this machine's byte order, one after another (mean,
 * count, then the half-sets' means and counts and the display statistics
 * when the job keeps them), each over the tile's pixels in row order: the
 * same build on the same architecture reads it. rd_job_tile_state_bytes is
 * the exact size (0 for no such tile); rd_job_tile_state_save writes it to
 * out; rd_job_tile_state_load replaces the tile's pixels with it, after
 * checking it (RD_ERR_INVALID for a wrong size, a non-finite value, display
 * statistics out of their range, counts that disagree or more samples than
 * the schedule gives; linear colours may be negative, as a scene's can be).
 * Bytes from a store are read as hostile: a rejected state leaves the tile
 * as it was. */
size_t rd_job_tile_state_bytes(const rd_job *j, int t);
void rd_job_tile_state_save(const rd_job *j, int t, void *out);
rd_error_code rd_job_tile_state_load(rd_job *j, int t, const void *in, size_t len, rd_error *err);

/* Where the schedule of passes stands, so that the process that ends a
 * pass tells the others how the next one runs. */
typedef struct {
    int pass;           /* the pass in progress, 0-based */
    int pass_samples;   /* its samples per pixel */
    double mean_weight; /* adaptive: mean of w_i at its start (rd_job_render_tile) */
    int spp, passes_done;
    double error;
    double last_pass_ms;
    rd_stop_reason stopped_by;
    rd_curve_point curve[RD_CURVE_MAX];
    int curve_len;
} rd_job_schedule;

void rd_job_schedule_get(const rd_job *j, rd_job_schedule *out);

/* Puts the job where sc says (RD_ERR_INVALID for values out of range: a
 * negative pass, samples < 1 or over the cap, passes done other than pass
 * (a pass in progress, no stop reason) or pass + 1 (the last pass ended, a
 * stop reason), a curve without one point for each pass ended (up to
 * RD_CURVE_MAX), a non-finite number, a negative time, error or curve figure, a mean
 * weight where the pass takes none). Tiles rendered after it render pass
 * sc->pass with sc's mean weight: the job's own pixels are not read, so
 * those of tiles rendered elsewhere may be stale. A tile rendered in a
 * pass after the first must hold its latest state, rendered here or
 * loaded. */
rd_error_code rd_job_schedule_set(rd_job *j, const rd_job_schedule *sc, rd_error *err);

/* rd_job_end_pass with the caller's clock: elapsed_ms since the render
 * began, pass_ms the pass just ended took (several processes rendered it). */
int rd_job_end_pass_at(rd_job *j, double elapsed_ms, double pass_ms);

/* Time the plan took to build, BVH figures, memory: for statistics, as
 * soon as the job exists. */
void rd_job_plan_stats(const rd_job *j, rd_render_stats *st);

#endif
