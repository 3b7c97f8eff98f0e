#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "file_io.h"
#include "grading.h"
#include "json_text.h"
#include "png_write.h"
#include "version.h"

static const char grade_help[] =
    "usage: rayd grade (--assignment NAME | --scene FILE) --image FILE [options]\n"
    "\n"
    "Compares a student's rendering with rayd's reference for the same scene and\n"
    "prints the verdict as JSON (docs/grading.md): pass or fail, RMSE, PSNR, SSIM,\n"
    "the failed pixels and where they are.\n"
    "\n"
    "  --assignment NAME    an assignment of --assignments (e.g. phong)\n"
    "  --scene FILE         or any scene file\n"
    "  --image FILE         the student's PNG (any layout: grey, palette, alpha, 16-bit)\n"
    "  --diff OUT.png       write the heat map of where the image differs\n"
    "  --assignments DIR    the assignments folder (default: scenes/assignments in the data folder)\n"
    "  --cache-dir DIR      where references are cached (default: none)\n"
    "  --threads N          render threads for the reference (default: the cores)\n"
    "  --limit-...  N       a size limit; 'rayd limits' lists them with defaults\n"
    "\n"
    "With --scene, the render overrides below change the scene before its\n"
    "reference is rendered; an assignment is graded as it is, without them.\n"
    "\n"
    "Exit status: 0 pass; 4 graded, fail; 1 usage or no such assignment; 2 bad\n"
    "scene, assignment or image (not a PNG, damaged, wrong size); 3 a file could\n"
    "not be read or written. Errors are those of POST /v1/grade for the same\n"
    "input (docs/grading.md).\n";

/* The heat map of where the image differs, as a PNG file. */
static rd_error_code write_diff(const rd_grade_output *o, const char *path, rd_error *err)
{
    uint8_t *heat = malloc((size_t)o->width * (size_t)o->height * 3);
    if (!heat)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_grade_heatmap(o->reference, o->image, o->width, o->height, o->thresholds.fail, heat);
    unsigned char *png = NULL;
    size_t len = 0;
    rd_png_options po = rd_png_options_default();
    rd_error_code rc = rd_png_encode(heat, o->width, o->height, &po, &png, &len, err);
    free(heat);
    if (!rc)
        rc = rd_write_file(path, png, len, err);
    free(png);
    return rc;
}

/* Prints the verdict; the exit status of a graded image. */
static int report(const rd_grade_output *o, const char *diff)
{
    int status = o->result.pass ? RD_EXIT_OK : RD_EXIT_GRADE_FAIL;
    rd_error err = {0};
    if (diff && write_diff(o, diff, &err)) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        status = RD_EXIT_IO;
    }
    char *json = rd_json_print(rd_grade_json(o));
    if (!json) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    fputs(json, stdout);
    free(json);
    return status;
}

int rd_cmd_grade(int argc, char **argv)
{
    enum { O_ASSIGN = 256, O_SCENE, O_IMAGE, O_DIFF, O_DIR, O_CACHE, O_THREADS };
    static const struct option opts[] = {{"assignment", required_argument, NULL, O_ASSIGN},
                                         {"scene", required_argument, NULL, O_SCENE},
                                         {"image", required_argument, NULL, O_IMAGE},
                                         {"diff", required_argument, NULL, O_DIFF},
                                         {"assignments", required_argument, NULL, O_DIR},
                                         {"cache-dir", required_argument, NULL, O_CACHE},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    rd_grade_input in = {0};
    const char *image = NULL, *diff = NULL, *cache_dir = NULL;
    rd_grader g = {.assignments_dir = rd_default_assignments_dir(), .limits = rd_scene_limits_default()};
    rd_scene_overrides ov = {0};
    int lrc = rd_cli_take_limits(&argc, argv, &g.limits, "rayd grade", NULL);
    if (!lrc)
        lrc = rd_cli_take_overrides(&argc, argv, &ov, "rayd grade", NULL);
    if (lrc)
        return lrc;
    in.ov = &ov;
    long threads = sysconf(_SC_NPROCESSORS_ONLN);
    if (threads < 1)
        threads = 1;
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(grade_help, stdout);
            rd_cli_overrides_help(stdout, NULL);
            return RD_EXIT_OK;
        case O_ASSIGN: in.assignment = optarg; break;
        case O_SCENE: in.scene_path = optarg; break;
        case O_IMAGE: image = optarg; break;
        case O_DIFF: diff = optarg; break;
        case O_DIR: g.assignments_dir = optarg; break;
        case O_CACHE: cache_dir = optarg; break;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &threads)) {
                fprintf(stderr, "rayd grade: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                return RD_EXIT_USAGE;
            }
            break;
        default:
            fprintf(stderr, "rayd grade: bad option '%s' (try 'rayd grade --help')\n", argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
    }
    if (optind != argc || !image || (!in.assignment == !in.scene_path)) {
        fprintf(stderr,
                "rayd grade: give --image and exactly one of --assignment or --scene (try 'rayd grade --help')\n");
        return RD_EXIT_USAGE;
    }
    if (in.assignment && ov.set) {
        fprintf(stderr, "rayd grade: an assignment is graded as it is: render overrides go with --scene only\n");
        return RD_EXIT_USAGE;
    }
    rd_error err = {0};
    char *png = NULL;
    /* The upload limit of the daemon: a PNG over the body limit is refused
     * there before it is read, here likewise. */
    rd_error_code rc =
        rd_read_file(image, RD_GRADE_MAX_PNG_BYTES, "the largest PNG graded, 1 GiB", &png, &in.png_len, &err);
    if (rc) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        return rd_error_answer_for(rc).exit;
    }
    in.png = (const unsigned char *)png;
    /* Only references on disk: one process grades one image. */
    if (cache_dir && !(g.cache = rd_ref_cache_new(0, cache_dir, NULL, NULL))) {
        free(png);
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    rd_grade_output out;
    rc = rd_grade_run(&g, &in, (int)threads, &out, &err);
    free(png);
    int status;
    if (rc) {
        /* The daemon never names its folders; the command line does. */
        fprintf(stderr, "rayd grade: %s\n", err.message);
        if (rc == RD_ERR_NOT_FOUND && in.assignment)
            fprintf(stderr, "rayd grade: searched %s (--assignments DIR names another folder)\n", g.assignments_dir);
        status = rd_grade_error_answer(out.stage, rc).exit;
    } else {
        status = report(&out, diff);
    }
    rd_grade_output_free(&out);
    rd_ref_cache_free(g.cache);
    return status;
}
