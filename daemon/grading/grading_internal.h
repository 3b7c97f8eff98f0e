/* Shared between the grading service's files. Not a public interface. */
#ifndef RD_GRADING_INTERNAL_H
#define RD_GRADING_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include "codegrade.h"
#include "grading_service.h"

enum { GRADES_KEPT = 256, LOBES_KEPT = 128 };

/* A finished grade's PNGs, for GET /v1/grades/{id}/... */
typedef struct {
    char id[RD_CAP_MAX];
    unsigned char *diff, *reference, *image;
    size_t diff_len, reference_len, image_len;
    double t;
} grade_entry;

typedef struct {
    char id[RD_CAP_MAX];
    char *svg;
} lobe_entry;

/* The references and the images of finished grades share cache_bytes:
 * kept grades shrink what references may hold, and the oldest grades go
 * once references hold nothing. */
struct rd_grading {
    rd_grading_options opt; /* its texts are the caller's, but daemon_id */
    char daemon_id[RD_STORE_ID_MAX];
    rd_store *store; /* the records; set at start, the service's own */
    atomic_llong last_expire_ms;
    atomic_ullong reference_hits, reference_misses;
    /* Guards what follows. */
    pthread_mutex_t mu;
    rd_grader grader; /* its cache locks itself */
    grade_entry kept[GRADES_KEPT];
    size_t next, kept_bytes;
    struct grade_batch *batches; /* those graded here now (grade_batch.c) */
    /* Grading code (grade_code.c), under code_mu. */
    rd_codegrade_config code; /* its grader is the one above */
    int sandbox_ok;           /* set at start */
    char sandbox_why[512];    /* else why not */
    pthread_mutex_t code_mu;
    lobe_entry lobes[LOBES_KEPT];
    size_t next_lobe;
    /* The slots: active of max_total taken, by clients holding n each
     * (max_total entries, as no more clients can hold one). */
    int active, max_total, max_client;
    struct {
        char client[64];
        int n;
    } * holders;
};

/* A finished grade kept (grading_service.c): its images with the verdict
 * (malloc'ed, with its id and student) and a malloc'ed copy of the heat map
 * for the record, both the caller's to free. */
rd_error_code grading_keep(rd_grading *g, const rd_grade_output *o, const char *student, char id[RD_CAP_MAX],
                           char **verdict, unsigned char **diff, size_t *diff_len, rd_error *err);

/* A grade's record (an assignment's only): kept until --grade-ttl, expired
 * here about once a minute. A record the store refuses becomes an error
 * row saying why; what still fails is logged. */
void grading_record(rd_grading *g, const rd_grade_output *o, const char *id, const char *student, const char *batch_id,
                    int pass, const char *verdict, const unsigned char *diff, size_t diff_len);

/* grading_keep then grading_record, with the image's own pass. */
rd_error_code grading_one(rd_grading *g, const rd_grade_output *o, const char *student, const char *batch_id,
                          char id[RD_CAP_MAX], char **verdict, rd_error *err);

/* The record of a student whose image could not be graded; its id in id
 * ("" when none could be made). */
void grading_error_record(rd_grading *g, const char *assignment, const char *student, const char *batch_id,
                          const char *message, char id[RD_CAP_MAX]);

/* Forgets the kept images of deleted grades, so that no image outlives its
 * record. */
void grading_forget(rd_grading *g, const rd_store_grade_id *ids, size_t n);

/* grade_batch.c: the batches graded here forget the service, whose queue
 * frees the tasks it still holds once the service is freed. */
void grading_batches_detach(rd_grading *g);

/* grade_batch.c: ends the batches a killed daemon of this id left running. */
void grading_batches_end_restarted(rd_grading *g);

/* grade_list.c: the records as rows, a JSON array or CSV (malloc'ed; NULL
 * when out of memory). */
char *grading_rows_text(const rd_store_grade *grades, size_t n, int csv);

/* grade_list.c: a batch's id, assignment, status, total, done and
 * created_at as a JSON object (NULL when out of memory). */
struct cJSON *grading_batch_json(const rd_store_batch *b);

/* grade_code.c: the code grader's state set up (the sandbox probed, which
 * logs when it does not start), and freed. RD_ERR_NOMEM. */
rd_error_code grading_code_init(rd_grading *g, rd_error *err);
void grading_code_free(rd_grading *g);

#endif
