#include <cJSON.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "file_io.h"
#include "png_write.h"
#include "rayd/render.h"
#include "scene_open.h"

static const char render_help[] = "usage: rayd render SCENE -o OUT.png [options]\n"
                                  "\n"
                                  "Renders SCENE (.cfg or .json; other names are sniffed) into an 8-bit RGB PNG\n"
                                  "and prints one line of statistics on stderr.\n"
                                  "\n"
                                  "  -o, --output FILE   where to write the PNG (required)\n"
                                  "      --width N       image width in pixels, 1..16384 (overrides [render])\n"
                                  "      --height N      image height in pixels, 1..16384\n"
                                  "      --samples N     samples per pixel, 1..65536; 1 is the pixel centre\n"
                                  "      --seed N        sampling seed; same seed gives the same image\n"
                                  "      --threads N     worker threads, 1..1024 (default: the number of cores);\n"
                                  "                      the image does not depend on it\n"
                                  "      --png-level N   zlib level 0..9 for the PNG (default 1)\n"
                                  "      --time-budget-ms T  render in passes and stop before T ms are spent\n"
                                  "      --target-error E    render in passes until the error estimate is <= E\n"
                                  "                      (either makes --samples the cap, not the count)\n"
                                  "      --adaptive      later passes spend samples where the estimated error is\n"
                                  "      --stats-format text|json|both  the statistics as the line below (text,\n"
                                  "                      the default), as one JSON object on one line (json), or\n"
                                  "                      the line and then the object (both)\n"
                                  "      --max-...  N    a size limit; 'rayd limits' lists them with defaults\n"
                                  "  -h, --help          this text\n"
                                  "\n"
                                  "Exit status: 0 written; 1 usage error; 2 scene error (message on stderr,\n"
                                  "no image written); 3 file could not be read or written.\n"
                                  "\n"
                                  "Statistics line (stderr):\n"
                                  "  render: WxH samples=N threads=N time_ms=T camera_rays=N shadow_rays=N\n"
                                  "  secondary_rays=N rays_per_s=R error_estimate=E nonfinite=N prepare_ms=T\n"
                                  "  bvh_build_ms=T bvh_nodes=N primitives=N world_bytes=B\n"
                                  "  stopped_by=samples|time_budget|target_error passes=N curve=MS:SPP:ERR,...\n"
                                  "error_estimate is the estimated RMS error of the image against a converged\n"
                                  "render, in [0,1] units (1 = 255 levels); 0 with one sample per pixel. curve\n"
                                  "has one point per pass: elapsed ms, samples per pixel, error estimate.\n"
                                  "\n"
                                  "Statistics object (--stats-format json): the same figures under the same\n"
                                  "names, numbers at full precision: width, height, samples, threads, time_ms,\n"
                                  "camera_rays, shadow_rays, secondary_rays, rays_per_s, error_estimate,\n"
                                  "nonfinite, prepare_ms, bvh_build_ms, bvh_nodes, primitives, world_bytes,\n"
                                  "stopped_by, passes, curve (an array of {ms, samples, error}), and\n"
                                  "mean_samples (the exact mean per pixel; samples is it rounded).\n";

enum { STATS_TEXT = 1, STATS_JSON = 2 };

static void stats_text(const rd_image *img, const rd_render_stats *st)
{
    fprintf(stderr,
            "render: %dx%d samples=%d threads=%d time_ms=%.3f camera_rays=%llu shadow_rays=%llu "
            "secondary_rays=%llu rays_per_s=%.4g error_estimate=%.6f nonfinite=%llu prepare_ms=%.3f "
            "bvh_build_ms=%.3f bvh_nodes=%zu primitives=%zu world_bytes=%zu stopped_by=%s passes=%d curve=",
            img->width, img->height, st->samples, st->threads, st->wall_ms, (unsigned long long)st->camera_rays,
            (unsigned long long)st->shadow_rays, (unsigned long long)st->secondary_rays, st->rays_per_second,
            st->error_estimate, (unsigned long long)st->nonfinite, st->prepare_ms, st->bvh_build_ms, st->bvh_nodes,
            st->primitives, st->world_bytes, rd_stop_reason_name(st->stopped_by), st->passes);
    for (int i = 0; i < st->curve_len; i++)
        fprintf(stderr, "%s%.3f:%g:%.6f", i ? "," : "", st->curve[i].ms, st->curve[i].samples, st->curve[i].error);
    fputc('\n', stderr);
}

/* One line, so that a reader can take the last line of stderr whatever
 * warnings came before it. Returns 0, or -1 when out of memory. */
static int stats_json(const rd_image *img, const rd_render_stats *st)
{
    cJSON *o = cJSON_CreateObject();
    int ok = o != NULL;
    ok = ok && cJSON_AddNumberToObject(o, "width", img->width);
    ok = ok && cJSON_AddNumberToObject(o, "height", img->height);
    ok = ok && cJSON_AddNumberToObject(o, "samples", st->samples);
    ok = ok && cJSON_AddNumberToObject(o, "mean_samples", st->mean_samples);
    ok = ok && cJSON_AddNumberToObject(o, "threads", st->threads);
    ok = ok && cJSON_AddNumberToObject(o, "time_ms", st->wall_ms);
    ok = ok && cJSON_AddNumberToObject(o, "camera_rays", (double)st->camera_rays);
    ok = ok && cJSON_AddNumberToObject(o, "shadow_rays", (double)st->shadow_rays);
    ok = ok && cJSON_AddNumberToObject(o, "secondary_rays", (double)st->secondary_rays);
    ok = ok && cJSON_AddNumberToObject(o, "rays_per_s", st->rays_per_second);
    ok = ok && cJSON_AddNumberToObject(o, "error_estimate", st->error_estimate);
    ok = ok && cJSON_AddNumberToObject(o, "nonfinite", (double)st->nonfinite);
    ok = ok && cJSON_AddNumberToObject(o, "prepare_ms", st->prepare_ms);
    ok = ok && cJSON_AddNumberToObject(o, "bvh_build_ms", st->bvh_build_ms);
    ok = ok && cJSON_AddNumberToObject(o, "bvh_nodes", (double)st->bvh_nodes);
    ok = ok && cJSON_AddNumberToObject(o, "primitives", (double)st->primitives);
    ok = ok && cJSON_AddNumberToObject(o, "world_bytes", (double)st->world_bytes);
    ok = ok && cJSON_AddStringToObject(o, "stopped_by", rd_stop_reason_name(st->stopped_by));
    ok = ok && cJSON_AddNumberToObject(o, "passes", st->passes);
    cJSON *curve = ok ? cJSON_AddArrayToObject(o, "curve") : NULL;
    ok = curve != NULL;
    for (int i = 0; ok && i < st->curve_len; i++) {
        cJSON *pt = cJSON_CreateObject();
        if (!pt || !cJSON_AddItemToArray(curve, pt)) {
            cJSON_Delete(pt);
            ok = 0;
            break;
        }
        ok = ok && cJSON_AddNumberToObject(pt, "ms", st->curve[i].ms);
        ok = ok && cJSON_AddNumberToObject(pt, "samples", st->curve[i].samples);
        ok = ok && cJSON_AddNumberToObject(pt, "error", st->curve[i].error);
    }
    char *text = ok ? cJSON_PrintUnformatted(o) : NULL;
    cJSON_Delete(o);
    if (!text)
        return -1;
    fputs(text, stderr);
    fputc('\n', stderr);
    free(text);
    return 0;
}

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "rayd render: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n(try 'rayd render --help')\n");
    return RD_EXIT_USAGE;
}

typedef struct {
    const char *scene, *output;
    long threads, level;
    rd_scene_overrides ov;
    rd_scene_limits lim;
    rd_render_options ro;
    int stats_format;
} render_args;

enum { HELP_PRINTED = -1 };

/* A number > 0 for --time-budget-ms or --target-error. */
static int positive(const char *flag, const char *v, double *out)
{
    char *end;
    double x = strtod(v, &end);
    if (!*v || *end || !(x > 0) || !(x < 1e15)) {
        char fmt[80];
        snprintf(fmt, sizeof fmt, "%s: expected a number > 0, got '%%s'", flag);
        return usage_error(fmt, v);
    }
    *out = x;
    return 0;
}

static int stats_format_of(const char *v, int *out)
{
    *out = strcmp(v, "text") == 0   ? STATS_TEXT
           : strcmp(v, "json") == 0 ? STATS_JSON
           : strcmp(v, "both") == 0 ? STATS_TEXT | STATS_JSON
                                    : 0;
    return *out ? 0 : usage_error("--stats-format: expected text, json or both, got '%s'", v);
}

/* 0 with *a filled, HELP_PRINTED, or the exit status of a usage error. */
static int parse_args(int argc, char **argv, render_args *a)
{
    enum {
        O_WIDTH = 256,
        O_HEIGHT,
        O_SAMPLES,
        O_SEED,
        O_THREADS,
        O_PNG_LEVEL,
        O_BUDGET,
        O_TARGET,
        O_ADAPTIVE,
        O_STATS_FORMAT
    };
    static const struct option opts[] = {{"output", required_argument, NULL, 'o'},
                                         {"width", required_argument, NULL, O_WIDTH},
                                         {"height", required_argument, NULL, O_HEIGHT},
                                         {"samples", required_argument, NULL, O_SAMPLES},
                                         {"seed", required_argument, NULL, O_SEED},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"png-level", required_argument, NULL, O_PNG_LEVEL},
                                         {"help", no_argument, NULL, 'h'},
                                         {"time-budget-ms", required_argument, NULL, O_BUDGET},
                                         {"target-error", required_argument, NULL, O_TARGET},
                                         {"adaptive", no_argument, NULL, O_ADAPTIVE},
                                         {"stats-format", required_argument, NULL, O_STATS_FORMAT},
                                         {NULL, 0, NULL, 0}};
    memset(a, 0, sizeof *a);
    a->threads = sysconf(_SC_NPROCESSORS_ONLN);
    if (a->threads < 1)
        a->threads = 1;
    a->level = -1;
    a->stats_format = STATS_TEXT;
    a->lim = rd_scene_limits_default();
    int rc = rd_cli_take_limits(&argc, argv, &a->lim, "rayd render", NULL);
    if (rc)
        return rc;
    rd_error err = {0};
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":o:h", opts, NULL)) != -1) {
        const char *key = c == O_WIDTH     ? "width"
                          : c == O_HEIGHT  ? "height"
                          : c == O_SAMPLES ? "samples"
                          : c == O_SEED    ? "seed"
                                           : NULL;
        char what[32];
        if (key) {
            snprintf(what, sizeof what, "--%s", key);
            rc = rd_override_set(&a->ov, key, optarg, what, &err) ? usage_error("%s", err.message) : 0;
        } else if (c == 'o') {
            a->output = optarg;
        } else if (c == 'h') {
            fputs(render_help, stdout);
            return HELP_PRINTED;
        } else if (c == O_THREADS) {
            rc = rd_cli_int(optarg, 1, 1024, &a->threads)
                     ? usage_error("--threads: expected an integer in 1..1024, got '%s'", optarg)
                     : 0;
        } else if (c == O_PNG_LEVEL) {
            rc = rd_cli_int(optarg, 0, 9, &a->level)
                     ? usage_error("--png-level: expected an integer in 0..9, got '%s'", optarg)
                     : 0;
        } else if (c == O_BUDGET) {
            rc = positive("--time-budget-ms", optarg, &a->ro.time_budget_ms);
        } else if (c == O_TARGET) {
            rc = positive("--target-error", optarg, &a->ro.target_error);
        } else if (c == O_ADAPTIVE) {
            a->ro.adaptive = 1;
        } else if (c == O_STATS_FORMAT) {
            rc = stats_format_of(optarg, &a->stats_format);
        } else {
            rc = usage_error(c == ':' ? "%s needs a value" : "unknown option '%s'", argv[optind - 1]);
        }
        if (rc)
            return rc;
    }
    if (optind != argc - 1)
        return usage_error("%s", optind >= argc ? "expected one SCENE file" : "expected exactly one SCENE file");
    if (!a->output)
        return usage_error("%s", "missing -o OUT.png");
    a->scene = argv[optind];
    a->ro.threads = (int)a->threads;
    return 0;
}

/* The image as a PNG file. */
static rd_error_code write_png(const rd_image *img, double gamma, const render_args *a, rd_error *err)
{
    uint8_t *rgb = malloc((size_t)img->width * (size_t)img->height * 3);
    if (!rgb)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_image_to_rgb8(img, gamma, rgb);
    rd_png_options po = rd_png_options_default();
    if (a->level >= 0)
        po.level = (int)a->level;
    unsigned char *png = NULL;
    size_t len = 0;
    rd_error_code rc = rd_png_encode(rgb, img->width, img->height, &po, &png, &len, err);
    free(rgb);
    if (!rc)
        rc = rd_write_file(a->output, png, len, err);
    free(png);
    return rc;
}

int rd_cmd_render(int argc, char **argv)
{
    render_args a;
    int prc = parse_args(argc, argv, &a);
    if (prc)
        return prc == HELP_PRINTED ? RD_EXIT_OK : prc;
    rd_scene scene;
    rd_scene_init(&scene);
    rd_scene_source src = {.path = a.scene};
    rd_warnings warnings = {0, ""};
    rd_error err = {0};
    rd_error_code rc = rd_scene_open(&src, &a.ov, &a.lim, &scene, &warnings, &err);
    if (warnings.count)
        fprintf(stderr, "%s%s", warnings.text, warnings.count > 5 ? "(more warnings not shown)\n" : "");
    rd_image img;
    rd_render_stats st;
    if (!rc && (rc = rd_render(&scene, &a.ro, &img, &st, &err)))
        fprintf(stderr, "%s: %s\n", a.scene, err.message);
    else if (rc)
        fprintf(stderr, "%s\n", err.message);
    if (rc) {
        rd_scene_free(&scene);
        return rd_error_answer_for(rc).exit;
    }
    rc = write_png(&img, scene.render.gamma, &a, &err);
    if (a.stats_format & STATS_TEXT)
        stats_text(&img, &st);
    if ((a.stats_format & STATS_JSON) && stats_json(&img, &st) && !rc)
        rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory writing the statistics");
    rd_image_free(&img);
    rd_scene_free(&scene);
    if (rc) {
        fprintf(stderr, "rayd render: %s\n", err.message);
        return RD_EXIT_IO;
    }
    return RD_EXIT_OK;
}
