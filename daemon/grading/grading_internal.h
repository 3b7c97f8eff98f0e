/* Shared between the grading service's files. Not a public interface. */
#ifndef RD_GRADING_INTERNAL_H
#define RD_GRADING_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include <cJSON.h>

#include "codegrade.h"
#include "grading_service.h"
#include "term.h"

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

/* Who handed a grade in, how and when: what its record's term needs. */
typedef struct {
    const char *student;
    const char *batch_id;   /* a batch's: judged on time (its instructor collected it), but a regrade */
    const char *regrade_of; /* a regrade's: the record it grades again, whose submission time it keeps */
    long long submitted_ms; /* when the request came; 0: now */
    int code;               /* a code grade */
    double share;           /* code: its configurations right, of all */
} grading_sub;

/* A grade's record (an assignment's only): kept until --grade-ttl, expired
 * here about once a minute. A record the store refuses becomes an error
 * row saying why; what still fails is logged. *verdict (malloc'ed) is
 * replaced by one with the record object (grade_term.c) when it can be. */
void grading_record(rd_grading *g, const rd_grade_output *o, const char *id, const grading_sub *sub, int pass,
                    char **verdict, const unsigned char *diff, size_t diff_len);

/* grading_keep then grading_record, with the image's own pass. */
rd_error_code grading_one(rd_grading *g, const rd_grade_output *o, const grading_sub *sub, char id[RD_CAP_MAX],
                          char **verdict, rd_error *err);

/* The record of a student whose image could not be graded; its id in id
 * ("" when none could be made). */
void grading_error_record(rd_grading *g, const char *assignment, const char *student, const char *batch_id,
                          const char *message, char id[RD_CAP_MAX]);

/* The same for a submission, of its kind and time. */
void grading_error_record_sub(rd_grading *g, const char *assignment, const grading_sub *sub, const char *message,
                              char id[RD_CAP_MAX]);

/* grade_term.c. The term of an assignment's .grade (the default when it
 * does not load). */
rd_term grading_term_of(rd_grading *g, const char *assignment);

/* Sets rec's kind, submission time, lateness, score and points (rec's
 * assignment, error and failed_fraction set); the term it used. */
rd_term grading_term_fields(rd_grading *g, rd_store_grade *rec, const grading_sub *sub, int pass);

/* The record object of an answer: student, assignment, kind,
 * submitted_at, due_at, late, late_days, closed, counts (null when -1),
 * score, points. NULL when out of memory. */
cJSON *grading_record_json(const rd_store_grade *rec, const rd_term *t, int counts);

/* verdict (taken over) with its "record" set to that object: a new text,
 * or verdict itself when it cannot be made. */
char *grading_with_record(char *verdict, const rd_store_grade *rec, const rd_term *t, int counts);

/* Whether rec is the one of its student's records of its assignment that
 * counts: 1, 0, or -1 when the store cannot say. */
int grading_counts(rd_grading *g, const rd_store_grade *rec, const rd_term *t);

/* counts[i] for rows where each student's records of an assignment are
 * together (sorted by student, then assignment): 1 for the record
 * of each student and assignment that counts, else 0. */
void grading_mark_counts(rd_grading *g, rd_store_grade *rows, size_t n, int *counts);
/* Forgets the kept images of deleted grades, so that no image outlives its
 * record. */
void grading_forget(rd_grading *g, const rd_store_grade_id *ids, size_t n);

/* grade_batch.c: the batches graded here forget the service, whose queue
 * frees the tasks it still holds once the service is freed. */
void grading_batches_detach(rd_grading *g);

/* grade_batch.c: ends the batches a killed daemon of this id left running. */
void grading_batches_end_restarted(rd_grading *g);

/* grade_list.c: the records as rows, a JSON array or CSV (malloc'ed; NULL
 * when out of memory), sorted by student (grades is sorted in place), each
 * saying whether it counts and, with --roster, whether its student is on
 * it; the roster's students without a record of assignment (NULL or "":
 * none asked) get a "no submission" row. */
char *grading_rows_text(rd_grading *g, rd_store_grade *grades, size_t n, int csv, const char *assignment);

/* rows sorted in place by student, then assignment, then submission time
 * (then id); rows itself. */
rd_store_grade *grading_sort_rows(rd_store_grade *rows, size_t n);

/* grade_list.c: a batch's id, assignment, status, total, done and
 * created_at as a JSON object (NULL when out of memory). */
struct cJSON *grading_batch_json(const rd_store_batch *b);

/* grade_code.c: the code grader's state set up (the sandbox probed, which
 * logs when it does not start), and freed. RD_ERR_NOMEM. */
rd_error_code grading_code_init(rd_grading *g, rd_error *err);
void grading_code_free(rd_grading *g);

#endif
