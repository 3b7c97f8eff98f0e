#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "png_read.h"
#include "png_write.h"
#include "rayd/render.h"
#include "scene_open.h"
#include "svg_plot.h"
#include "file_io.h"

static const char converge_help[] =
    "usage: rayd converge SCENE [--reference REF.png | --reference-samples N] [options]\n"
    "\n"
    "Renders SCENE at 1, 2, 4, ... samples per pixel and prints, for each, the\n"
    "time, the error estimate the renderer reports, and the true error: the RMSE\n"
    "of its display values (after clamp and gamma, 1 = 255 levels) against a\n"
    "converged reference. The reference is REF.png, or a render of N samples\n"
    "(default 1024) whose own estimated error is taken out in quadrature. Ends\n"
    "with the fitted log-log slopes of both errors against samples.\n"
    "\n"
    "  --max-samples N        the last row (default 64)\n"
    "  --reference REF.png    compare with this image (same size as the render)\n"
    "  --reference-samples N  render the reference with N samples (default 1024)\n"
    "  --width W --height H   override the scene's size\n"
    "  --max-...  N           a size limit; 'rayd limits' lists them with defaults\n"
    "                         (but --max-samples is the last row here)\n"
    "  --threads N            render threads (default: the number of cores)\n"
    "  --adaptive             use adaptive passes (each row a progressive render)\n"
    "  --svg FILE             write the error-against-time plot as SVG\n"
    "  --csv FILE             write the table as CSV\n";

/* RMSE between an image's display values and reference display values. */
static double rmse(const rd_image *img, const double *ref, double gamma)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        double d = rd_display(img->rgb[i], gamma) - ref[i];
        sum += d * d;
    }
    return sqrt(sum / (double)n);
}

/* Least-squares slope of log(y) against log(x) over points with y > 0. */
static double loglog_slope(const double *x, const double *y, int n)
{
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (!(x[i] > 0) || !(y[i] > 0))
            continue;
        double a = log(x[i]), b = log(y[i]);
        sx += a;
        sy += b;
        sxx += a * a;
        sxy += a * b;
        m++;
    }
    double d = m * sxx - sx * sx;
    return m >= 2 && d != 0 ? (m * sxy - sx * sy) / d : NAN;
}

int rd_cmd_converge(int argc, char **argv)
{
    enum { O_MAX = 256, O_REF, O_REFS, O_W, O_H, O_THREADS, O_SVG, O_CSV, O_ADAPTIVE };
    static const struct option opts[] = {
        {"max-samples", required_argument, NULL, O_MAX}, {"reference", required_argument, NULL, O_REF},
        {"reference-samples", required_argument, NULL, O_REFS}, {"width", required_argument, NULL, O_W},
        {"height", required_argument, NULL, O_H}, {"threads", required_argument, NULL, O_THREADS},
        {"svg", required_argument, NULL, O_SVG}, {"csv", required_argument, NULL, O_CSV},
        {"adaptive", no_argument, NULL, O_ADAPTIVE}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    long max_samples = 64, ref_samples = 1024, threads = sysconf(_SC_NPROCESSORS_ONLN);
    const char *ref_path = NULL, *svg = NULL, *csv = NULL;
    int adaptive = 0;
    if (threads < 1)
        threads = 1;
    rd_scene_limits lim = rd_scene_limits_default();
    int lrc = rd_cli_take_limits(&argc, argv, &lim, "rayd converge", "--max-samples");
    if (lrc)
        return lrc;
    rd_scene_overrides ov = {0};
    rd_error err = {0};
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        /* Sizes and sample counts take what the scene keys take. */
        const char *key = c == O_W ? "width" : c == O_H ? "height" : c == O_MAX || c == O_REFS ? "samples" : NULL;
        if (key) {
            rd_scene_overrides one = {0};
            char what[32];
            snprintf(what, sizeof what, "%s", argv[optind - 2]);
            if (rd_override_set(c == O_W || c == O_H ? &ov : &one, key, optarg, what, &err)) {
                fprintf(stderr, "rayd converge: %s\n", err.message);
                return RD_EXIT_USAGE;
            }
            if (c == O_MAX)
                max_samples = one.values.samples;
            if (c == O_REFS)
                ref_samples = one.values.samples;
            continue;
        }
        switch (c) {
        case 'h': fputs(converge_help, stdout); return RD_EXIT_OK;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &threads)) {
                fprintf(stderr, "rayd converge: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                return RD_EXIT_USAGE;
            }
            break;
        case O_REF: ref_path = optarg; break;
        case O_SVG: svg = optarg; break;
        case O_CSV: csv = optarg; break;
        case O_ADAPTIVE: adaptive = 1; break;
        default:
            fprintf(stderr, "rayd converge: bad option '%s' (try 'rayd converge --help')\n", argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "rayd converge: expected one SCENE (try 'rayd converge --help')\n");
        return RD_EXIT_USAGE;
    }
    const char *path = argv[optind];
    rd_scene s;
    rd_scene_init(&s);
    /* Every row and the reference must fit the limits, not just the scene. */
    char most[24];
    snprintf(most, sizeof most, "%ld", max_samples > ref_samples || ref_path ? max_samples : ref_samples);
    rd_override_set(&ov, "samples", most, "samples", &err);
    rd_scene_source src = {.path = path};
    rd_error_code rc = rd_scene_open(&src, &ov, &lim, &s, NULL, &err);
    if (rc) {
        fprintf(stderr, "%s\n", err.message);
        rd_scene_free(&s);
        return rd_error_answer_for(rc).exit;
    }
    size_t n = (size_t)s.render.width * (size_t)s.render.height * 3;
    double *ref = malloc(n * sizeof *ref);
    double ref_err = 0;
    rd_render_options ro = {0};
    ro.threads = (int)threads;
    if (!ref) {
        rd_scene_free(&s);
        return RD_EXIT_IO;
    }
    if (ref_path) {
        char *data;
        size_t len;
        rd_png_image png;
        /* The reference has the render's size, which the limits allowed. */
        int w = s.render.width, h = s.render.height;
        rc = rd_read_file(ref_path, rd_png_file_bound(w, h), "--reference: a PNG of the render's size", &data,
                          &len, &err);
        if (!rc) {
            rc = rd_png_decode((unsigned char *)data, len, (size_t)w * (size_t)h, "--reference: the render's size",
                               &png, &err);
            free(data);
        }
        if (!rc && (png.width != s.render.width || png.height != s.render.height)) {
            rc = rd_error_set(&err, RD_ERR_INVALID, 0, 0, "%s is %dx%d, the render %dx%d", ref_path, png.width,
                              png.height, s.render.width, s.render.height);
            free(png.rgb);
        }
        if (rc) {
            fprintf(stderr, "rayd converge: %s\n", err.message);
            free(ref);
            rd_scene_free(&s);
            return rd_error_answer_for(rc).exit;
        }
        for (size_t i = 0; i < n; i++)
            ref[i] = (double)png.rgb[i] / png.maxval;
        free(png.rgb);
        /* An 8-bit reference is off by up to half a level: RMS 1/(255·√12). */
        ref_err = png.maxval == 255 ? 1.0 / (255.0 * sqrt(12.0)) : 0;
    } else {
        s.render.samples = (int)ref_samples;
        rd_image img;
        rd_render_stats st;
        fprintf(stderr, "rendering the reference (%ld samples per pixel)...\n", ref_samples);
        if (rd_render(&s, &ro, &img, &st, &err)) {
            fprintf(stderr, "rayd converge: %s\n", err.message);
            free(ref);
            rd_scene_free(&s);
            return RD_EXIT_SCENE;
        }
        for (size_t i = 0; i < n; i++)
            ref[i] = rd_display(img.rgb[i], s.render.gamma);
        ref_err = st.error_estimate;
        rd_image_free(&img);
        fprintf(stderr, "reference: %.0f ms, its own error estimate %.6f\n", st.wall_ms, ref_err);
    }
    int rows = 0;
    double ms[32], spp[32], est[32], truth[32];
    printf("# %s %dx%d, reference %s (own error %.6f, taken out in quadrature)\n", path, s.render.width,
           s.render.height, ref_path ? ref_path : "rendered", ref_err);
    printf("%8s %10s %12s %12s %8s\n", "samples", "ms", "estimate", "true", "est/true");
    for (long k = 1; k <= max_samples && rows < 32; k *= 2) {
        s.render.samples = (int)k;
        rd_image img;
        rd_render_stats st;
        ro.adaptive = adaptive;
        /* Adaptive rows are progressive renders capped at k samples. */
        ro.target_error = adaptive ? 1e-12 : 0;
        if (rd_render(&s, &ro, &img, &st, &err)) {
            fprintf(stderr, "rayd converge: %s\n", err.message);
            break;
        }
        double raw = rmse(&img, ref, s.render.gamma);
        double t = raw * raw - ref_err * ref_err;
        ms[rows] = st.wall_ms;
        spp[rows] = st.mean_samples;
        est[rows] = st.error_estimate;
        truth[rows] = t > 0 ? sqrt(t) : 0;
        printf("%8.1f %10.1f %12.6f %12.6f %8.3f\n", spp[rows], ms[rows], est[rows], truth[rows],
               truth[rows] > 0 ? est[rows] / truth[rows] : NAN);
        rd_image_free(&img);
        rows++;
    }
    double slope_true = loglog_slope(spp, truth, rows), slope_est = loglog_slope(spp + 1, est + 1, rows - 1);
    printf("slope of log(true error) against log(samples): %.3f\n", slope_true);
    printf("slope of log(estimate) against log(samples):   %.3f\n", slope_est);
    if (csv) {
        FILE *f = fopen(csv, "w");
        if (f) {
            fprintf(f, "samples,ms,estimate,true\n");
            for (int i = 0; i < rows; i++)
                fprintf(f, "%g,%.3f,%.8f,%.8f\n", spp[i], ms[i], est[i], truth[i]);
            fclose(f);
        }
    }
    if (svg) {
        rd_svg_series series[2] = {{"true error (RMSE)", "#1f5fbf", 0, ms, truth, (size_t)rows},
                                   {"estimated error", "#d2452d", 1, ms, est, (size_t)rows}};
        char title[300];
        snprintf(title, sizeof title, "%s: error against render time", path);
        char *text = rd_svg_loglog(title, "render time (ms)", "RMS error (1 = 255 levels)", series, 2);
        if (!text || rd_write_file(svg, text, strlen(text), &err))
            fprintf(stderr, "rayd converge: cannot write %s\n", svg);
        free(text);
    }
    free(ref);
    rd_scene_free(&s);
    return RD_EXIT_OK;
}
