/* Shared between the daemon's HTTP files: one request's state and the
 * helpers that answer it. Not a public interface. */
#ifndef RD_HTTP_INTERNAL_H
#define RD_HTTP_INTERNAL_H

#include <microhttpd.h>
#include <pthread.h>
#include <stdatomic.h>

#include "rayd/error.h"
#include "error_map.h"
#include "server.h"

struct rd_server {
    rd_server_options opt;
    struct MHD_Daemon *mhd;
    rd_jq *jobs;
    atomic_int draining;
    uint16_t port;
    atomic_ullong http_count[6];    /* 1xx..5xx answers, index = class; [0] unused */
    atomic_ullong requests;
    atomic_int waiting;             /* suspended synchronous renders */
    atomic_int stopped;
    struct rd_grades *grades;       /* grade results and the reference cache */
    /* Every open connection with its deadline, for the reaper thread. */
    pthread_mutex_t conn_mu;
    pthread_cond_t conn_cv;
    struct rd_conn *conns;
    pthread_t reaper;
    int reaper_on, reaper_stop;
    atomic_ullong deadline_closed;  /* connections closed by a header or body deadline */
    atomic_ullong raw_refused;      /* requests refused before libmicrohttpd parsed them */
};

/* One grading request in progress (routes_grade.c). */
typedef struct rd_grade_req rd_grade_req;

typedef struct {
    rd_server *srv;
    struct MHD_Connection *conn;
    double t0;
    char method[16];
    char path[200];
    unsigned status;
    size_t bytes;
    char job_id[24];
    /* the upload */
    char *body;
    size_t len, cap;
    int answered;           /* a response was queued early (413, 415, 503) */
    int too_big;            /* the body passed --max-body-bytes; the rest is dropped */
    size_t discarded;
    int kind;               /* which route, see http_server.c */
    int started;            /* on_request has seen the request */
    int http11;             /* HTTP/1.1: may be sent an interim 102 while it waits */
    int async;              /* POST /v1/jobs: answered 202 once the scene is read */
    int raw;                /* half-closed while waiting: answered on the socket; close */
    /* a synchronous render */
    pthread_mutex_t mu;
    rd_jq_job *job;
    int suspended, finished;
    /* POST /v1/grade */
    struct MHD_PostProcessor *post;
    rd_grade_req *grade;
} rd_req;

/* Queue a response and record status and size for the log. Takes ownership
 * of body (malloc'ed) when must_free. */
enum MHD_Result rd_reply(rd_req *r, unsigned status, const char *type, void *body, size_t len,
                         int must_free);

/* The same with extra headers: name, value, ..., NULL. */
enum MHD_Result rd_reply_with(rd_req *r, unsigned status, const char *type, void *body, size_t len, int must_free,
                              const char *const *headers);

/* A synchronous request's job: rd_req_on_done is the job's done callback
 * (it resumes the connection); rd_req_wait suspends the connection until
 * then, or returns 1 when the job has already ended. */
void rd_req_on_done(rd_jq_job *job, void *user);
int rd_req_wait(rd_req *r, rd_jq_job *job);

/* The client's socket, for the job to watch for a hang-up; -1 if unknown. */
int rd_req_socket(rd_req *r);

/* An error answer: {"error": {"code", "message"[, "line", "column"]}}. */
enum MHD_Result rd_reply_error(rd_req *r, unsigned status, const char *code, const rd_error *err,
                               const char *message);

/* The same, adding a header (Allow, Retry-After). */
enum MHD_Result rd_reply_error_hdr(rd_req *r, unsigned status, const char *code, const char *message,
                                   const char *header, const char *value);

enum MHD_Result rd_reply_json(rd_req *r, unsigned status, char *json_text);

/* HTTP status for a scene error code. */

/* Route handlers. The body is complete when they are called. */
enum MHD_Result rd_route_render(rd_req *r, int async);
enum MHD_Result rd_route_render_resumed(rd_req *r);
enum MHD_Result rd_route_job(rd_req *r, const char *id, const char *rest);
/* GET /v1/jobs/{id}/image?partial=1 of a running job, once its snapshot is encoded. */
enum MHD_Result rd_route_job_image_resumed(rd_req *r);
enum MHD_Result rd_route_scenes(rd_req *r, const char *name);
enum MHD_Result rd_route_metrics(rd_req *r);
enum MHD_Result rd_route_page(rd_req *r);
/* The list, or with name "NAME/scene" that assignment's scene text. */
enum MHD_Result rd_route_assignments(rd_req *r, const char *name);
/* First call of POST /v1/grade: set up the form reader (or answer 415). */
enum MHD_Result rd_route_grade_begin(rd_req *r);
enum MHD_Result rd_route_grade_data(rd_req *r, const char *data, size_t size);
enum MHD_Result rd_route_grade(rd_req *r);
enum MHD_Result rd_route_grade_resumed(rd_req *r);
enum MHD_Result rd_route_grade_files(rd_req *r, const char *rest);
void rd_grade_req_free(rd_req *r);

struct rd_grades *rd_grades_new(rd_jq *jobs, const rd_server_options *opt);
void rd_grades_free(struct rd_grades *g);

/* The web page, generated from daemon/http/web/index.html. */
extern const char rd_web_index_html[];

#endif
