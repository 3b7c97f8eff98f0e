#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "grading.h"
#include "png_write.h"
#include "asset_source.h"
#include "scene_load.h"
#include "file_io.h"

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
    "  --assignments DIR    the assignments folder (default scenes/assignments)\n"
    "  --cache-dir DIR      where references are cached (default: none)\n"
    "  --threads N          render threads for the reference (default: the cores)\n"
    "\n"
    "Exit status: 0 pass; 4 graded, fail; 1 usage; 2 bad scene or image (not a\n"
    "PNG, wrong size); 3 a file could not be read or written.\n";

int rd_cmd_grade(int argc, char **argv)
{
    enum { O_ASSIGN = 256, O_SCENE, O_IMAGE, O_DIFF, O_DIR, O_CACHE, O_THREADS };
    static const struct option opts[] = {
        {"assignment", required_argument, NULL, O_ASSIGN}, {"scene", required_argument, NULL, O_SCENE},
        {"image", required_argument, NULL, O_IMAGE}, {"diff", required_argument, NULL, O_DIFF},
        {"assignments", required_argument, NULL, O_DIR}, {"cache-dir", required_argument, NULL, O_CACHE},
        {"threads", required_argument, NULL, O_THREADS}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    const char *assignment = NULL, *scene = NULL, *image = NULL, *diff = NULL;
    rd_grader g;
    memset(&g, 0, sizeof g);
    g.assignments_dir = "scenes/assignments";
    g.limits = rd_scene_limits_default();
    long threads = sysconf(_SC_NPROCESSORS_ONLN);
    g.threads = threads > 0 ? (int)threads : 1;
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'h': fputs(grade_help, stdout); return RD_EXIT_OK;
        case O_ASSIGN: assignment = optarg; break;
        case O_SCENE: scene = optarg; break;
        case O_IMAGE: image = optarg; break;
        case O_DIFF: diff = optarg; break;
        case O_DIR: g.assignments_dir = optarg; break;
        case O_CACHE: g.cache_dir = optarg; break;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &threads)) {
                fprintf(stderr, "rayd grade: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                return RD_EXIT_USAGE;
            }
            g.threads = (int)threads;
            break;
        default:
            fprintf(stderr, "rayd grade: bad option '%s' (try 'rayd grade --help')\n", argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
    }
    if (optind != argc || !image || (!assignment == !scene)) {
        fprintf(stderr, "rayd grade: give --image and exactly one of --assignment or --scene (try 'rayd grade --help')\n");
        return RD_EXIT_USAGE;
    }
    rd_error err = {0};
    char *png = NULL, *text = NULL;
    size_t png_len = 0, text_len = 0;
    rd_error_code rc = rd_read_file(image, 1u << 30, "(1 GiB)", &png, &png_len, &err);
    if (!rc && scene)
        rc = rd_read_file(scene, g.limits.max_bytes, "--max-scene-bytes", &text, &text_len, &err);
    if (rc) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        free(png);
        return RD_EXIT_IO;
    }
    char *scene_dir = scene ? rd_dirname(scene) : NULL;
    g.assets_dir = scene_dir;
    rd_grade_output out;
    rc = rd_grade_run(&g, assignment, text, text_len, scene, (unsigned char *)png, png_len, &out, &err);
    free(png);
    free(text);
    free(scene_dir);
    if (rc) {
        fprintf(stderr, "%s%s\n", out.status == RD_GRADE_BAD_SCENE ? "" : "rayd grade: ", err.message);
        return out.status == RD_GRADE_UNKNOWN_ASSIGNMENT ? RD_EXIT_USAGE : RD_EXIT_SCENE;
    }
    int status = out.result.pass ? RD_EXIT_OK : 4;
    if (diff) {
        uint8_t *heat = malloc((size_t)out.width * (size_t)out.height * 3);
        unsigned char *pngout = NULL;
        size_t len = 0;
        rc = heat ? RD_OK : rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory");
        if (!rc) {
            rd_grade_heatmap(out.reference, out.image, out.width, out.height, out.thresholds.fail, heat);
            rd_png_options po = rd_png_options_default();
            rc = rd_png_encode(heat, out.width, out.height, &po, &pngout, &len, &err);
        }
        if (!rc)
            rc = rd_write_file(diff, pngout, len, &err);
        free(heat);
        free(pngout);
        if (rc) {
            fprintf(stderr, "rayd grade: %s\n", err.message);
            status = RD_EXIT_IO;
        }
    }
    char *json = rd_grade_json(&out, NULL);
    if (json) {
        fputs(json, stdout);
        fputc('\n', stdout);
        free(json);
    }
    rd_grade_output_free(&out);
    return status;
}
