#include <cJSON.h>
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "cli.h"
#include "file_io.h"
#include "hdr_write.h"
#include "json_text.h"
#include "png_write.h"
#include "progress_bar.h"
#include "rayd/job.h"
#include "rayd/render.h"
#include "scene_open.h"

static const char render_help[] = "usage: rayd render SCENE -o OUT [options]\n"
                                  "\n"
                                  "Renders SCENE (.cfg or .json; other names are sniffed) and prints one line of\n"
                                  "statistics on stderr. OUT's extension says what is written:\n"
                                  "  .png  8-bit RGB: the linear image clamped, gamma applied, rounded\n"
                                  "  .exr  OpenEXR, the linear image: RGB 32-bit float, ZIP, scanlines\n"
                                  "  .pfm  portable float map, the linear image: little-endian, bottom row first\n"
                                  "  -     the PNG on stdout (the statistics stay on stderr)\n"
                                  "  /dev/null, a FIFO: the PNG, written into it in place\n"
                                  "Any other name is refused before rendering, and so is --gamma with .exr or\n"
                                  ".pfm (gamma does not change the linear image); an output that cannot be\n"
                                  "written (missing folder, no permission) too; a file is replaced only once\n"
                                  "it is whole.\n"
                                  "\n"
                                  "  -o, --output OUT    where to write the image (required)\n"
                                  "      --threads N     worker threads, 1..1024 (default: the number of cores);\n"
                                  "                      the image does not depend on it\n"
                                  "      --png-level N   zlib level 0..9 for the PNG (default 1)\n"
                                  "      --time-budget-ms T  render in passes and stop before T ms are spent\n"
                                  "      --target-error E    render in passes until the error estimate is <= E\n"
                                  "                      (either makes the samples the cap, not the count)\n"
                                  "      --adaptive      later passes spend samples where the estimated error is\n"
                                  "      --packets camera|shadow|all|none  trace the rays of 4x4 pixel blocks\n"
                                  "                      in packets: the camera rays, the shadow rays towards\n"
                                  "                      point, spot and directional lights, or both; the\n"
                                  "                      same image and counts, at another speed (none, the\n"
                                  "                      default: ray by ray)\n"
                                  "      --stats-format text|json|both  the statistics as the line below (text,\n"
                                  "                      the default), as one JSON object on one line (json), or\n"
                                  "                      the line and then the object (both)\n"
                                  "      --progress      a progress bar on stderr even when it is not a terminal\n"
                                  "      --quiet         no progress bar or pass lines (the statistics stay)\n"
                                  "      --limit-...  N  a size limit; 'rayd limits' lists them with defaults\n"
                                  "  -h, --help          this text\n"
                                  "\n";

static const char render_help_tail[] = "\n"
                                       "Samples 1 is the pixel centre; the same seed gives the same image.\n"
                                       "\n"
                                       "Progress: on a terminal, after the first second, a bar redrawn in place\n"
                                       "(tiles of the pass, samples, error estimate, time spent and left); not on a\n"
                                       "terminal, one line per pass (render pass N: samples=S error=E ms=T), only\n"
                                       "when the render has more than one pass.\n"
                                       "\n"
                                       "Exit status: 0 written; 1 usage error; 2 scene error (message on stderr,\n"
                                       "no image written); 3 file could not be read or written.\n"
                                       "\n"
                                       "Statistics line (stderr):\n"
                                       "  render: WxH samples=N threads=N time_ms=T camera_rays=N shadow_rays=N\n"
                                       "  secondary_rays=N rays_per_second=R error_estimate=E nonfinite=N\n"
                                       "  prepare_ms=T bvh_build_ms=T bvh_nodes=N primitives=N world_bytes=B\n"
                                       "  stopped_by=samples|time_budget|target_error passes=N curve=MS:SPP:ERR,...\n"
                                       "error_estimate is the estimated RMS error of the image against a converged\n"
                                       "render, in [0,1] units (1 = 255 levels); 0 with one sample per pixel. curve\n"
                                       "has one point per pass: elapsed ms, samples per pixel, error estimate.\n"
                                       "\n"
                                       "Statistics object (--stats-format json): the same figures under the same\n"
                                       "names, numbers at full precision: width, height, samples, threads, time_ms,\n"
                                       "camera_rays, shadow_rays, secondary_rays, rays_per_second, error_estimate,\n"
                                       "nonfinite, prepare_ms, bvh_build_ms, bvh_nodes, primitives, world_bytes,\n"
                                       "stopped_by, passes, curve (an array of [ms, samples, error]), and\n"
                                       "mean_samples (the exact mean per pixel; samples is it rounded). The names\n"
                                       "and the curve are those of the daemon's job status (GET /v1/jobs/{id}),\n"
                                       "which gives the ray counts, rays_per_second, prepare_ms and primitives\n"
                                       "under \"stats\".\n";

enum { STATS_TEXT = 1, STATS_JSON = 2 };

static void stats_text(const rd_image *img, const rd_render_stats *st)
{
    fprintf(stderr,
            "render: %dx%d samples=%d threads=%d time_ms=%.3f camera_rays=%llu shadow_rays=%llu "
            "secondary_rays=%llu rays_per_second=%.4g error_estimate=%.6f nonfinite=%llu prepare_ms=%.3f "
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
 * warnings came before it. The figures under the names, and the curve in
 * the shape, of the daemon's job status (rd_stats_json), flat, with the
 * ones only a whole render in one process has. Returns 0, or -1 when out
 * of memory. */
static int stats_json(const rd_image *img, const rd_render_stats *st)
{
    int failed = 0;
    cJSON *o = cJSON_CreateObject();
    rd_json_add(o, "width", cJSON_CreateNumber(img->width), &failed);
    rd_json_add(o, "height", cJSON_CreateNumber(img->height), &failed);
    if (!failed && rd_stats_json(o, st, RD_STATS_STOPPED | RD_STATS_COSTS | RD_STATS_PROCESS))
        failed = 1;
    char *text = failed ? NULL : cJSON_PrintUnformatted(o);
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

/* What rayd writes, by the output's extension. */
typedef enum { OUT_PNG, OUT_EXR, OUT_PFM } out_kind;

static const struct {
    const char *ext;
    out_kind kind;
} out_kinds[] = {{".png", OUT_PNG}, {".exr", OUT_EXR}, {".pfm", OUT_PFM}};

enum { N_OUT_KINDS = sizeof out_kinds / sizeof out_kinds[0] };

/* 0 with *kind set from the name's extension, or a usage error listing
 * those rayd writes. */
static int out_kind_of(const char *path, out_kind *kind)
{
    *kind = OUT_PNG;
    /* stdout, /dev/null, a FIFO: a PNG, whatever the name. */
    if (strcmp(path, "-") == 0 || rd_is_special_file(path))
        return 0;
    const char *dot = strrchr(path, '.');
    for (int i = 0; dot && !strchr(dot, '/') && i < N_OUT_KINDS; i++)
        if (strcasecmp(dot, out_kinds[i].ext) == 0) {
            *kind = out_kinds[i].kind;
            return 0;
        }
    char exts[64] = "";
    size_t n = 0;
    for (int i = 0; i < N_OUT_KINDS; i++)
        n += (size_t)snprintf(exts + n, sizeof exts - n, "%s%s", i ? ", " : "", out_kinds[i].ext);
    fprintf(stderr, "rayd render: -o %s: rayd writes %s (or - for a PNG on stdout)\n(try 'rayd render --help')\n", path,
            exts);
    return RD_EXIT_USAGE;
}

typedef struct {
    const char *scene, *output;
    out_kind kind;
    long threads, level;
    rd_scene_overrides ov;
    rd_scene_limits lim;
    rd_render_options ro;
    int stats_format;
    rd_bar_mode bar;
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

static void print_help(void)
{
    fputs(render_help, stdout);
    rd_cli_overrides_help(stdout, NULL);
    fputs(render_help_tail, stdout);
}

static int packets_of(const char *arg, unsigned *out)
{
    static const struct {
        const char *name;
        unsigned bits;
    } names[] = {{"none", 0},
                 {"camera", RD_PACKETS_CAMERA},
                 {"shadow", RD_PACKETS_SHADOW},
                 {"all", RD_PACKETS_CAMERA | RD_PACKETS_SHADOW}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(arg, names[i].name)) {
            *out = names[i].bits;
            return 0;
        }
    return usage_error("--packets: expected camera, shadow, all or none, got '%s'", arg);
}

/* The options after the limits and the overrides: 0, HELP_PRINTED or the
 * exit status of a usage error. */
static int parse_option(int c, const char *arg, render_args *a)
{
    switch (c) {
    case 'o': a->output = arg; return 0;
    case 'h': print_help(); return HELP_PRINTED;
    case 't':
        return rd_cli_int(arg, 1, 1024, &a->threads)
                   ? usage_error("--threads: expected an integer in 1..1024, got '%s'", arg)
                   : 0;
    case 'l':
        return rd_cli_int(arg, 0, 9, &a->level) ? usage_error("--png-level: expected an integer in 0..9, got '%s'", arg)
                                                : 0;
    case 'b': return positive("--time-budget-ms", arg, &a->ro.time_budget_ms);
    case 'e': return positive("--target-error", arg, &a->ro.target_error);
    case 'a': a->ro.adaptive = 1; return 0;
    case 's': return stats_format_of(arg, &a->stats_format);
    case 'k': return packets_of(arg, &a->ro.packets);
    case 'p': a->bar = RD_BAR_ON; return 0;
    case 'q': a->bar = RD_BAR_OFF; return 0;
    default: return usage_error(c == ':' ? "%s needs a value" : "unknown option '%s'", arg);
    }
}

/* 0 with *a filled, HELP_PRINTED, or the exit status of a usage error. */
static int parse_args(int argc, char **argv, render_args *a)
{
    /* The letters are only the options' codes: the short options are -o
     * and -h alone (the optstring). */
    static const struct option opts[] = {{"output", required_argument, NULL, 'o'},
                                         {"threads", required_argument, NULL, 't'},
                                         {"png-level", required_argument, NULL, 'l'},
                                         {"help", no_argument, NULL, 'h'},
                                         {"time-budget-ms", required_argument, NULL, 'b'},
                                         {"target-error", required_argument, NULL, 'e'},
                                         {"adaptive", no_argument, NULL, 'a'},
                                         {"stats-format", required_argument, NULL, 's'},
                                         {"packets", required_argument, NULL, 'k'},
                                         {"progress", no_argument, NULL, 'p'},
                                         {"quiet", no_argument, NULL, 'q'},
                                         {NULL, 0, NULL, 0}};
    memset(a, 0, sizeof *a);
    a->threads = sysconf(_SC_NPROCESSORS_ONLN);
    if (a->threads < 1)
        a->threads = 1;
    a->level = -1;
    a->stats_format = STATS_TEXT;
    a->lim = rd_scene_limits_default();
    int rc = rd_cli_take_limits(&argc, argv, &a->lim, "rayd render", NULL);
    if (!rc)
        rc = rd_cli_take_overrides(&argc, argv, &a->ov, "rayd render", NULL);
    if (rc)
        return rc;
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":o:h", opts, NULL)) != -1) {
        rc = parse_option(c, c == '?' || c == ':' ? argv[optind - 1] : optarg, a);
        if (rc)
            return rc;
    }
    if (optind != argc - 1)
        return usage_error("%s", optind >= argc ? "expected one SCENE file" : "expected exactly one SCENE file");
    if (!a->output)
        return usage_error("%s", "missing -o OUT (a .png, .exr or .pfm file, or -)");
    if ((rc = out_kind_of(a->output, &a->kind)))
        return rc;
    /* EXR and PFM hold the linear image, before gamma: a --gamma there would
     * change nothing in the file, and a user who asked for it expects it to. */
    if (a->kind != OUT_PNG && rd_override_given(&a->ov, "gamma"))
        return usage_error("--gamma: %s holds the linear image, which gamma does not change; drop --gamma, or "
                           "write a .png",
                           a->kind == OUT_EXR ? "an .exr file" : "a .pfm file");
    if (strcmp(a->output, "-") == 0 && isatty(STDOUT_FILENO))
        return usage_error("%s", "-o -: stdout is a terminal; redirect it to a file or a program");
    a->scene = argv[optind];
    a->ro.threads = (int)a->threads;
    return 0;
}

/* What a render gives: a PNG needs only the 8-bit image, which a
 * one-sample render writes without a linear one (rd_render_rgb8); EXR and
 * PFM need the linear image. */
typedef struct {
    rd_image img; /* width and height always; rgb for EXR and PFM */
    uint8_t *rgb8;
} frame;

static void frame_free(frame *f)
{
    rd_image_free(&f->img);
    free(f->rgb8);
    f->rgb8 = NULL;
}

/* The image as a PNG's bytes. */
static rd_error_code encode_png(const frame *f, long level, unsigned char **out, size_t *len, rd_error *err)
{
    rd_png_options po = rd_png_options_default();
    if (level >= 0)
        po.level = (int)level;
    return rd_png_encode(f->rgb8, f->img.width, f->img.height, &po, out, len, err);
}

static rd_error_code write_stdout(const unsigned char *data, size_t len, rd_error *err)
{
    if (fwrite(data, 1, len, stdout) != len || fflush(stdout) != 0)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "-: cannot write to stdout: %s", strerror(errno));
    return RD_OK;
}

/* The image as OUT says: PNG, EXR or PFM, to the file or stdout. */
static rd_error_code write_output(const frame *f, const render_args *a, rd_error *err)
{
    unsigned char *data = NULL;
    size_t len = 0;
    rd_error_code rc = a->kind == OUT_EXR   ? rd_exr_encode(&f->img, &data, &len, err)
                       : a->kind == OUT_PFM ? rd_pfm_encode(&f->img, &data, &len, err)
                                            : encode_png(f, a->level, &data, &len, err);
    if (!rc)
        rc = strcmp(a->output, "-") == 0 ? write_stdout(data, len, err) : rd_write_file(a->output, data, len, err);
    free(data);
    return rc;
}

/* The frame OUT's kind needs; on an error it is empty. */
static rd_error_code render_frame(const rd_scene *scene, const render_args *a, frame *f, rd_render_stats *st,
                                  rd_error *err)
{
    memset(f, 0, sizeof *f);
    if (a->kind != OUT_PNG)
        return rd_render(scene, &a->ro, &f->img, st, err);
    f->rgb8 = malloc((size_t)scene->render.width * (size_t)scene->render.height * 3);
    if (!f->rgb8)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for a %dx%d image", scene->render.width,
                            scene->render.height);
    rd_error_code rc = rd_render_rgb8(scene, &a->ro, f->rgb8, st, err);
    if (rc)
        frame_free(f);
    f->img.width = rc ? 0 : scene->render.width;
    f->img.height = rc ? 0 : scene->render.height;
    return rc;
}

/* Renders with the progress a asks for. */
static rd_error_code render(const rd_scene *scene, render_args *a, frame *f, rd_render_stats *st, rd_error *err)
{
    rd_progress_settings goal = {scene->render.samples, a->ro.time_budget_ms, a->ro.target_error, a->ro.adaptive};
    rd_progress_bar bar;
    rd_progress_bar_init(&bar, a->bar, &goal, "render");
    rd_progress_bar_attach(&bar, &a->ro);
    rd_error_code rc = render_frame(scene, a, f, st, err);
    rd_progress_bar_end(&bar);
    return rc;
}

int rd_cmd_render(int argc, char **argv)
{
    render_args a;
    int prc = parse_args(argc, argv, &a);
    if (prc)
        return prc == HELP_PRINTED ? RD_EXIT_OK : prc;
    rd_error err = {0};
    /* An output that cannot be written fails now, not after the render. */
    if (strcmp(a.output, "-") != 0 && rd_check_writable(a.output, &err)) {
        fprintf(stderr, "rayd render: %s\n", err.message);
        return RD_EXIT_IO;
    }
    rd_scene scene;
    rd_scene_init(&scene);
    rd_scene_source src = {.path = a.scene, .threads = a.ro.threads};
    rd_warnings warnings = {0, ""};
    rd_error_code rc = rd_scene_open(&src, &a.ov, &a.lim, &scene, &warnings, &err);
    if (warnings.count)
        fprintf(stderr, "%s%s", warnings.text, warnings.count > 5 ? "(more warnings not shown)\n" : "");
    frame f;
    rd_render_stats st;
    if (!rc && (rc = render(&scene, &a, &f, &st, &err)))
        fprintf(stderr, "%s: %s\n", a.scene, err.message);
    else if (rc)
        fprintf(stderr, "%s\n", err.message);
    if (rc) {
        rd_scene_free(&scene);
        return rd_error_answer_for(rc).exit;
    }
    rc = write_output(&f, &a, &err);
    if (a.stats_format & STATS_TEXT)
        stats_text(&f.img, &st);
    if ((a.stats_format & STATS_JSON) && stats_json(&f.img, &st) && !rc)
        rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory writing the statistics");
    frame_free(&f);
    rd_scene_free(&scene);
    if (rc) {
        fprintf(stderr, "rayd render: %s\n", err.message);
        return RD_EXIT_IO;
    }
    return RD_EXIT_OK;
}
