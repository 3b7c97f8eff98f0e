/* A class's batch on the render threads: the first task renders the
 * reference (once: it is cached) and then hands the images out in slices,
 * one a render thread. Every grade is a record in the store, which the
 * batch counts; a daemon killed mid-batch ends it when it starts again. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grading_internal.h"
#include "rayd/clock.h"
#include "strbuf.h"

static void free_images(rd_grade_batch_image *im, size_t n)
{
    for (size_t i = 0; i < n; i++)
        free(im[i].png);
    free(im);
}

/* Shared by the batch's tasks; the last one to end frees it. While any
 * task holds it, it is in g->batches, where a DELETE finds it. */
typedef struct grade_batch {
    rd_grading *g;
    char id[RD_STORE_ID_MAX];
    char assignment[80];
    rd_grade_batch_image *images;
    size_t n;
    uint8_t *ref; /* the reference, once rendered or found */
    int w, h;
    rd_error failed; /* the reference could not be had: every image is this error */
    pthread_mutex_t mu;
    int refs;
    int cancelled; /* under mu: every image not taken was dropped, and none is taken */
    struct grade_batch *next;
} grade_batch;

/* Under g->mu. */
static void unlink_batch(rd_grading *g, grade_batch *b)
{
    for (grade_batch **p = &g->batches; *p; p = &(*p)->next)
        if (*p == b) {
            *p = b->next;
            return;
        }
}

/* g->mu is taken first: a cancel walks g->batches under it, so the last
 * ref must not go while it looks at the batch. The queue frees the tasks
 * it still holds after the service is gone (rd_grading_free detached the
 * batch: g is NULL), with nothing left to tell. */
static void batch_unref(grade_batch *b)
{
    rd_grading *g = b->g;
    if (g)
        pthread_mutex_lock(&g->mu);
    pthread_mutex_lock(&b->mu);
    int last = --b->refs == 0;
    pthread_mutex_unlock(&b->mu);
    if (last && g)
        unlink_batch(g, b);
    if (g)
        pthread_mutex_unlock(&g->mu);
    if (!last)
        return;
    free_images(b->images, b->n);
    free(b->ref);
    pthread_mutex_destroy(&b->mu);
    free(b);
}

/* A task: the reference (first), or a slice of the images. */
typedef struct {
    grade_batch *b;
    size_t i0, i1;
    rd_grade_output out; /* the reference task's */
} batch_task;

static void free_batch_task(void *arg)
{
    batch_task *t = arg;
    rd_grade_output_free(&t->out);
    batch_unref(t->b);
    free(t);
}

/* The images' bytes count in the queue's budget from the batch's start
 * until each is graded. */
static long long images_bytes(const rd_grade_batch_image *images, size_t n)
{
    long long sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += (long long)images[i].len;
    return sum;
}

/* Its bytes leave the budget once: len is 0 after. */
static void drop_png(grade_batch *b, rd_grade_batch_image *im)
{
    free(im->png);
    im->png = NULL;
    rd_jq_external_bytes(b->g->opt.jobs, -(long long)im->len);
    im->len = 0;
}

/* Image i moved out of the batch to be graded, so that a cancel meanwhile
 * drops only the others; 0 when the batch was cancelled. */
static int take_image(grade_batch *b, size_t i, rd_grade_batch_image *out)
{
    pthread_mutex_lock(&b->mu);
    int go = !b->cancelled;
    if (go) {
        *out = b->images[i];
        b->images[i].png = NULL;
        b->images[i].len = 0;
    }
    pthread_mutex_unlock(&b->mu);
    return go;
}

static void grade_image(grade_batch *b, size_t i)
{
    rd_grade_batch_image taken, *im = &taken;
    if (!take_image(b, i, im))
        return;
    char id[RD_CAP_MAX];
    grading_sub sub = {.student = im->student,
                       .batch_id = b->id,
                       .submitted_ms = im->submitted_ms,
                       .regrade_of = im->regrade_of[0] ? im->regrade_of : NULL};
    if (im->error) {
        grading_error_record_sub(b->g, b->assignment, &sub, im->error, id);
        drop_png(b, im);
        return;
    }
    rd_grade_input in = {.assignment = b->assignment, .png = im->png, .png_len = im->len};
    rd_grade_output o;
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    rd_error_code rc = b->failed.code ? b->failed.code : rd_grade_prepare(&b->g->grader, &in, &s, &o, &err);
    if (b->failed.code)
        err = b->failed;
    if (!rc && !o.reference)
        rc = rd_grade_set_reference(&b->g->grader, &o, b->ref, b->w, b->h, &err);
    if (!rc && rd_grade_finish(&o))
        rc = rd_error_set(&err, RD_ERR_NOMEM, 0, 0, "out of memory comparing the images");
    char *verdict = NULL;
    if (!rc)
        rc = grading_one(b->g, &o, &sub, id, &verdict, &err);
    if (rc)
        grading_error_record_sub(b->g, b->assignment, &sub, err.message, id);
    free(verdict);
    if (!b->failed.code)
        rd_grade_output_free(&o);
    rd_scene_free(&s);
    drop_png(b, im);
}

static void cancel_here(rd_grading *g, const char *id);

/* A DELETE answered by another daemon on the same store cancels the batch
 * in the store only: a slice looks every CHECK_EVERY images (a row read,
 * against a grade's tens of milliseconds) and then stops here too. */
enum { CHECK_EVERY = 16 };

static int cancelled_in_store(const grade_batch *b)
{
    rd_store_batch sb;
    return rd_store_batch_get(b->g->store, b->id, &sb, NULL) == RD_OK && sb.status == RD_STORE_BATCH_CANCELLED;
}

static rd_error_code grade_slice(void *arg, rd_scene *s, int *render, rd_error *err)
{
    (void)s, (void)err;
    batch_task *t = arg;
    *render = 0;
    for (size_t i = t->i0; i < t->i1; i++) {
        if ((i - t->i0) % CHECK_EVERY == CHECK_EVERY - 1 && cancelled_in_store(t->b)) {
            cancel_here(t->b->g, t->b->id);
            break;
        }
        grade_image(t->b, i);
    }
    return RD_OK;
}

/* The reference: found in the cache, or rendered by the queue as any
 * grade's is. */
static rd_error_code prepare_reference(void *arg, rd_scene *s, int *render, rd_error *err)
{
    batch_task *t = arg;
    rd_grade_input in = {.assignment = t->b->assignment};
    rd_error_code rc = rd_grade_prepare_reference(&t->b->g->grader, &in, s, &t->out, err);
    *render = !rc && !t->out.reference;
    return rc;
}

static rd_error_code submit_slices(grade_batch *b, rd_error *err)
{
    size_t k = (size_t)(b->g->opt.workers > 0 ? b->g->opt.workers : 1);
    if (k > b->n)
        k = b->n;
    for (size_t j = 0; j < k; j++) {
        batch_task *t = calloc(1, sizeof *t);
        if (!t)
            return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        t->b = b;
        t->i0 = b->n * j / k;
        t->i1 = b->n * (j + 1) / k;
        pthread_mutex_lock(&b->mu);
        b->refs++;
        pthread_mutex_unlock(&b->mu);
        rd_jq_task task = {grade_slice, NULL, free_batch_task, t, 0, NULL};
        /* registered: the queue holds it until it ends */
        rd_jq_submit_options so = {.watch_fd = -1, .renders_nothing = 1};
        rd_jq_job *job;
        rd_error_code rc = rd_jq_submit(b->g->opt.jobs, &task, &so, &job, err);
        if (rc)
            return rc;
        rd_jq_job_unref(job);
    }
    return RD_OK;
}

/* The reference task's end: the slices go out (on a full queue, this
 * thread grades what could not be queued). */
static rd_error_code finish_reference(void *arg, const uint8_t *rgb, int w, int h, rd_error *err)
{
    batch_task *t = arg;
    grade_batch *b = t->b;
    rd_grade_output *o = &t->out;
    rd_error_code rc = rgb ? rd_grade_set_reference(&b->g->grader, o, rgb, w, h, err) : RD_OK;
    size_t n = (size_t)o->width * (size_t)o->height * 3;
    if (!rc && !(b->ref = malloc(n ? n : 1)))
        rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (!rc) {
        memcpy(b->ref, o->reference, n);
        b->w = o->width;
        b->h = o->height;
    } else {
        b->failed = *err;
    }
    pthread_mutex_lock(&b->mu);
    int cancelled = b->cancelled;
    pthread_mutex_unlock(&b->mu);
    rd_error qerr = {0};
    if (!cancelled && submit_slices(b, &qerr)) {
        batch_task all = {b, 0, b->n, {0}};
        int render = 0;
        grade_slice(&all, NULL, &render, &qerr);
    }
    return RD_OK;
}

/* The students' ids, each followed by '\n' (malloc'ed; NULL when out of
 * memory): what a restarted daemon needs to name the ones it did not
 * grade. A batch's ids never hold a control character. */
static char *students_text(const rd_grade_batch_image *images, size_t n)
{
    rd_strbuf t = {0};
    for (size_t i = 0; i < n; i++)
        rd_strbuf_printf(&t, "%s\n", images[i].student);
    return rd_strbuf_take(&t, NULL);
}

/* The batch's row: its daemon and students with it, or, when the students
 * are more than the store takes as one text, without them (a restart then
 * numbers the rows it could not grade). */
static rd_error_code create_batch(rd_grading *g, const char *id, const char *assignment,
                                  const rd_grade_batch_image *images, size_t n, rd_error *err)
{
    char *students = students_text(images, n);
    if (!students)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_error_code rc = rd_store_batch_create(g->store, id, assignment, (int)n, g->daemon_id, students, err);
    if (rc == RD_ERR_LIMIT)
        rc = rd_store_batch_create(g->store, id, assignment, (int)n, g->daemon_id, NULL, err);
    free(students);
    return rc;
}

rd_error_code rd_grading_batch_start(rd_grading *g, const char *assignment, rd_grade_batch_image *images, size_t n,
                                     char id[RD_STORE_ID_MAX], rd_error *err)
{
    grade_batch *b = calloc(1, sizeof *b);
    batch_task *t = calloc(1, sizeof *t);
    rd_error_code rc = !b || !t ? rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory") : rd_cap_new(b->id, 0, err);
    if (!rc)
        rc = create_batch(g, b->id, assignment, images, n, err);
    if (rc) {
        free_images(images, n);
        free(b);
        free(t);
        return rc;
    }
    b->g = g;
    snprintf(b->assignment, sizeof b->assignment, "%s", assignment);
    b->images = images;
    b->n = n;
    b->refs = 1;
    pthread_mutex_init(&b->mu, NULL);
    t->b = b;
    memcpy(id, b->id, RD_STORE_ID_MAX);
    pthread_mutex_lock(&g->mu);
    b->next = g->batches;
    g->batches = b;
    pthread_mutex_unlock(&g->mu);
    rd_jq_task task = {prepare_reference, finish_reference, free_batch_task, t, 0, NULL};
    rd_jq_submit_options so = {.watch_fd = -1}; /* registered: the queue holds it until it ends */
    rd_jq_job *job;
    long long held = images_bytes(images, n);
    rd_jq_external_bytes(g->opt.jobs, held);
    rc = rd_jq_submit(g->opt.jobs, &task, &so, &job, err);
    if (rc) {
        rd_jq_external_bytes(g->opt.jobs, -held);
        rd_store_batch_cancel(g->store, id, NULL, NULL);
        return rc;
    }
    rd_jq_job_unref(job);
    return RD_OK;
}

/* ---- batches a killed daemon left running ---- */

static const char RESTARTED[] = "not graded: the daemon restarted while grading the batch; grade this image again";

/* 1 when g (n grades) holds a row of student. */
static int has_row(const rd_store_grade *g, size_t n, const char *student)
{
    for (size_t i = 0; i < n; i++)
        if (g[i].student && strcmp(g[i].student, student) == 0)
            return 1;
    return 0;
}

/* Ends one batch: an error row for each student without a row, named from
 * the batch's students, or numbered when it has none (an older batch, or
 * one whose students the store could not take). Each row counts, so the
 * last one makes it done. */
static void end_batch(rd_grading *g, const rd_store_batch *b)
{
    rd_store_grade_filter f = {.batch_id = b->id, .max = (size_t)b->total};
    rd_store_grade *rows = NULL;
    size_t n = 0;
    char *students = NULL;
    rd_error err = {0};
    if (rd_store_grades_list(g->store, &f, &rows, &n, &err) ||
        rd_store_batch_students(g->store, b->id, &students, &err)) {
        rd_log_msg(g->opt.log, "warning", "batch %s could not be ended: %s", b->id, err.message);
        rd_store_grades_free(rows, n);
        return;
    }
    char id[RD_CAP_MAX];
    int left = b->total - b->done;
    for (char *p = students, *nl; left > 0 && (nl = strchr(p, '\n')); p = nl + 1) {
        *nl = 0;
        if (!has_row(rows, n, p) && left-- > 0)
            grading_error_record(g, b->assignment, p, b->id, RESTARTED, id);
    }
    for (int k = b->total - left + 1; k <= b->total; k++) {
        char unnamed[48];
        snprintf(unnamed, sizeof unnamed, "(not graded %d of %d)", k, b->total);
        grading_error_record(g, b->assignment, unnamed, b->id, RESTARTED, id);
    }
    free(students);
    rd_store_grades_free(rows, n);
    rd_log_msg(g->opt.log, "info", "batch %s ended after a restart: %d of %d images had been graded", b->id, b->done,
               b->total);
}

void grading_batches_end_restarted(rd_grading *g)
{
    rd_store_batch *list = NULL;
    size_t n = 0;
    rd_error err = {0};
    if (rd_store_batches_running(g->store, g->daemon_id, SIZE_MAX, &list, &n, &err)) {
        rd_log_msg(g->opt.log, "warning", "the batches left running could not be read: %s", err.message);
        return;
    }
    for (size_t i = 0; i < n; i++)
        end_batch(g, &list[i]);
    free(list);
}

/* ---- a batch as text ---- */

static const char NO_BATCH[] = "no batch with that id (batches expire with their grades, see --grade-ttl)";

/* The status with the rows as grading_rows_text wrote them: cJSON would
 * print their numbers again, with fewer digits than grade_table.h gives. */
static char *status_text(const rd_store_batch *b, const char *rows)
{
    cJSON *o = grading_batch_json(b);
    cJSON_AddRawToObject(o, "results", rows);
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return text;
}

static rd_error_code batch_get(rd_grading *g, const char *id, rd_store_batch *b, rd_error *err)
{
    rd_error_code rc = rd_store_batch_get(g->store, id, b, err);
    /* An id the store would never have made is no batch either. */
    if (rc == RD_ERR_NOT_FOUND || rc == RD_ERR_INVALID)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s", NO_BATCH);
    return rc;
}

rd_error_code rd_grading_batch_text(rd_grading *g, const char *id, rd_grading_batch_form form, char **text,
                                    rd_error *err)
{
    rd_store_batch b;
    rd_error_code rc = batch_get(g, id, &b, err);
    if (rc)
        return rc;
    rd_store_grade_filter f = {.batch_id = id, .max = (size_t)b.total};
    rd_store_grade *rows = NULL;
    size_t n = 0;
    if ((rc = rd_store_grades_list(g->store, &f, &rows, &n, err)))
        return rc;
    char *t = grading_rows_text(g, rows, n, form == RD_BATCH_ROWS_CSV, b.assignment);
    rd_store_grades_free(rows, n);
    if (t && form == RD_BATCH_STATUS) {
        char *status = status_text(&b, t);
        free(t);
        t = status;
    }
    *text = t;
    return t ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

/* ---- cancelling and deleting ---- */

void grading_batches_detach(rd_grading *g)
{
    pthread_mutex_lock(&g->mu);
    for (grade_batch *b = g->batches; b; b = b->next)
        b->g = NULL;
    g->batches = NULL;
    pthread_mutex_unlock(&g->mu);
}

/* A batch graded here stops: the images not taken yet are dropped and
 * leave the budget at once, so the slices still queued find nothing to
 * grade. The images being graded now end as they would. Nothing when the
 * batch is not graded here (another daemon's, or ended). */
static void cancel_here(rd_grading *g, const char *id)
{
    pthread_mutex_lock(&g->mu);
    for (grade_batch *b = g->batches; b; b = b->next) {
        if (!rd_cap_equal(b->id, id))
            continue;
        pthread_mutex_lock(&b->mu);
        b->cancelled = 1;
        for (size_t i = 0; i < b->n; i++)
            drop_png(b, &b->images[i]);
        pthread_mutex_unlock(&b->mu);
    }
    pthread_mutex_unlock(&g->mu);
}

/* In the store first, so that a store that cannot be written leaves the
 * batch as it was: then it takes no more rows, whoever grades it (the
 * images being graded now are refused, and logged), and here its images
 * stop. */
static rd_error_code cancel(rd_grading *g, const rd_store_batch *b, char **status, rd_error *err)
{
    rd_error_code rc = rd_store_batch_cancel(g->store, b->id, NULL, err);
    if (rc)
        return rc;
    cancel_here(g, b->id);
    rd_log_msg(g->opt.log, "info", "batch %s cancelled", b->id);
    return rd_grading_batch_text(g, b->id, RD_BATCH_STATUS, status, err);
}

rd_error_code rd_grading_batch_delete(rd_grading *g, const char *id, char **status, rd_error *err)
{
    rd_store_batch b;
    *status = NULL;
    rd_error_code rc = batch_get(g, id, &b, err);
    if (rc)
        return rc;
    if (b.status == RD_STORE_BATCH_RUNNING)
        return cancel(g, &b, status, err);
    rd_store_grade_id *ids = NULL;
    size_t n = 0;
    rc = rd_store_batch_delete(g->store, id, &ids, &n, err);
    if (rc == RD_ERR_NOT_FOUND)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s", NO_BATCH);
    if (rc)
        return rc;
    grading_forget(g, ids, n);
    free(ids);
    rd_log_msg(g->opt.log, "info", "batch %s deleted with its %zu records", id, n);
    return RD_OK;
}
