#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "assignment.h"
#include "cli.h"
#include "file_io.h"
#include "grade_table.h"
#include "grading.h"
#include "json_text.h"
#include "png_write.h"
#include "rayd/clock.h"
#include "rayd/memory.h"
#include "version.h"

static const char grade_help[] =
    "usage: rayd grade (--assignment NAME | --scene FILE) --image FILE [options]\n"
    "       rayd grade (--assignment NAME | --scene FILE) (--image FILE ... | --dir FOLDER) [--csv OUT.csv]\n"
    "       rayd grade --assignment NAME --code FILE   (a student's calcReflectedLight: rayd grade --code --help)\n"
    "\n"
    "Compares a student's rendering with rayd's reference for the same scene and\n"
    "prints the verdict as JSON (docs/grading.md): pass or fail, RMSE, PSNR, SSIM,\n"
    "the failed pixels and where they are.\n"
    "\n"
    "Given several images (--image more than once, or --dir), or --csv, it grades\n"
    "a class: the reference is rendered once, and it prints one line per student\n"
    "(the image's file name without its extension) and a summary line. An image\n"
    "that cannot be graded (not a PNG, damaged, wrong size, unreadable) is that\n"
    "student's error line and row; the others are graded all the same.\n"
    "\n"
    "  --assignment NAME    an assignment of --assignments (e.g. phong)\n"
    "  --scene FILE         or any scene file\n"
    "  --image FILE         a student's PNG (any layout: grey, palette, alpha, 16-bit);\n"
    "                       give it again for every student\n"
    "  --dir FOLDER         every *.png of FOLDER (any case, not hidden), sorted by name\n"
    "  --csv OUT.csv        write the class's table (docs/grading.md, \"Grading a class\")\n"
    "  --diff OUT.png       write the heat map of where the image differs (one image only)\n"
    "  --assignments DIR    the assignments folder (default: scenes/assignments in the data folder)\n"
    "  --cache-dir DIR      where references are cached (default: none)\n"
    "  --threads N          render threads for the reference (default: the cores)\n"
    "  --limit-...  N       a size limit; 'rayd limits' lists them with defaults\n"
    "\n"
    "With --scene, the render overrides below change the scene before its\n"
    "reference is rendered; an assignment is graded as it is, without them.\n"
    "\n"
    "Exit status: 0 pass (a class: every student passes); 4 graded, fail (a class:\n"
    "some student fails or has an error row); 1 usage or no such assignment; 2 bad\n"
    "scene, assignment or image (not a PNG, damaged, wrong size); 3 a file could\n"
    "not be read or written. Errors are those of POST /v1/grade for the same\n"
    "input (docs/grading.md).\n";

rd_error_code rd_cli_write_diff(const rd_grade_output *o, const char *path, rd_error *err)
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

int rd_cli_grade_report(cJSON *verdict, const rd_grade_output *o, const char *diff, int status)
{
    rd_error err = {0};
    if (diff && o && rd_cli_write_diff(o, diff, &err)) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        status = RD_EXIT_IO;
    }
    char *json = rd_json_print(verdict);
    if (!json) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    fputs(json, stdout);
    free(json);
    return status;
}

/* Prints the verdict; the exit status of a graded image. */
static int report(const rd_grade_output *o, const char *diff)
{
    return rd_cli_grade_report(rd_grade_json(o), o, diff, o->result.pass ? RD_EXIT_OK : RD_EXIT_GRADE_FAIL);
}

/* A grade's error that is not a student's: the message, and the status. */
static int run_error(const rd_grader *g, const rd_grade_input *in, const rd_grade_output *o, rd_error_code rc,
                     const rd_error *err)
{
    /* The daemon never names its folders; the command line does. */
    fprintf(stderr, "rayd grade: %s\n", err->message);
    if (rc == RD_ERR_NOT_FOUND && in->assignment)
        fprintf(stderr, "rayd grade: searched %s (--assignments DIR names another folder)\n", g->assignments_dir);
    return rd_grade_error_answer(o->stage, rc).exit;
}

/* One image: the verdict JSON, as POST /v1/grade answers it. */
static int grade_one(rd_grader *g, rd_grade_input *in, const char *image, const char *diff, const char *cache_dir,
                     int threads)
{
    rd_error err = {0};
    char *png = NULL;
    /* The upload limit of the daemon: a PNG over the body limit is refused
     * there before it is read, here likewise. */
    rd_error_code rc =
        rd_read_file(image, RD_GRADE_MAX_PNG_BYTES, "the largest PNG graded, 1 GiB", &png, &in->png_len, &err);
    if (rc) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        return rd_error_answer_for(rc).exit;
    }
    in->png = (const unsigned char *)png;
    /* Only references on disk: one process grades one image. */
    if (cache_dir && !(g->cache = rd_ref_cache_new(0, cache_dir, NULL, NULL))) {
        free(png);
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    rd_grade_output out;
    rc = rd_grade_run(g, in, threads, &out, &err);
    free(png);
    int status = rc ? run_error(g, in, &out, rc, &err) : report(&out, diff);
    rd_grade_output_free(&out);
    rd_ref_cache_free(g->cache);
    g->cache = NULL;
    return status;
}

/* A class: each student's image and id (its file name without the
 * extension), both malloc'ed. */
typedef struct {
    char *path, *student;
} student_image;

typedef struct {
    student_image *v;
    size_t n, cap;
} class_list;

static void class_free(class_list *c)
{
    for (size_t i = 0; i < c->n; i++) {
        free(c->v[i].path);
        free(c->v[i].student);
    }
    free(c->v);
}

/* Appends a copy of path; 0, or -1 when out of memory. */
static int class_add(class_list *c, const char *path)
{
    if (!rd_grow_array((void **)&c->v, &c->cap, c->n + 1, sizeof *c->v, 16))
        return -1;
    const char *slash = strrchr(path, '/');
    const char *base = slash && slash[1] ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    size_t len = dot && dot > base ? (size_t)(dot - base) : strlen(base);
    student_image *s = &c->v[c->n];
    s->path = strdup(path);
    s->student = strndup(base, len);
    if (!s->path || !s->student) {
        free(s->path);
        free(s->student);
        return -1;
    }
    c->n++;
    return 0;
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Adds folder's *.png (any case; hidden files are left out, as a shell's
 * *.png leaves them), sorted by name in byte order. 0 or an exit status. */
static int class_add_dir(class_list *c, const char *folder)
{
    DIR *d = opendir(folder);
    if (!d) {
        fprintf(stderr, "rayd grade: --dir %s: cannot open: %s\n", folder, strerror(errno));
        return RD_EXIT_IO;
    }
    char **names = NULL;
    size_t n = 0, cap = 0;
    int status = RD_EXIT_OK;
    struct dirent *e;
    while (!status && (e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (e->d_name[0] == '.' || len < 5 || strcasecmp(e->d_name + len - 4, ".png") != 0)
            continue;
        if (!rd_grow_array((void **)&names, &cap, n + 1, sizeof *names, 64)) {
            status = RD_EXIT_SCENE;
            break;
        }
        if (!(names[n] = strdup(e->d_name)))
            status = RD_EXIT_SCENE;
        else
            n++;
    }
    closedir(d);
    if (n)
        qsort(names, n, sizeof *names, by_name);
    size_t flen = strlen(folder);
    int sep = flen > 0 && folder[flen - 1] != '/';
    for (size_t i = 0; i < n && !status; i++) {
        char *path = malloc(flen + (size_t)sep + strlen(names[i]) + 1);
        if (!path) {
            status = RD_EXIT_SCENE;
            break;
        }
        sprintf(path, "%s%s%s", folder, sep ? "/" : "", names[i]);
        if (class_add(c, path))
            status = RD_EXIT_SCENE;
        free(path);
    }
    for (size_t i = 0; i < n; i++)
        free(names[i]);
    free(names);
    if (status)
        fprintf(stderr, "rayd grade: out of memory\n");
    return status;
}

static int by_student(const void *a, const void *b)
{
    const student_image *x = *(const student_image *const *)a, *y = *(const student_image *const *)b;
    return strcmp(x->student, y->student);
}

/* Every id makes a row, and names one image only. 0 or an exit status. */
static int class_check_ids(const class_list *c)
{
    for (size_t i = 0; i < c->n; i++) {
        rd_grade_row row;
        rd_error err = {0};
        if (rd_grade_row_error(&row, c->v[i].student, NULL, NULL, 0, &err)) {
            fprintf(stderr, "rayd grade: %s: %s\n", c->v[i].path, err.message);
            return RD_EXIT_USAGE;
        }
    }
    const student_image **v = malloc(c->n * sizeof *v);
    if (!v) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    for (size_t i = 0; i < c->n; i++)
        v[i] = &c->v[i];
    qsort(v, c->n, sizeof *v, by_student);
    int status = RD_EXIT_OK;
    for (size_t i = 1; i < c->n && !status; i++) {
        if (!strcmp(v[i - 1]->student, v[i]->student)) {
            fprintf(stderr, "rayd grade: %s and %s are both student '%s': one image per student\n", v[i - 1]->path,
                    v[i]->path, v[i]->student);
            status = RD_EXIT_USAGE;
        }
    }
    free(v);
    return status;
}

/* Text for a line of its own: control characters (a newline in a file
 * name) are written '?'. */
static void put_clean(const char *s)
{
    for (; *s; s++)
        putchar((unsigned char)*s < 0x20 || *s == 0x7f ? '?' : *s);
}

static void print_row(const rd_grade_row *row)
{
    fputs("student ", stdout);
    put_clean(row->student);
    if (rd_grade_row_is_error(row)) {
        fputs(": error: ", stdout);
        put_clean(row->error);
        putchar('\n');
    } else {
        printf(": %s failed_fraction=%.4g max_abs=%d psnr_db=%.2f ssim=%.4f\n", row->pass ? "pass" : "fail",
               row->failed_fraction, row->max_abs, row->psnr_db, row->ssim);
    }
    fflush(stdout);
}

/* A row's score of the assignment's points (docs/grading.md, "A term").
 * The command grades what its user collected: on time, whatever the
 * assignment's due time. A scene's rows have none. */
static void score_row(const rd_grader *g, const char *assignment, rd_grade_row *row)
{
    rd_assignment a;
    rd_error err = {0};
    if (!assignment || rd_assignment_load(g->assignments_dir, assignment, &a, &err))
        return;
    rd_term_outcome o = {
        .graded = !rd_grade_row_is_error(row), .pass = row->pass, .failed_fraction = row->failed_fraction};
    snprintf(row->kind, sizeof row->kind, "image");
    row->points = a.term.points;
    row->score = rd_term_score(&a.term, &o);
}

/* Grades one student of the class into row. RD_OK with the row made
 * (graded or an error row), else an error of the whole run, with *status. */
static rd_error_code grade_student(const rd_grader *g, const rd_grade_input *class_in, const student_image *s,
                                   int threads, int *seen_reference, rd_grade_row *row, int *status)
{
    rd_error err = {0};
    rd_grade_input in = *class_in;
    char *png = NULL;
    rd_error_code rc =
        rd_read_file(s->path, RD_GRADE_MAX_PNG_BYTES, "the largest PNG graded, 1 GiB", &png, &in.png_len, &err);
    if (rc) {
        rd_grade_row_error(row, s->student, class_in->assignment, err.message, rd_wall_ms(), NULL);
        score_row(g, class_in->assignment, row);
        return RD_OK;
    }
    in.png = (const unsigned char *)png;
    rd_grade_output out;
    rc = rd_grade_run(g, &in, threads, &out, &err);
    free(png);
    if (rc == RD_OK) {
        /* What shows the reference was rendered once: a line each time. */
        if (!out.reference_cached) {
            fprintf(stderr, "rayd grade: reference rendered (key %s)\n", out.key);
        } else if (!*seen_reference) {
            fprintf(stderr, "rayd grade: reference read from the cache (key %s)\n", out.key);
        }
        *seen_reference = 1;
        rc = rd_grade_row_from_output(row, s->student, &out, rd_wall_ms(), &err);
        if (rc)
            *status = run_error(g, class_in, &out, rc, &err);
    } else if (out.stage == RD_GRADE_STAGE_IMAGE) {
        rd_grade_row_error(row, s->student, out.assignment, err.message, rd_wall_ms(), NULL);
        rc = RD_OK;
    } else {
        *status = run_error(g, class_in, &out, rc, &err);
    }
    rd_grade_output_free(&out);
    if (rc == RD_OK)
        score_row(g, class_in->assignment, row);
    return rc;
}

/* Opens the scene with no image, so that a bad assignment or scene ends
 * the run as it would for one image, before any student is read. */
static int check_scene(const rd_grader *g, const rd_grade_input *in)
{
    static const unsigned char nothing[1];
    rd_grade_input probe = *in;
    probe.png = nothing;
    probe.png_len = 0;
    rd_scene s;
    rd_scene_init(&s);
    rd_grade_output o;
    rd_error err = {0};
    rd_error_code rc = rd_grade_prepare(g, &probe, &s, &o, &err);
    rd_scene_free(&s);
    int status = rc && o.stage != RD_GRADE_STAGE_IMAGE ? run_error(g, in, &o, rc, &err) : RD_EXIT_OK;
    rd_grade_output_free(&o);
    return status;
}

/* A class: a line per student, the summary, the CSV; 0 when every student
 * passes, 4 when one does not, else the status of what ended the run. */
static int grade_class(rd_grader *g, rd_grade_input *in, const class_list *c, const char *csv, const char *cache_dir,
                       int threads)
{
    rd_error err = {0};
    if (csv && rd_check_writable(csv, &err)) {
        fprintf(stderr, "rayd grade: --csv %s\n", err.message);
        return RD_EXIT_IO;
    }
    int status = check_scene(g, in);
    if (status)
        return status;
    /* In memory, so that every student after the first is compared with
     * the same reference (and on disk with --cache-dir). */
    if (!(g->cache = rd_ref_cache_new(SIZE_MAX, cache_dir, NULL, NULL))) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    rd_strbuf table = {0};
    rd_grade_csv_header(&table);
    size_t passed = 0, failed = 0, errors = 0;
    int seen_reference = 0;
    for (size_t i = 0; i < c->n && !status; i++) {
        rd_grade_row row;
        if (grade_student(g, in, &c->v[i], threads, &seen_reference, &row, &status))
            break;
        print_row(&row);
        rd_grade_csv_row(&table, &row);
        if (rd_grade_row_is_error(&row))
            errors++;
        else if (row.pass)
            passed++;
        else
            failed++;
    }
    rd_ref_cache_free(g->cache);
    g->cache = NULL;
    if (status) {
        rd_strbuf_free(&table);
        return status;
    }
    printf("summary: %zu student%s of %s: %zu pass, %zu fail, %zu error%s\n", c->n, c->n == 1 ? "" : "s",
           in->assignment ? in->assignment : in->scene_path, passed, failed, errors, errors == 1 ? "" : "s");
    fflush(stdout);
    size_t len = 0;
    char *text = rd_strbuf_take(&table, &len);
    if (csv && !text) {
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    if (csv && rd_write_file(csv, text, len, &err)) {
        fprintf(stderr, "rayd grade: %s\n", err.message);
        free(text);
        return RD_EXIT_IO;
    }
    free(text);
    return passed == c->n ? RD_EXIT_OK : RD_EXIT_GRADE_FAIL;
}

/* The students of every --image and --dir, in the order given. 0 or an
 * exit status. */
static int class_make(class_list *c, char **src, const int *is_dir, int n)
{
    int status = RD_EXIT_OK;
    for (int i = 0; i < n && !status; i++) {
        if (is_dir[i]) {
            status = class_add_dir(c, src[i]);
        } else if (class_add(c, src[i])) {
            fprintf(stderr, "rayd grade: out of memory\n");
            status = RD_EXIT_SCENE;
        }
    }
    if (!status && !c->n) {
        fprintf(stderr, "rayd grade: no image to grade: the --dir folder has no *.png file\n");
        status = RD_EXIT_USAGE;
    }
    return status;
}

int rd_cmd_grade(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--code") == 0 || strncmp(argv[i], "--code=", 7) == 0)
            return rd_cmd_grade_code(argc, argv);
    enum { O_ASSIGN = 256, O_SCENE, O_IMAGE, O_DIFF, O_ASSIGNMENTS, O_CACHE, O_THREADS, O_DIR, O_CSV };
    static const struct option opts[] = {{"assignment", required_argument, NULL, O_ASSIGN},
                                         {"scene", required_argument, NULL, O_SCENE},
                                         {"image", required_argument, NULL, O_IMAGE},
                                         {"dir", required_argument, NULL, O_DIR},
                                         {"csv", required_argument, NULL, O_CSV},
                                         {"diff", required_argument, NULL, O_DIFF},
                                         {"assignments", required_argument, NULL, O_ASSIGNMENTS},
                                         {"cache-dir", required_argument, NULL, O_CACHE},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    rd_grade_input in = {0};
    const char *diff = NULL, *cache_dir = NULL, *csv = NULL;
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
    /* Every --image and --dir, in order: each --image is one more student
     * (it used to replace the one before). */
    char **src = malloc((size_t)argc * sizeof *src);
    int *is_dir = malloc((size_t)argc * sizeof *is_dir);
    if (!src || !is_dir) {
        free(src);
        free(is_dir);
        fprintf(stderr, "rayd grade: out of memory\n");
        return RD_EXIT_SCENE;
    }
    int n_src = 0, images = 0, dirs = 0, status = RD_EXIT_OK;
    optind = 1;
    opterr = 0;
    int c;
    while (!status && (c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(grade_help, stdout);
            rd_cli_overrides_help(stdout, NULL);
            free(src);
            free(is_dir);
            return RD_EXIT_OK;
        case O_ASSIGN: in.assignment = optarg; break;
        case O_SCENE: in.scene_path = optarg; break;
        case O_IMAGE:
        case O_DIR:
            is_dir[n_src] = c == O_DIR;
            src[n_src++] = optarg;
            images += c == O_IMAGE;
            dirs += c == O_DIR;
            break;
        case O_CSV: csv = optarg; break;
        case O_DIFF: diff = optarg; break;
        case O_ASSIGNMENTS: g.assignments_dir = optarg; break;
        case O_CACHE: cache_dir = optarg; break;
        case O_THREADS:
            if (rd_cli_int(optarg, 1, 1024, &threads)) {
                fprintf(stderr, "rayd grade: --threads: expected an integer in 1..1024, got '%s'\n", optarg);
                status = RD_EXIT_USAGE;
            }
            break;
        default:
            fprintf(stderr, "rayd grade: bad option '%s' (try 'rayd grade --help')\n", argv[optind - 1]);
            status = RD_EXIT_USAGE;
        }
    }
    /* One --image alone is graded as it always was: the verdict JSON. */
    int one = images == 1 && !dirs && !csv;
    if (!status && (optind != argc || !n_src || (!in.assignment == !in.scene_path))) {
        fprintf(stderr, "rayd grade: give --image (or --dir) and exactly one of --assignment or --scene (try 'rayd "
                        "grade --help')\n");
        status = RD_EXIT_USAGE;
    }
    if (!status && in.assignment && ov.set) {
        fprintf(stderr, "rayd grade: an assignment is graded as it is: render overrides go with --scene only\n");
        status = RD_EXIT_USAGE;
    }
    if (!status && diff && !one) {
        fprintf(stderr, "rayd grade: --diff writes the heat map of one image: give one --image, without --dir "
                        "or --csv\n");
        status = RD_EXIT_USAGE;
    }
    class_list students = {0};
    if (!status)
        status = class_make(&students, src, is_dir, n_src);
    free(src);
    free(is_dir);
    if (!status && one)
        status = grade_one(&g, &in, students.v[0].path, diff, cache_dir, (int)threads);
    else if (!status && !(status = class_check_ids(&students)))
        status = grade_class(&g, &in, &students, csv, cache_dir, (int)threads);
    class_free(&students);
    return status;
}
