#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "compare.h"
#include "file_io.h"
#include "png_read.h"
#include "png_write.h"
#include "progress_bar.h"
#include "rayd/render.h"
#include "scene_open.h"
#include "strbuf.h"
#include "svg_plot.h"

static const char converge_help[] =
    "usage: rayd converge SCENE [--reference REF.png | --reference-samples N] [options]\n"
    "\n"
    "Renders SCENE at 1, 2, 4, ... samples per pixel and prints, for each, the\n"
    "time, the error estimate the renderer reports, and the true error: the RMSE\n"
    "of its display values (after clamp and gamma, 1 = 255 levels) against a\n"
    "converged reference. The reference is REF.png, or a render of N samples\n"
    "(default 256) whose own estimated error is taken out in quadrature. Ends\n"
    "with the fitted log-log slopes of both errors against samples.\n"
    "\n"
    "Unless --width or --height is given, it renders at half the scene's width\n"
    "and height, so that the default run takes well under a minute; the full\n"
    "measure is e.g. --width 640 --height 480 --reference-samples 1024.\n"
    "\n"
    "  --max-samples N        the last row (default 64)\n"
    "  --reference REF.png    compare with this image (same size as the render)\n"
    "  --reference-samples N  render the reference with N samples (default 256)\n"
    "  --limit-...  N         a size limit; 'rayd limits' lists them with defaults\n"
    "  --threads N            render threads (default: the number of cores)\n"
    "  --adaptive             use adaptive passes (each row a progressive render)\n"
    "  --svg FILE             write the error-against-time plot as SVG\n"
    "  --csv FILE             write the table as CSV\n"
    "  --progress, --quiet    the progress bar of each render on stderr even when\n"
    "                         it is not a terminal, or never (the table is on\n"
    "                         stdout, a row as soon as it is measured)\n"
    "\n";

/* The row count and the reference set the samples. */
static const char *const converge_sets[] = {"samples", NULL};

typedef struct {
    long max_samples, ref_samples, threads;
    const char *path, *ref_path, *svg, *csv;
    int adaptive;
    rd_bar_mode bar;
    rd_scene_limits lim;
    rd_scene_overrides ov;
} converge_args;

enum { HELP_PRINTED = -1, MAX_ROWS = 32 };

/* The table: one row per sample count. */
typedef struct {
    int n;
    double ms[MAX_ROWS], spp[MAX_ROWS], est[MAX_ROWS], truth[MAX_ROWS];
} rows;

/* 0 with *a filled, HELP_PRINTED, or the exit status of a usage error. */
static int parse_args(int argc, char **argv, converge_args *a)
{
    enum { O_MAX = 256, O_REF, O_REFS, O_THREADS, O_SVG, O_CSV, O_ADAPTIVE, O_PROGRESS, O_QUIET };
    static const struct option opts[] = {{"max-samples", required_argument, NULL, O_MAX},
                                         {"reference", required_argument, NULL, O_REF},
                                         {"reference-samples", required_argument, NULL, O_REFS},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"progress", no_argument, NULL, O_PROGRESS},
                                         {"quiet", no_argument, NULL, O_QUIET},
                                         {"svg", required_argument, NULL, O_SVG},
                                         {"csv", required_argument, NULL, O_CSV},
                                         {"adaptive", no_argument, NULL, O_ADAPTIVE},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    memset(a, 0, sizeof *a);
    a->max_samples = 64;
    a->ref_samples = 256;
    a->threads = sysconf(_SC_NPROCESSORS_ONLN);
    if (a->threads < 1)
        a->threads = 1;
    a->lim = rd_scene_limits_default();
    int lrc = rd_cli_take_limits(&argc, argv, &a->lim, "rayd converge", "--max-samples");
    if (!lrc)
        lrc = rd_cli_take_overrides(&argc, argv, &a->ov, "rayd converge", converge_sets);
    if (lrc)
        return lrc;
    rd_error err = {0};
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        /* Sample counts take what the scene key takes. */
        if (c == O_MAX || c == O_REFS) {
            rd_scene_overrides one = {0};
            if (rd_override_set(&one, "samples", optarg, c == O_MAX ? "--max-samples" : "--reference-samples", &err)) {
                fprintf(stderr, "rayd converge: %s\n", err.message);
                return RD_EXIT_USAGE;
            }
            if (c == O_MAX)
                a->max_samples = one.values.samples;
            if (c == O_REFS)
                a->ref_samples = one.values.samples;
            continue;
        }
        switch (c) {
        case 'h':
            fputs(converge_help, stdout);
            rd_cli_overrides_help(stdout, converge_sets);
            return HELP_PRINTED;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &a->threads)) {
                fprintf(stderr, "rayd converge: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                return RD_EXIT_USAGE;
            }
            break;
        case O_REF: a->ref_path = optarg; break;
        case O_SVG: a->svg = optarg; break;
        case O_CSV: a->csv = optarg; break;
        case O_ADAPTIVE: a->adaptive = 1; break;
        case O_PROGRESS: a->bar = RD_BAR_ON; break;
        case O_QUIET: a->bar = RD_BAR_OFF; break;
        default:
            fprintf(stderr, "rayd converge: bad option '%s' (try 'rayd converge --help')\n", argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "rayd converge: expected one SCENE (try 'rayd converge --help')\n");
        return RD_EXIT_USAGE;
    }
    a->path = argv[optind];
    /* Every row and the reference must fit the limits, not just the scene. */
    char most[24];
    snprintf(most, sizeof most, "%ld",
             a->max_samples > a->ref_samples || a->ref_path ? a->max_samples : a->ref_samples);
    rd_override_set(&a->ov, "samples", most, "samples", &err);
    return 0;
}

/* The display values of --reference REF.png, and its own error. */
static rd_error_code read_reference(const char *path, const rd_scene *s, double *ref, double *ref_err, rd_error *err)
{
    /* The reference has the render's size, which the limits allowed. */
    int w = s->render.width, h = s->render.height;
    char *data;
    size_t len;
    rd_png_image png;
    rd_error_code rc =
        rd_read_file(path, rd_png_file_bound(w, h), "--reference: a PNG of the render's size", &data, &len, err);
    if (rc)
        return rc;
    rc = rd_png_decode((unsigned char *)data, len, (size_t)w * (size_t)h, "--reference: the render's size", &png, err);
    free(data);
    if (rc)
        return rc;
    if (png.width != w || png.height != h) {
        free(png.rgb);
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "%s is %dx%d, the render %dx%d", path, png.width, png.height, w,
                            h);
    }
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
        ref[i] = (double)png.rgb[i] / png.maxval;
    free(png.rgb);
    /* An 8-bit reference is off by up to half a level: RMS 1/(255·√12). */
    *ref_err = png.maxval == 255 ? 1.0 / (255.0 * sqrt(12.0)) : 0;
    return RD_OK;
}

/* One render, its progress on stderr as a asks. */
static rd_error_code render(const converge_args *a, const rd_scene *s, rd_render_options ro, const char *label,
                            rd_image *img, rd_render_stats *st, rd_error *err)
{
    rd_progress_settings goal = {s->render.samples, ro.time_budget_ms, ro.target_error, ro.adaptive};
    rd_progress_bar bar;
    rd_progress_bar_init(&bar, a->bar, &goal, label);
    rd_progress_bar_attach(&bar, &ro);
    rd_error_code rc = rd_render(s, &ro, img, st, err);
    rd_progress_bar_end(&bar);
    return rc;
}

/* The reference's display values: read, or rendered with ref_samples. */
static rd_error_code load_reference(const converge_args *a, rd_scene *s, double *ref, double *ref_err, rd_error *err)
{
    if (a->ref_path)
        return read_reference(a->ref_path, s, ref, ref_err, err);
    s->render.samples = (int)a->ref_samples;
    rd_render_options ro = {.threads = (int)a->threads};
    rd_image img;
    rd_render_stats st;
    fprintf(stderr, "rendering the reference (%ld samples per pixel)...\n", a->ref_samples);
    rd_error_code rc = render(a, s, ro, "reference", &img, &st, err);
    if (rc)
        return rc;
    for (size_t i = 0; i < (size_t)img.width * (size_t)img.height * 3; i++)
        ref[i] = rd_display(img.rgb[i], s->render.gamma);
    *ref_err = st.error_estimate;
    rd_image_free(&img);
    fprintf(stderr, "reference: %.0f ms, its own error estimate %.6f\n", st.wall_ms, *ref_err);
    return RD_OK;
}

/* Renders 1, 2, 4, ... samples and prints each row with its true error. */
static void measure_rows(const converge_args *a, rd_scene *s, const double *ref, double ref_err, rows *t)
{
    rd_render_options ro = {.threads = (int)a->threads, .adaptive = a->adaptive};
    /* Adaptive rows are progressive renders capped at k samples. */
    ro.target_error = a->adaptive ? 1e-12 : 0;
    printf("# %s %dx%d, reference %s (own error %.6f, taken out in quadrature)\n", a->path, s->render.width,
           s->render.height, a->ref_path ? a->ref_path : "rendered", ref_err);
    printf("%8s %10s %12s %12s %8s\n", "samples", "ms", "estimate", "true", "est/true");
    t->n = 0;
    for (long k = 1; k <= a->max_samples && t->n < MAX_ROWS; k *= 2) {
        s->render.samples = (int)k;
        rd_image img;
        rd_render_stats st;
        rd_error err = {0};
        char label[32];
        snprintf(label, sizeof label, "row %ld", k);
        if (render(a, s, ro, label, &img, &st, &err)) {
            fprintf(stderr, "rayd converge: %s\n", err.message);
            break;
        }
        double raw = rd_compare_display_rmse(&img, ref, s->render.gamma), d = raw * raw - ref_err * ref_err;
        int i = t->n++;
        t->ms[i] = st.wall_ms;
        t->spp[i] = st.mean_samples;
        t->est[i] = st.error_estimate;
        t->truth[i] = d > 0 ? sqrt(d) : 0;
        printf("%8.1f %10.1f %12.6f %12.6f %8.3f\n", t->spp[i], t->ms[i], t->est[i], t->truth[i],
               t->truth[i] > 0 ? t->est[i] / t->truth[i] : NAN);
        fflush(stdout);
        rd_image_free(&img);
    }
    printf("slope of log(true error) against log(samples): %.3f\n", rd_loglog_slope(t->spp, t->truth, t->n));
    printf("slope of log(estimate) against log(samples):   %.3f\n", rd_loglog_slope(t->spp + 1, t->est + 1, t->n - 1));
}

static rd_error_code write_csv(const char *path, const rows *t, rd_error *err)
{
    rd_strbuf b = {0};
    rd_strbuf_printf(&b, "samples,ms,estimate,true\n");
    for (int i = 0; i < t->n; i++)
        rd_strbuf_printf(&b, "%g,%.3f,%.8f,%.8f\n", t->spp[i], t->ms[i], t->est[i], t->truth[i]);
    size_t len;
    char *text = rd_strbuf_take(&b, &len);
    if (!text)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_error_code rc = rd_write_file(path, text, len, err);
    free(text);
    return rc;
}

static rd_error_code write_svg(const char *path, const char *scene, rows *t, rd_error *err)
{
    rd_svg_series series[2] = {{"true error (RMSE)", "#1f5fbf", 0, t->ms, t->truth, (size_t)t->n},
                               {"estimated error", "#d2452d", 1, t->ms, t->est, (size_t)t->n}};
    char title[300];
    snprintf(title, sizeof title, "%s: error against render time", scene);
    char *text = rd_svg_loglog(title, "render time (ms)", "RMS error (1 = 255 levels)", series, 2);
    if (!text)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_error_code rc = rd_write_file(path, text, strlen(text), err);
    free(text);
    return rc;
}

int rd_cmd_converge(int argc, char **argv)
{
    converge_args a;
    int prc = parse_args(argc, argv, &a);
    if (prc)
        return prc == HELP_PRINTED ? RD_EXIT_OK : prc;
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    rd_scene_source src = {.path = a.path};
    rd_error_code rc = rd_scene_open(&src, &a.ov, &a.lim, &s, NULL, &err);
    if (rc) {
        fprintf(stderr, "%s\n", err.message);
        rd_scene_free(&s);
        return rd_error_answer_for(rc).exit;
    }
    if (!rd_override_given(&a.ov, "width") && !rd_override_given(&a.ov, "height")) {
        s.render.width = (s.render.width + 1) / 2;
        s.render.height = (s.render.height + 1) / 2;
    }
    double *ref = malloc((size_t)s.render.width * (size_t)s.render.height * 3 * sizeof *ref), ref_err = 0;
    rc = ref ? load_reference(&a, &s, ref, &ref_err, &err) : rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory");
    static rows t;
    if (!rc)
        measure_rows(&a, &s, ref, ref_err, &t);
    if (!rc && a.csv)
        rc = write_csv(a.csv, &t, &err);
    if (!rc && a.svg)
        rc = write_svg(a.svg, a.path, &t, &err);
    if (rc)
        fprintf(stderr, "rayd converge: %s\n", err.message);
    free(ref);
    rd_scene_free(&s);
    return rc ? rd_error_answer_for(rc).exit : RD_EXIT_OK;
}
