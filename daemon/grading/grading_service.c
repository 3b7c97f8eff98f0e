/* The service's start and end, the images kept of finished grades, and the
 * records. */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grading_internal.h"
#include "png_write.h"
#include "rayd/clock.h"
#include "utf8.h"

/* The reference cache tells the queue of every byte it holds. */
static void count_bytes(void *jobs, long long delta) { rd_jq_external_bytes(jobs, delta); }

static rd_error_code open_store(rd_grading *g, rd_error *err)
{
    rd_error why = {0};
    g->store = rd_store_open(g->opt.store_spec, &g->opt.store, &why);
    if (g->store)
        return RD_OK;
    return rd_error_set(err, why.code, 0, 0, "the grade records' store cannot be used: %s", why.message);
}

rd_grading *rd_grading_start(const rd_grading_options *o, rd_error *err)
{
    rd_grading *g = calloc(1, sizeof *g);
    if (!g) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    g->opt = *o;
    snprintf(g->daemon_id, sizeof g->daemon_id, "%s", o->daemon_id ? o->daemon_id : "");
    g->opt.daemon_id = g->daemon_id;
    pthread_mutex_init(&g->mu, NULL);
    pthread_mutex_init(&g->code_mu, NULL);
    g->grader.assignments_dir = o->assignments_dir;
    g->grader.assets_dir = o->scenes_dir;
    g->grader.limits = o->limits;
    g->grader.cache = rd_ref_cache_new(o->cache_bytes, o->cache_dir, count_bytes, o->jobs);
    rd_error_code rc =
        g->grader.cache ? grading_code_init(g, err) : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    if (!rc)
        rc = open_store(g, err);
    if (rc) {
        rd_grading_free(g);
        return NULL;
    }
    grading_batches_end_restarted(g);
    return g;
}

void rd_grading_free(rd_grading *g)
{
    if (!g)
        return;
    grading_batches_detach(g);
    /* The queue is gone by now: nobody is told of these bytes. */
    for (int i = 0; i < GRADES_KEPT; i++) {
        free(g->kept[i].diff);
        free(g->kept[i].reference);
        free(g->kept[i].image);
    }
    grading_code_free(g);
    rd_ref_cache_free(g->grader.cache);
    rd_store_close(g->store);
    pthread_mutex_destroy(&g->code_mu);
    pthread_mutex_destroy(&g->mu);
    free(g);
}

void rd_grading_metrics_get(rd_grading *g, rd_grading_metrics *m)
{
    m->reference_hits = atomic_load(&g->reference_hits);
    m->reference_misses = atomic_load(&g->reference_misses);
}

/* ---- the images of finished grades ---- */

static size_t entry_bytes(const grade_entry *e) { return e->diff_len + e->reference_len + e->image_len; }

/* Under g->mu. */
static void drop_kept(rd_grading *g, grade_entry *e)
{
    size_t n = entry_bytes(e);
    g->kept_bytes -= n;
    rd_jq_external_bytes(g->opt.jobs, -(long long)n);
    free(e->diff);
    free(e->reference);
    free(e->image);
    memset(e, 0, sizeof *e);
}

/* Past the cap the references give way first, then the oldest grades.
 * Under g->mu. */
static void fit(rd_grading *g)
{
    while (g->kept_bytes > g->opt.cache_bytes) {
        grade_entry *old = NULL;
        for (int i = 0; i < GRADES_KEPT; i++)
            if (g->kept[i].id[0] && (!old || g->kept[i].t < old->t))
                old = &g->kept[i];
        if (!old)
            break;
        drop_kept(g, old);
    }
    rd_ref_cache_set_max_bytes(g->grader.cache, g->opt.cache_bytes - g->kept_bytes);
}

static unsigned char *encode(const uint8_t *rgb, int w, int h, size_t *len)
{
    unsigned char *png = NULL;
    rd_error err;
    rd_png_options po = rd_png_options_default();
    if (rd_png_encode(rgb, w, h, &po, &png, len, &err))
        return NULL;
    return png;
}

/* The PNGs of a finished grade, kept under a new id; a copy of the diff
 * for the record (NULL when out of memory; the caller frees it). */
static rd_error_code keep(rd_grading *g, const rd_grade_output *o, char id[RD_CAP_MAX], unsigned char **diff,
                          size_t *diff_len, rd_error *err)
{
    if (rd_cap_new(id, 'g', err))
        return err->code;
    size_t n = (size_t)o->width * (size_t)o->height * 3;
    uint8_t *heat = malloc(n);
    grade_entry e;
    memset(&e, 0, sizeof e);
    if (heat) {
        rd_grade_heatmap(o->reference, o->image, o->width, o->height, o->thresholds.fail, heat);
        e.diff = encode(heat, o->width, o->height, &e.diff_len);
        free(heat);
    }
    e.reference = encode(o->reference, o->width, o->height, &e.reference_len);
    e.image = encode(o->image, o->width, o->height, &e.image_len);
    *diff = e.diff ? malloc(e.diff_len) : NULL;
    *diff_len = *diff ? e.diff_len : 0;
    if (*diff)
        memcpy(*diff, e.diff, e.diff_len);
    e.t = rd_now_ms();
    memcpy(e.id, id, sizeof e.id);
    pthread_mutex_lock(&g->mu);
    grade_entry *slot = &g->kept[g->next++ % GRADES_KEPT];
    drop_kept(g, slot);
    *slot = e;
    g->kept_bytes += entry_bytes(&e);
    rd_jq_external_bytes(g->opt.jobs, (long long)entry_bytes(&e));
    fit(g);
    pthread_mutex_unlock(&g->mu);
    return RD_OK;
}

/* The verdict with the kept images' addresses, the grade's id and its
 * student (when known). */
static char *verdict_json(const rd_grade_output *o, const char *id, const char *student)
{
    cJSON *root = rd_grade_json(o);
    if (!root)
        return NULL;
    if (student && *student && !cJSON_AddStringToObject(root, "student", student)) {
        cJSON_Delete(root);
        return NULL;
    }
    static const char *const files[][2] = {
        {"diff_url", "diff"}, {"reference_url", "reference"}, {"image_url", "image"}};
    char url[80];
    int ok = cJSON_AddStringToObject(root, "id", id) != NULL;
    for (int i = 0; i < 3 && ok; i++) {
        snprintf(url, sizeof url, "/v1/grades/%s/%s.png", id, files[i][1]);
        ok = cJSON_AddStringToObject(root, files[i][0], url) != NULL;
    }
    char *text = ok ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    return text;
}

rd_error_code grading_keep(rd_grading *g, const rd_grade_output *o, const char *student, char id[RD_CAP_MAX],
                           char **verdict, unsigned char **diff, size_t *diff_len, rd_error *err)
{
    *diff = NULL;
    *diff_len = 0;
    *verdict = NULL;
    if (keep(g, o, id, diff, diff_len, err))
        return err->code;
    *verdict = verdict_json(o, id, student);
    if (*verdict)
        return RD_OK;
    free(*diff);
    *diff = NULL;
    return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

/* Under g->mu: a copy of the kept PNG which (0 diff, 1 reference, 2 image)
 * of grade id, or NULL. */
static unsigned char *kept_copy(rd_grading *g, const char *id, int which, size_t *len)
{
    for (int i = 0; i < GRADES_KEPT; i++) {
        grade_entry *e = &g->kept[i];
        if (!e->id[0] || !rd_cap_equal(e->id, id))
            continue;
        const unsigned char *src = which == 0 ? e->diff : which == 1 ? e->reference : e->image;
        *len = which == 0 ? e->diff_len : which == 1 ? e->reference_len : e->image_len;
        unsigned char *copy = src ? malloc(*len) : NULL;
        if (copy)
            memcpy(copy, src, *len);
        return copy;
    }
    return NULL;
}

rd_error_code rd_grading_image_file(rd_grading *g, const char *id, const char *file, unsigned char **png, size_t *len,
                                    rd_error *err)
{
    static const char *const files[] = {"diff.png", "reference.png", "image.png"};
    int which = -1;
    for (int k = 0; k < 3; k++)
        if (strcmp(file, files[k]) == 0)
            which = k;
    *png = NULL;
    if (which >= 0) {
        pthread_mutex_lock(&g->mu);
        *png = kept_copy(g, id, which, len);
        pthread_mutex_unlock(&g->mu);
    }
    /* Once the grade has left memory its record still has the diff. */
    if (!*png && which == 0 && rd_store_grade_image(g->store, id, RD_STORE_GRADE_DIFF, png, len, NULL))
        *png = NULL;
    if (*png)
        return RD_OK;
    return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0,
                        "no such grade image (the last 256 grades' images are kept; a record keeps its diff)");
}

/* ---- the records ---- */

/* Stores rec; a record the store refuses (a text it will not take) becomes
 * an error row saying why, with its texts made valid, so that a batch
 * still counts every student. What still fails (the store unreachable, the
 * batch ended) is logged. */
static void put_record(rd_grading *g, const rd_store_grade *rec, const unsigned char *diff, size_t diff_len)
{
    rd_error err = {0};
    rd_error_code rc = rd_store_grade_put(g->store, rec, diff, diff_len, &err);
    if (rc == RD_ERR_INVALID || rc == RD_ERR_LIMIT) {
        char student[RD_STORE_NAME_MAX], why[600];
        rd_utf8_readable(rec->student, strlen(rec->student), student, sizeof student);
        snprintf(
            why, sizeof why, "%s%s",
            rec->error ? "not graded; its message was refused: " : "graded, but its record was refused: ", err.message);
        char message[600];
        rd_utf8_readable(why, strlen(why), message, sizeof message);
        rd_store_grade row = {.id = rec->id,
                              .batch_id = rec->batch_id,
                              .assignment = rec->assignment,
                              .student = student,
                              .graded_ms = rec->graded_ms,
                              .error = message};
        rc = rd_store_grade_put(g->store, &row, NULL, 0, &err);
    }
    if (rc)
        rd_log_msg(g->opt.log, "warning", "grade %s was not recorded: %s", rec->id, err.message);
}

/* Grades of a given scene rather than an assignment are not records: they
 * belong to no course. */
void grading_record(rd_grading *g, const rd_grade_output *o, const char *id, const grading_sub *sub, int pass,
                    char **verdict, const unsigned char *diff, size_t diff_len)
{
    if (!o->assignment[0])
        return;
    char key[96];
    snprintf(key, sizeof key, "%s/%s", o->key, rd_renderer_id());
    rd_store_grade rec = {.id = id,
                          .batch_id = sub->batch_id,
                          .regrade_of = sub->regrade_of,
                          .assignment = o->assignment,
                          .student = sub->student ? sub->student : "",
                          .pass = pass,
                          .failed_fraction = o->result.failed_fraction,
                          .max_abs = o->result.max_abs,
                          .psnr_db = o->result.psnr_db,
                          .ssim = o->result.ssim,
                          .reference_key = key,
                          .graded_ms = rd_wall_ms()};
    rd_term t = grading_term_fields(g, &rec, sub, pass);
    /* Which counts is known once it is stored; the answer says so then. */
    *verdict = grading_with_record(*verdict, &rec, &t, -1);
    rec.verdict = *verdict;
    put_record(g, &rec, diff, diff_len);
    rd_error err = {0};
    long long now = rd_wall_ms(), last = atomic_load(&g->last_expire_ms);
    if (now - last > 60000 && atomic_compare_exchange_strong(&g->last_expire_ms, &last, now))
        rd_store_grades_expire(g->store, (int64_t)g->opt.ttl_ms, NULL, &err);
}

/* The image a record was graded from, stored beside it so that it can be
 * graded again (grade_regrade.c): the kept PNG, lossless, of the pixels
 * compared. A failure only means no regrade of it; it is logged. */
static void store_image(rd_grading *g, const char *id)
{
    size_t len = 0;
    pthread_mutex_lock(&g->mu);
    unsigned char *png = kept_copy(g, id, 2, &len);
    pthread_mutex_unlock(&g->mu);
    rd_error err = {0};
    if (png && rd_store_grade_image_put(g->store, id, RD_STORE_GRADE_IMAGE, png, len, &err))
        rd_log_msg(g->opt.log, "warning", "grade %s: its image was not stored (no regrade of it): %s", id, err.message);
    free(png);
}

rd_error_code grading_one(rd_grading *g, const rd_grade_output *o, const grading_sub *sub, char id[RD_CAP_MAX],
                          char **verdict, rd_error *err)
{
    unsigned char *diff;
    size_t diff_len;
    rd_error_code rc = grading_keep(g, o, sub->student, id, verdict, &diff, &diff_len, err);
    if (!rc)
        grading_record(g, o, id, sub, o->result.pass, verdict, diff, diff_len);
    if (!rc && o->assignment[0])
        store_image(g, id);
    free(diff);
    return rc;
}

void grading_error_record_sub(rd_grading *g, const char *assignment, const grading_sub *sub, const char *message,
                              char id[RD_CAP_MAX])
{
    rd_error made = {0};
    if (rd_cap_new(id, 'g', &made)) {
        rd_log_msg(g->opt.log, "warning", "a grade of %s was not recorded: %s", sub->student, made.message);
        return;
    }
    rd_store_grade rec = {.id = id,
                          .batch_id = sub->batch_id,
                          .regrade_of = sub->regrade_of,
                          .assignment = assignment,
                          .student = sub->student ? sub->student : "",
                          .graded_ms = rd_wall_ms(),
                          .error = message && *message ? message : "not graded"};
    grading_term_fields(g, &rec, sub, 0);
    put_record(g, &rec, NULL, 0);
}

void grading_error_record(rd_grading *g, const char *assignment, const char *student, const char *batch_id,
                          const char *message, char id[RD_CAP_MAX])
{
    grading_sub sub = {.student = student, .batch_id = batch_id};
    grading_error_record_sub(g, assignment, &sub, message, id);
}

void grading_forget(rd_grading *g, const rd_store_grade_id *ids, size_t n)
{
    pthread_mutex_lock(&g->mu);
    for (int i = 0; i < GRADES_KEPT; i++)
        for (size_t k = 0; g->kept[i].id[0] && k < n; k++)
            if (rd_cap_equal(g->kept[i].id, ids[k].id))
                drop_kept(g, &g->kept[i]);
    fit(g);
    pthread_mutex_unlock(&g->mu);
}

static const char NO_GRADE[] = "no such grade (records are kept for --grade-ttl)";

rd_error_code rd_grading_student_delete(rd_grading *g, const char *student, size_t *deleted, rd_error *err)
{
    rd_store_grade_id *ids = NULL;
    size_t n = 0;
    rd_error_code rc = rd_store_grades_delete(g->store, student, &ids, &n, err);
    if (rc)
        return rc;
    grading_forget(g, ids, n);
    free(ids);
    *deleted = n;
    return RD_OK;
}

rd_error_code rd_grading_grade_delete(rd_grading *g, const char *id, rd_error *err)
{
    rd_error_code rc = rd_store_grade_delete(g->store, id, err);
    if (rc == RD_ERR_NOT_FOUND || rc == RD_ERR_INVALID)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s", NO_GRADE);
    if (rc)
        return rc;
    rd_store_grade_id one;
    snprintf(one.id, sizeof one.id, "%s", id);
    grading_forget(g, &one, 1);
    return RD_OK;
}

/* An error row's verdict: what the record says of it. */
static char *error_verdict(const char *id, const rd_store_grade *rec)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "id", id);
    cJSON_AddStringToObject(o, "student", rec->student ? rec->student : "");
    cJSON_AddStringToObject(o, "assignment", rec->assignment ? rec->assignment : "");
    cJSON_AddBoolToObject(o, "pass", 0);
    cJSON_AddStringToObject(o, "error", rec->error);
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return text;
}

rd_error_code rd_grading_verdict(rd_grading *g, const char *id, char **json, rd_error *err)
{
    rd_store_grade rec = {0};
    rd_error_code rc = rd_store_grade_get(g->store, id, &rec, err);
    if (rc == RD_ERR_NOT_FOUND || rc == RD_ERR_INVALID)
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s", NO_GRADE);
    if (rc)
        return rc;
    *json = rec.verdict ? strdup(rec.verdict) : rec.error ? error_verdict(id, &rec) : NULL;
    /* The record as it stands now: a later submission may have taken its
     * place as the one that counts. */
    if (*json) {
        rd_term t = grading_term_of(g, rec.assignment);
        *json = grading_with_record(*json, &rec, &t, grading_counts(g, &rec, &t));
    }
    rd_store_grade_free(&rec);
    return *json ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}
