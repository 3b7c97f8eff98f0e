/* One image's grade on a render thread: prepared (rd_grade_prepare, which
 * finds a cached reference), rendered only when there is none, then
 * finished (compare, heat map, the kept PNGs, the verdict, the record). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grading_internal.h"
#include "rayd/clock.h"

typedef struct {
    rd_grading *g;
    char *image;
    size_t image_len;
    char *scene;
    size_t scene_len;
    char assignment[80];
    char student[256];
    long long submitted_ms; /* when the request came, not when it was graded */
    rd_grade_output out;
    char *json; /* the verdict */
} image_task;

static rd_grade_input input_of(const image_task *t)
{
    rd_grade_input in = {0};
    in.assignment = t->assignment[0] ? t->assignment : NULL;
    in.scene_text = t->scene;
    in.scene_len = t->scene_len;
    in.source = "<upload>";
    in.png = (const unsigned char *)t->image;
    in.png_len = t->image_len;
    return in;
}

static rd_error_code prepare(void *arg, rd_scene *s, int *render, rd_error *err)
{
    image_task *t = arg;
    rd_grade_input in = input_of(t);
    rd_error_code rc = rd_grade_prepare(&t->g->grader, &in, s, &t->out, err);
    free(t->image);
    t->image = NULL;
    if (rc)
        return rc;
    atomic_fetch_add(t->out.reference ? &t->g->reference_hits : &t->g->reference_misses, 1);
    *render = !t->out.reference;
    return RD_OK;
}

static rd_error_code finish(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    image_task *t = arg;
    rd_grade_output *o = &t->out;
    if (rgb) {
        rd_error_code rc = rd_grade_set_reference(&t->g->grader, o, rgb, w, h, err);
        if (rc)
            return rc;
    }
    if (rd_grade_finish(o))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    char id[RD_CAP_MAX];
    grading_sub sub = {.student = t->student, .submitted_ms = t->submitted_ms};
    return grading_one(t->g, o, &sub, id, &t->json, err);
}

static void free_task(void *arg)
{
    image_task *t = arg;
    if (!t)
        return;
    free(t->image);
    free(t->scene);
    free(t->json);
    rd_grade_output_free(&t->out);
    free(t);
}

rd_error_code rd_grading_image_task(rd_grading *g, rd_grading_image *in, rd_jq_task *task, rd_error *err)
{
    image_task *t = calloc(1, sizeof *t);
    if (!t) {
        free(in->image);
        free(in->scene);
        in->image = in->scene = NULL;
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    t->g = g;
    t->image = in->image;
    t->image_len = in->image_len;
    t->scene = in->scene;
    t->scene_len = in->scene_len;
    in->image = in->scene = NULL;
    snprintf(t->assignment, sizeof t->assignment, "%s", in->assignment ? in->assignment : "");
    snprintf(t->student, sizeof t->student, "%s", in->student ? in->student : "");
    t->submitted_ms = rd_wall_ms();
    *task = (rd_jq_task){prepare, finish, free_task, t, t->image_len + t->scene_len, NULL};
    return RD_OK;
}

rd_grading_answer rd_grading_image_answer(void *task_arg)
{
    image_task *t = task_arg;
    rd_grading_answer a = {t->json, 200, t->out.result.pass, t->out.stage ? t->out.stage : RD_GRADE_STAGE_REFERENCE};
    t->json = NULL;
    return a;
}
