/* rayd grade --code: a student's calcReflectedLight graded in the sandbox
 * (codegrade.h), the same pipeline and answer as POST /v1/grade/code. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "code_frames.h"
#include "codegrade.h"
#include "file_io.h"
#include "json_text.h"
#include "version.h"

static const char help[] =
    "usage: rayd grade --assignment NAME --code FILE [options]\n"
    "\n"
    "Grades a student's calcReflectedLight (docs/grading.md, \"Grading code\"): the\n"
    "file (PhongMaterial.h, or a .cpp defining PhongMaterial::calcReflectedLight) is\n"
    "compiled with the course's headers inside a sandbox (bubblewrap), called on\n"
    "fixed configurations and on every shading point of the assignment's scene,\n"
    "and the image it makes is graded against the reference. Prints a summary:\n"
    "the verdict, then each cause of what fails (why the code does not compile,\n"
    "or the configurations' causes) with its words and one example. --json\n"
    "prints the whole answer of POST /v1/grade/code instead: the compiler's\n"
    "messages, every configuration group, the image's verdict, what the code\n"
    "printed.\n"
    "\n"
    "  --assignment NAME    an assignment of --assignments (e.g. phong)\n"
    "  --code FILE          the student's file\n"
    "  --diff OUT.png       write the heat map of where the image differs\n"
    "  --json               print the answer as JSON, not the summary\n"
    "  --assignments DIR    the assignments folder (default: scenes/assignments in the data folder)\n"
    "  --course DIR         the course's headers and adapter (default: %s)\n"
    "  --code-eval PATH     the evaluator (default: %s)\n"
    "  --bwrap PATH         bubblewrap (default: /usr/bin/bwrap)\n"
    "  --threads N          render threads for the reference (default: the cores)\n"
    "\n"
    "Exit status: 0 pass; 4 graded and failing; 2 the code does not compile (the\n"
    "summary shows why and the first error, --json all the compiler's messages),\n"
    "the file is not C++ text, or the assignment has no material a student\n"
    "writes; 1 usage or no such assignment; 3 a file could not be read or\n"
    "written, or the sandbox cannot start here.\n";

/* The summary for a person, the diff written as with --json. */
static int summarize(cJSON *answer, const rd_grade_output *o, const char *diff, int status)
{
    rd_error err = {0};
    char *text = answer ? rd_codegrade_summary(answer) : NULL;
    cJSON_Delete(answer);
    if (!text) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    fputs(text, stdout);
    free(text);
    if (diff && o && rd_cli_write_diff(o, diff, &err)) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        status = RD_EXIT_IO;
    }
    return status;
}

static int report(const rd_codegrade_result *r, const char *diff, int json)
{
    int status = r->pass ? RD_EXIT_OK : r->compile.result != 0 ? RD_EXIT_SCENE : RD_EXIT_GRADE_FAIL;
    if (r->compile.result != 0)
        fprintf(stderr, "rayd grade: the code does not compile%s\n",
                r->compile.result == RD_COMPILE_TIME_LIMIT ? " within the time limit" : "");
    const rd_grade_output *o = r->image_graded ? &r->grade : NULL;
    if (json)
        return rd_cli_grade_report(rd_codegrade_json(r), o, diff, status);
    return summarize(rd_codegrade_json(r), o, diff, status);
}

static int run(rd_codegrade_config *cfg, const char *assignment, const char *path, const char *diff, int json)
{
    rd_error err = {0};
    char *text = NULL;
    size_t len = 0;
    if (rd_read_file(path, cfg->max_bytes, "--max-code-bytes", &text, &len, &err)) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        return RD_EXIT_IO;
    }
    const char *slash = strrchr(path, '/');
    rd_codegrade_input in = {assignment, slash ? slash + 1 : path, text, len};
    rd_codegrade_result r;
    rd_error_code rc = rd_codegrade_run(cfg, &in, &r, &err);
    int status;
    if (rc) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        if (rc == RD_ERR_NOT_FOUND && r.grade.stage == RD_GRADE_STAGE_ASSIGNMENT)
            fprintf(stderr, "rayd grade: searched %s (--assignments DIR names another folder)\n",
                    cfg->grader.assignments_dir);
        status = rd_code_error_answer(r.grade.stage, rc).exit;
    } else {
        status = report(&r, diff, json);
    }
    rd_codegrade_result_free(&r);
    free(text);
    return status;
}

int rd_cmd_grade_code(int argc, char **argv)
{
    enum { O_ASSIGN = 256, O_CODE, O_DIFF, O_JSON, O_ASSIGNMENTS, O_COURSE, O_EVAL, O_BWRAP, O_THREADS };
    static const struct option opts[] = {{"assignment", required_argument, NULL, O_ASSIGN},
                                         {"code", required_argument, NULL, O_CODE},
                                         {"diff", required_argument, NULL, O_DIFF},
                                         {"json", no_argument, NULL, O_JSON},
                                         {"assignments", required_argument, NULL, O_ASSIGNMENTS},
                                         {"course", required_argument, NULL, O_COURSE},
                                         {"code-eval", required_argument, NULL, O_EVAL},
                                         {"bwrap", required_argument, NULL, O_BWRAP},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    rd_codegrade_config cfg = rd_codegrade_config_default();
    cfg.grader.assignments_dir = rd_default_assignments_dir();
    cfg.grader.limits = rd_scene_limits_default();
    cfg.course_dir = rd_default_course_dir();
    cfg.eval = rd_default_eval_path();
    cfg.bwrap = "/usr/bin/bwrap";
    long threads = sysconf(_SC_NPROCESSORS_ONLN);
    const char *assignment = NULL, *code = NULL, *diff = NULL;
    int json = 0;
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf(help, rd_default_course_dir(), rd_default_eval_path());
            return RD_EXIT_OK;
        }
    optind = 1;
    opterr = 0;
    for (int c; (c = getopt_long(argc, argv, ":h", opts, NULL)) != -1;) {
        switch (c) {
        case 'h': printf(help, rd_default_course_dir(), rd_default_eval_path()); return RD_EXIT_OK;
        case O_ASSIGN: assignment = optarg; break;
        case O_CODE: code = optarg; break;
        case O_DIFF: diff = optarg; break;
        case O_JSON: json = 1; break;
        case O_ASSIGNMENTS: cfg.grader.assignments_dir = optarg; break;
        case O_COURSE: cfg.course_dir = optarg; break;
        case O_EVAL: cfg.eval = optarg; break;
        case O_BWRAP: cfg.bwrap = optarg; break;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &threads)) {
                fprintf(stderr, "rayd grade: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                return RD_EXIT_USAGE;
            }
            break;
        default:
            fprintf(stderr, "rayd grade: bad option '%s' with --code (try 'rayd grade --code --help')\n",
                    argv[optind - 1]);
            return RD_EXIT_USAGE;
        }
    }
    if (optind != argc || !assignment || !code) {
        fprintf(stderr, "rayd grade: give --assignment NAME and --code FILE (try 'rayd grade --code --help')\n");
        return RD_EXIT_USAGE;
    }
    cfg.threads = threads < 1 ? 1 : (int)threads;
    return run(&cfg, assignment, code, diff, json);
}
