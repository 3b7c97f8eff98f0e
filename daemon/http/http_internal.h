/* Shared between the daemon's HTTP files: one request's state and the
 * helpers that answer it. Not a public interface. */
#ifndef RD_HTTP_INTERNAL_H
#define RD_HTTP_INTERNAL_H

#include <microhttpd.h>
#include <pthread.h>
#include <stdatomic.h>

#include "auth.h"
#include "capability.h"
#include "error_map.h"
#include "grading_service.h"
#include "rayd/error.h"
#include "server.h"

enum { RD_LINGER_MAX = 64, RD_LINGER_MS = 2000 };

struct rd_server {
    rd_server_options opt;
    struct MHD_Daemon *mhd;
    rd_jq *jobs;
    rd_farm *farm; /* the stored jobs; NULL until it has started */
    rd_auth *auth; /* --instructor-tokens; NULL: the instructors' routes are off */
    /* Guards auth: SIGHUP replaces it (rd_server_reload_tokens) while
     * request threads check tokens against it. */
    pthread_mutex_t auth_mu;
    char daemon_id[RD_STORE_ID_MAX];
    atomic_int draining;
    uint16_t port;
    struct rd_metrics *metrics; /* what /metrics reports of the HTTP side (metrics.h) */
    atomic_ullong requests;
    atomic_int waiting; /* suspended synchronous renders */
    atomic_int stopped;
    /* Set (under conn_mu) once the stop has cancelled what runs: no request
     * suspends its connection after it, since libmicrohttpd aborts when it
     * is stopped with one suspended. */
    int no_more_waits;
    rd_grading *grading; /* NULL until the server is ready (rd_server_grading) */
    /* Every open connection with its deadline, for the reaper thread. */
    pthread_mutex_t conn_mu;
    pthread_cond_t conn_cv;
    struct rd_conn *conns;
    pthread_t reaper;
    int reaper_on, reaper_stop;
    atomic_ullong deadline_closed; /* connections closed by a header or body deadline */
    /* Sockets answered before their body was read (an early 413), kept
     * open and drained until the client stops sending or until a bound:
     * closing a socket with unread bytes resets the connection, and a
     * client still sending would then lose the answer. Under conn_mu. */
    struct {
        int fd;
        double until;
    } lingering[RD_LINGER_MAX];
    int nlingering;
    atomic_ullong raw_refused; /* requests refused before libmicrohttpd parsed them */
    struct rd_access *access;  /* request ids, clients, the access log (access.h) */
    atomic_int ready;          /* the start-up checks passed and it listens */
};

/* The farm, once the server is ready: it starts after libmicrohttpd (its
 * daemon id holds the port), and ready is stored after it, so a thread
 * that sees ready sees the farm. NULL before. */
static inline rd_farm *rd_server_farm(rd_server *s) { return atomic_load(&s->ready) ? s->farm : NULL; }

/* The grading service, likewise: it starts once the farm has (its batches
 * are named by the daemon id). */
static inline rd_grading *rd_server_grading(rd_server *s) { return atomic_load(&s->ready) ? s->grading : NULL; }

typedef struct rd_route rd_route;

typedef struct rd_req {
    rd_server *srv;
    struct MHD_Connection *conn;
    double t0;
    char method[16];
    char path[200];
    char query[1024];    /* for the log, as key=value&... */
    char request_id[72]; /* echoed as X-Request-Id */
    char client[64];     /* the peer, or the client a trusted proxy names */
    char user_agent[256];
    int admitted; /* counted against --max-per-ip (access.h) */
    unsigned status;
    size_t bytes;
    char job_id[RD_STORE_ID_MAX];
    /* the upload */
    char *body;
    size_t len, cap;
    int answered; /* a response was queued early (413, 415, 503) */
    int too_big;  /* the body passed --max-body-bytes; the rest is dropped */
    size_t discarded;
    const rd_route *route; /* NULL: no such route */
    size_t rest;           /* where the URL goes on past the route's path */
    int started;           /* on_request has seen the request */
    int http11;            /* HTTP/1.1: may be sent an interim 102 while it waits */
    int raw;               /* half-closed while waiting: answered on the socket; close */
    /* a synchronous render */
    pthread_mutex_t mu;
    rd_jq_job *job;
    int suspended, finished;
    /* The request headers an answer's content depends on (its Vary), beside
     * the Origin that CORS adds; NULL: none. */
    const char *vary;
    /* the route's own state while the request lasts, freed by free_state */
    void *state;
    void (*free_state)(struct rd_req *r);
} rd_req;

/* One row of the route table (router.c). A path matches itself (EXACT),
 * the paths below it, "/PATH/..." (BELOW), or either; the handlers get
 * the rest of the URL after the path ("" or "/..."). */
typedef enum { RD_ROUTE_EXACT, RD_ROUTE_BELOW, RD_ROUTE_EXACT_OR_BELOW } rd_route_match;

struct rd_route {
    const char *path;
    rd_route_match match;
    const char *methods;                        /* also the Allow header of a 405 */
    const char *(*allow_for)(const char *rest); /* methods that depend on the rest; NULL: methods */
    /* The headers have arrived: refuse early (413, 415, 503) or set up.
     * NULL: nothing to do. */
    enum MHD_Result (*begin)(rd_req *r);
    /* Body bytes as they arrive; NULL: the server collects them up to
     * --max-body-bytes when collect_body is set, else drops them. */
    enum MHD_Result (*data)(rd_req *r, const char *data, size_t size);
    int collect_body;
    /* The whole request has arrived (r->body holds a collected body). */
    enum MHD_Result (*complete)(rd_req *r, const char *rest);
    /* The job it waited for ended; NULL when it never waits. */
    enum MHD_Result (*resumed)(rd_req *r);
};

/* The route of url (and where its rest starts), or NULL. */
const rd_route *rd_route_find(const char *url, size_t *rest);

/* NULL when the route takes method on that rest, else its Allow header. */
const char *rd_route_allowed(const rd_route *t, const char *method, const char *rest);

/* Queue a response and record status and size for the log. Takes ownership
 * of body (malloc'ed) when must_free. */
enum MHD_Result rd_reply(rd_req *r, unsigned status, const char *type, void *body, size_t len, int must_free);

/* The same with extra headers: name, value, ..., NULL. */
enum MHD_Result rd_reply_with(rd_req *r, unsigned status, const char *type, void *body, size_t len, int must_free,
                              const char *const *headers);

/* The web page (daemon/http/web/index.html) with this status and extra
 * headers (name, value, ..., NULL). */
enum MHD_Result rd_reply_page(rd_req *r, unsigned status, const char *const *headers);

/* The q-value, in thousandths (0 to 1000), an Accept header gives type
 * ("text/html"): that of the most specific range matching it (the type,
 * "text/wildcard", then the wildcard of all); -1 when none does or accept is
 * NULL. *named (may be NULL): the type itself is named. */
int rd_accept_quality(const char *accept, const char *type, int *named);

/* A synchronous request's job: rd_req_on_done is the job's done callback
 * (it resumes the connection); rd_req_wait suspends the connection until
 * then, or returns 1 when the job has already ended. */
void rd_req_on_done(rd_jq_job *job, void *user);
int rd_req_wait(rd_req *r, rd_jq_job *job);

/* Submits task as r's job, watching r's connection for a hang-up and
 * resuming r when it ends (or, with so->notify_prepared, once prepared):
 * 503 queue_full or unavailable when it cannot be queued; the route's
 * resumed answer when the job has already ended; else MHD_YES with r
 * suspended. so's other fields are the caller's. */
enum MHD_Result rd_req_submit(rd_req *r, const rd_jq_task *task, rd_jq_submit_options *so);

/* Answered before the body was read: when the connection closes, its
 * socket is drained for a while first (rd_server.lingering). */
void rd_req_linger(rd_req *r);

/* The client's socket, for the job to watch for a hang-up; -1 if unknown. */
int rd_req_socket(rd_req *r);

/* An error answer: {"error": {"code", "message"[, "line", "column"]}}. */
enum MHD_Result rd_reply_error(rd_req *r, unsigned status, const char *code, const rd_error *err, const char *message);

/* The same, adding a header (Allow, Retry-After). */
enum MHD_Result rd_reply_error_hdr(rd_req *r, unsigned status, const char *code, const char *message,
                                   const char *header, const char *value);

enum MHD_Result rd_reply_json(rd_req *r, unsigned status, char *json_text);

/* The answer to a waiting client whose job (what: "render", "grade") was
 * cancelled: none when the client itself hung up; 409 when a DELETE of
 * its id stopped it; 503 with Retry-After when the server is stopping. */
enum MHD_Result rd_reply_cancelled(rd_req *r, const rd_jq_info *info, const char *what);

/* Route handlers (router.c lists which serve what). */
enum MHD_Result rd_jobs_begin(rd_req *r);
enum MHD_Result rd_render_begin(rd_req *r);
enum MHD_Result rd_route_render_sync(rd_req *r, const char *rest);
enum MHD_Result rd_route_jobs_post(rd_req *r, const char *rest);
enum MHD_Result rd_route_render_resumed(rd_req *r);
enum MHD_Result rd_route_jobs_resumed(rd_req *r);
/* GET or DELETE /v1/jobs/{id}, GET /v1/jobs/{id}/image */
enum MHD_Result rd_route_job(rd_req *r, const char *rest);
/* GET /v1/jobs/{id}/image?partial=1 of a running job, once its snapshot is encoded. */
enum MHD_Result rd_route_job_image_resumed(rd_req *r);
enum MHD_Result rd_route_scenes(rd_req *r, const char *rest);
enum MHD_Result rd_route_metrics(rd_req *r, const char *rest);
enum MHD_Result rd_route_page(rd_req *r, const char *rest);
/* GET /openapi.json: docs/openapi.json, built in. */
enum MHD_Result rd_route_openapi(rd_req *r, const char *rest);
/* The list, or with rest "/NAME/scene" that assignment's scene text. */
enum MHD_Result rd_route_assignments(rd_req *r, const char *rest);
/* POST /v1/grade: the form read as it arrives, answered at its end. */
enum MHD_Result rd_route_grade_begin(rd_req *r);
enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size);
enum MHD_Result rd_route_grade(rd_req *r, const char *rest);
enum MHD_Result rd_route_grade_resumed(rd_req *r);
/* GET /v1/grades (the records, for instructors), /v1/grades/{id} (a
 * record's verdict), /v1/grades/{id}/{diff,reference,image}.png */
enum MHD_Result rd_route_grade_files(rd_req *r, const char *rest);
enum MHD_Result rd_route_grades_list(rd_req *r);
/* GET /v1/gradebook?format=moodle|canvas: the gradebook (instructors). */
enum MHD_Result rd_route_gradebook(rd_req *r, const char *rest);
/* POST /v1/grade/regrade?assignment=NAME: a regrade, as a batch (instructors). */
enum MHD_Result rd_route_regrade(rd_req *r, const char *rest);
/* DELETE /v1/grades?student=NAME, DELETE /v1/grades/{id} (instructors). */
enum MHD_Result rd_route_grades_delete(rd_req *r);
enum MHD_Result rd_route_grade_delete(rd_req *r, const char *id);
/* POST and GET /v1/grade/batch, GET /v1/grade/batch/{id}[/results.csv|.json],
 * DELETE /v1/grade/batch/{id} */
enum MHD_Result rd_route_batch_begin(rd_req *r);
enum MHD_Result rd_route_batch_data(rd_req *r, const char *data, size_t size);
enum MHD_Result rd_route_batch_post(rd_req *r, const char *rest);
/* An archive's expansion (a job of the render queue) has ended. */
enum MHD_Result rd_route_batch_resumed(rd_req *r);
enum MHD_Result rd_route_batch_get(rd_req *r, const char *rest);

/* A multipart form as it arrives: the first member of each route's form
 * struct (the request's state), read by the route's table of fields.
 * libmicrohttpd 0.9.75 cannot answer in the middle of an upload, so a form
 * found bad stops being parsed and the rest of it is read and dropped; the
 * answer goes out once it has all arrived (one that runs far past the
 * limit has its connection closed instead). */
typedef struct {
    struct MHD_PostProcessor *post;
    const struct rd_form_field *fields;
    size_t files_max;       /* every file part's bytes together; 0: no bound */
    const char *files_flag; /* ... the flag that sets it */
    size_t file_bytes;
    unsigned refused; /* 0, or the answer's status: 400, 413, 503 */
    char why[320];    /* ... and its message */
    /* The part an empty call at offset 0 began (form.c, part_starts). */
    int empty_start;
    char empty_key[64], empty_name[256];
} rd_form;

/* A file's bytes (malloc'ed, NUL-terminated; NULL while empty: the form's
 * free_state frees them with rd_form_blob_free, unless the route took
 * them), how many parts of its field began, the first one's file name. */
typedef struct {
    unsigned char *data;
    size_t len;
    int parts;
    char filename[80];
} rd_form_blob;

void rd_form_blob_free(rd_form_blob *b);

typedef enum {
    RD_FORM_TEXT, /* a char[cap] at offset, parts appended; longer is 400 saying too_long */
    RD_FORM_BLOB, /* an rd_form_blob at offset, parts appended, at most the flag at cap (413) */
    RD_FORM_FILE, /* the same, of one part only, whose file name is kept */
    RD_FORM_EACH  /* each part is the route's: part() is called with its bytes */
} rd_form_kind;

/* One field of a route's form. Every route answers the same faults with
 * the same words: a part without a name, a text too long, a second part of
 * a FILE, a part over its flag, the files over the form's. */
typedef struct rd_form_field {
    const char *name; /* NULL ends the table */
    rd_form_kind kind;
    size_t offset; /* in the route's form struct */
    /* TEXT: the array's size; BLOB, FILE: offsetof(rd_server_options, the
     * size_t flag bounding the field's bytes) */
    size_t cap;
    const char *too_long; /* TEXT: the 400's message; BLOB, FILE: the flag's name */
    /* EACH: the bytes of a part of the field (starts: its first call);
     * MHD_NO after rd_form_refuse. */
    enum MHD_Result (*part)(rd_req *r, rd_form *f, const char *filename, int starts, const char *data, size_t size);
} rd_form_field;

/* The rows of the text fields every grading form has, in a table of the
 * form struct T. */
#define RD_FORM_ASSIGNMENT(T)                                                                                          \
    {                                                                                                                  \
        "assignment", RD_FORM_TEXT, offsetof(T, assignment), sizeof(((T *)0)->assignment), RD_FORM_ASSIGNMENT_LONG,    \
            NULL                                                                                                       \
    }
#define RD_FORM_STUDENT(T)                                                                                             \
    {                                                                                                                  \
        "student", RD_FORM_TEXT, offsetof(T, student), sizeof(((T *)0)->student), RD_FORM_STUDENT_LONG, NULL           \
    }
#define RD_FORM_ASSIGNMENT_LONG "the 'assignment' field is longer than an assignment name can be"
#define RD_FORM_STUDENT_LONG "the 'student' field is longer than a student id can be"

/* Appends a part's bytes within limit (the flag named) and the form's
 * files_max: MHD_YES, or MHD_NO with the form refused (413, or 503 when out
 * of memory). */
enum MHD_Result rd_form_take(rd_form *f, const char *name, unsigned char **buf, size_t *len, size_t limit,
                             const char *flag, const char *data, size_t size);

/* The form is refused with this status and message (the first refusal
 * stands): MHD_NO, to stop the post processor. */
enum MHD_Result rd_form_refuse(rd_form *f, unsigned status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

typedef struct {
    size_t size;                 /* of the route's form struct, calloc'ed */
    const rd_form_field *fields; /* the route's table */
    size_t max_total;            /* a larger Content-Length is 413 at once ... */
    const char *too_large;       /* ... naming the flags that set it */
    size_t files_max;            /* rd_form.files_max */
    const char *files_flag;      /* rd_form.files_flag */
    const char *hint;            /* what to send, when it is not multipart/form-data (415) */
    void (*free_state)(rd_req *r);
} rd_form_spec;

/* The headers have arrived: 413, 415, or the form set up as r's state. */
enum MHD_Result rd_form_begin(rd_req *r, const rd_form_spec *spec);
/* Body bytes: parsed, or dropped once the form is refused, up to
 * discard_max dropped bytes in all, after which the connection closes. */
enum MHD_Result rd_form_data(rd_req *r, const char *data, size_t size, size_t discard_max);
/* The whole form has arrived: 0 when it was not refused, else 1 with its
 * answer (the refusal's, or 400 when there is no form) in *ret. */
int rd_form_refused(rd_req *r, enum MHD_Result *ret);
/* Destroys the post processor (the route frees its own struct). */
void rd_form_end(rd_form *f);

/* POST /v1/grade/code; GET /v1/grade/code/skeleton/{material} and
 * /v1/grade/code/{id}/lobe.svg (routes_code.c). */
enum MHD_Result rd_route_code_begin(rd_req *r);
enum MHD_Result rd_route_code_data(rd_req *r, const char *data, size_t size);
enum MHD_Result rd_route_code(rd_req *r, const char *rest);
enum MHD_Result rd_route_code_resumed(rd_req *r);
enum MHD_Result rd_route_code_get(rd_req *r, const char *rest);
/* The instructors' routes' gate (--instructor-tokens, auth.h): 0 when the
 * request may go on, else its answer (404 off, 401, 403) is in *ret. */
int rd_require_instructor(rd_req *r, enum MHD_Result *ret);

/* An image that never changes under its name: ETag etag (quoted here),
 * Cache-Control for max_age_s seconds, and 304 without a body when the
 * client's If-None-Match already names it. Takes ownership like rd_reply. */
enum MHD_Result rd_reply_immutable(rd_req *r, const char *type, void *body, size_t len, int must_free, const char *etag,
                                   double max_age_s);

/* GET /readyz: 200 once started, 503 while starting or draining. */
enum MHD_Result rd_route_ready(rd_req *r, const char *rest);

/* The 413 of a body over --max-body-bytes. */
enum MHD_Result rd_reply_too_large(rd_req *r, const char *what);

/* The 503 of a server that is stopping. */
enum MHD_Result rd_reply_draining(rd_req *r);

/* The 503 of a server whose start-up has not finished. */
enum MHD_Result rd_reply_starting(rd_req *r);

/* The answer to err as the error map gives it (error_map.h), a stage's
 * (rd_code_error_answer, ...) or the code's own (rd_reply_failed): its
 * status and JSON code, Retry-After when it has one, the message after
 * the answer's lead. */
enum MHD_Result rd_reply_answer(rd_req *r, rd_error_answer a, const rd_error *err);
enum MHD_Result rd_reply_failed(rd_req *r, const rd_error *err);

/* The web page, generated from daemon/http/web/index.html. */
extern const char rd_web_index_html[];

/* The OpenAPI description, generated from docs/openapi.json. */
extern const char rd_openapi_json[];

#endif
