/* Regrading (docs/grading.md, "Regrading"): an assignment's image records
 * graded again against its reference as it is now, after the scene or the
 * renderer (rayd-core) changed, as a batch of their stored images. The old
 * verdicts stay; the new records say which they replace. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grading_internal.h"

enum { REGRADED_MAX = 10000 };

static const char NO_IMAGE[] =
    "not regraded: this record's image was not kept (graded before regrades were possible); grade the image again";

/* Whether some record of rows regrades id. */
static int has_regrade(const rd_store_grade *rows, size_t n, const char *id)
{
    for (size_t i = 0; i < n; i++)
        if (rows[i].regrade_of && strcmp(rows[i].regrade_of, id) == 0)
            return 1;
    return 0;
}

/* The batch's image of record r: its stored PNG, or an error row. */
static void image_of(rd_grading *g, const rd_store_grade *r, rd_grade_batch_image *im)
{
    snprintf(im->student, sizeof im->student, "%s", r->student[0] ? r->student : "(unnamed)");
    snprintf(im->regrade_of, sizeof im->regrade_of, "%s", r->id);
    im->submitted_ms = r->submitted_ms;
    rd_error err = {0};
    if (rd_store_grade_image(g->store, r->id, RD_STORE_GRADE_IMAGE, &im->png, &im->len, &err)) {
        im->png = NULL;
        im->len = 0;
        im->error = NO_IMAGE;
    }
}

/* The images of the records to regrade: image records, graded or not,
 * that no record regrades yet. */
static rd_error_code images_of(rd_grading *g, const rd_store_grade *rows, size_t n, rd_grade_batch_image **out,
                               size_t *k, rd_error *err)
{
    *out = calloc(n ? n : 1, sizeof **out);
    *k = 0;
    if (!*out)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    for (size_t i = 0; i < n; i++)
        if ((!rows[i].kind || strcmp(rows[i].kind, "image") == 0) && !has_regrade(rows, n, rows[i].id))
            image_of(g, &rows[i], &(*out)[(*k)++]);
    return RD_OK;
}

rd_error_code rd_grading_regrade(rd_grading *g, const char *assignment, char id[RD_STORE_ID_MAX], rd_error *err)
{
    rd_store_grade_filter f = {.assignment = assignment, .max = REGRADED_MAX};
    rd_store_grade *rows = NULL;
    size_t n = 0, k = 0;
    rd_grade_batch_image *images = NULL;
    rd_error_code rc = rd_store_grades_list(g->store, &f, &rows, &n, err);
    if (!rc)
        rc = images_of(g, rows, n, &images, &k, err);
    rd_store_grades_free(rows, n);
    if (!rc && k == 0)
        rc = rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "%s has no image record to regrade", assignment);
    if (rc) {
        free(images);
        return rc;
    }
    return rd_grading_batch_start(g, assignment, images, k, id, err);
}
