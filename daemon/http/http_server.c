#define _GNU_SOURCE /* POLLRDHUP */
#include <arpa/inet.h>
#include <cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "access.h"
#include "codegrade.h"
#include "http_internal.h"
#include "log.h"
#include "metrics.h"
#include "rayd/clock.h"
#include "roster.h"
#include "timed_wait.h"
#include "version.h"

/* An open connection. libmicrohttpd's own timeout counts idle time, which
 * every trickled byte resets; these deadlines count from when the headers
 * (or the body) began, so a client that sends a byte a second cannot hold
 * a slot. */
struct rd_conn {
    int fd;
    int linger;      /* drain before closing (rd_req_linger) */
    double deadline; /* monotonic ms; 0 = none (the request is being answered) */
    struct rd_conn *prev, *next;
};

static void set_deadline(rd_server *s, struct MHD_Connection *conn, double after_ms)
{
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    struct rd_conn *c = ci ? ci->socket_context : NULL;
    if (!c)
        return;
    pthread_mutex_lock(&s->conn_mu);
    c->deadline = after_ms > 0 ? rd_now_ms() + after_ms : 0;
    pthread_mutex_unlock(&s->conn_mu);
}

/* Keeps a copy of the socket, whose other end may still be sending, to be
 * drained by the reaper; libmicrohttpd's close then ends nothing. Past
 * RD_LINGER_MAX of them it is closed at once. Under conn_mu. */
static void start_lingering(rd_server *s, int fd)
{
    if (s->nlingering >= RD_LINGER_MAX)
        return;
    int copy = fcntl(fd, F_DUPFD_CLOEXEC, 0);
    if (copy < 0)
        return;
    fcntl(copy, F_SETFL, fcntl(copy, F_GETFL) | O_NONBLOCK);
    shutdown(copy, SHUT_WR); /* the answer is out: the client sees its end */
    s->lingering[s->nlingering].fd = copy;
    s->lingering[s->nlingering].until = rd_now_ms() + RD_LINGER_MS;
    s->nlingering++;
    pthread_cond_signal(&s->conn_cv);
}

/* Reads and drops what lingering sockets hold; closes those whose client
 * has stopped (end of stream, an error) or whose time is up, or all with
 * everything. Under conn_mu. */
static void drain_lingering(rd_server *s, int everything)
{
    static char sink[65536];
    double now = rd_now_ms();
    for (int i = 0; i < s->nlingering;) {
        ssize_t k = 1;
        for (int reads = 0; reads < 64 && k > 0; reads++)
            k = recv(s->lingering[i].fd, sink, sizeof sink, 0);
        int ended = k == 0 || (k < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
        if (everything || ended || now > s->lingering[i].until) {
            close(s->lingering[i].fd);
            s->lingering[i] = s->lingering[--s->nlingering];
        } else {
            i++;
        }
    }
}

static void on_connection(void *cls, struct MHD_Connection *conn, void **socket_context,
                          enum MHD_ConnectionNotificationCode code)
{
    rd_server *s = cls;
    if (!socket_context)
        return;
    if (code == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
        struct rd_conn *c = ci ? calloc(1, sizeof *c) : NULL;
        *socket_context = c;
        if (!c)
            return;
        c->fd = ci->connect_fd;
        pthread_mutex_lock(&s->conn_mu);
        c->deadline = rd_now_ms() + s->opt.header_timeout_ms;
        c->next = s->conns;
        if (s->conns)
            s->conns->prev = c;
        s->conns = c;
        pthread_mutex_unlock(&s->conn_mu);
        return;
    }
    /* Closed: libmicrohttpd closes the socket after this returns, so the
     * reaper never touches a descriptor that may have been reused. */
    struct rd_conn *c = *socket_context;
    if (!c)
        return;
    pthread_mutex_lock(&s->conn_mu);
    if (c->linger)
        start_lingering(s, c->fd);
    if (c->prev)
        c->prev->next = c->next;
    else
        s->conns = c->next;
    if (c->next)
        c->next->prev = c->prev;
    pthread_mutex_unlock(&s->conn_mu);
    free(c);
    *socket_context = NULL;
}

/* Ten times a second: connections past their deadline are shut down;
 * libmicrohttpd then sees the end of the stream and closes them. */
static void *reaper(void *arg)
{
    rd_server *s = arg;
    pthread_mutex_lock(&s->conn_mu);
    while (!s->reaper_stop) {
        double now = rd_now_ms();
        for (struct rd_conn *c = s->conns; c; c = c->next)
            if (c->deadline > 0 && now > c->deadline) {
                shutdown(c->fd, SHUT_RDWR);
                c->deadline = 0;
                atomic_fetch_add(&s->deadline_closed, 1);
            }
        drain_lingering(s, 0);
        rd_timed_wait(&s->conn_cv, &s->conn_mu, s->nlingering ? 10 : 100);
    }
    drain_lingering(s, 1);
    pthread_mutex_unlock(&s->conn_mu);
    return NULL;
}

/* on_uri's answer for a request it refused: no state of its own, since
 * libmicrohttpd 0.9.75 does not report the end of a request whose headers
 * never completed, and anything allocated here could leak. */
static char refused_request;

/* Called with the request line before libmicrohttpd splits the query.
 * Thousands of arguments exhaust its per-connection memory, after which it
 * can send nothing at all, so such a request is answered 431 here, on the
 * socket, and the sending side closed; libmicrohttpd then drops the
 * connection. */
static void *on_uri(void *cls, const char *uri, struct MHD_Connection *conn)
{
    rd_server *s = cls;
    const char *q = uri ? strchr(uri, '?') : NULL;
    unsigned args = q ? 1 : 0;
    for (const char *p = q; p && *p; p++)
        args += *p == '&';
    if (args <= s->opt.max_query_args)
        return NULL;
    char body[200], head[400];
    int bl = snprintf(body, sizeof body,
                      "{\"error\":{\"code\":\"too_many_arguments\",\"message\":\"the query has %u arguments, "
                      "over the limit of %u (--max-query-args)\"}}",
                      args, s->opt.max_query_args);
    char id[24];
    rd_access_new_id(s->access, id, sizeof id);
    int hl = snprintf(head, sizeof head,
                      "HTTP/1.1 431 Request Header Fields Too Large\r\nContent-Type: application/json\r\n"
                      "Content-Length: %d\r\nX-Request-Id: %s\r\nConnection: close\r\n\r\n",
                      bl, id);
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
    int fd = ci ? ci->connect_fd : -1;
    if (fd >= 0 && send(fd, head, (size_t)hl, MSG_NOSIGNAL | MSG_DONTWAIT) == hl)
        send(fd, body, (size_t)bl, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (fd >= 0)
        shutdown(fd, SHUT_WR);
    atomic_fetch_add(&s->raw_refused, 1);
    rd_metrics_refused(s);
    return &refused_request;
}

/* Below the 5 s a stopping server waits for suspended clients. */
enum { RAW_ANSWER_MS = 4000 };

/* At a stop: how long cancelled jobs may take to end (one is bounded by its
 * parse, the rest stop within milliseconds), then how long the resumed
 * clients' answers may take to go out. */
enum { CANCELLED_END_MS = 30000, ANSWERS_SENT_MS = 5000 };

/* 1 when the client shut its sending side but still reads. */
static int peer_half_closed(int fd)
{
    struct pollfd p = {fd, POLLIN | POLLRDHUP, 0};
    if (fd < 0 || poll(&p, 1, 0) <= 0 || (p.revents & (POLLHUP | POLLERR | POLLNVAL)))
        return 0;
    char c;
    return (p.revents & POLLRDHUP) || recv(fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0;
}

static int send_all(int fd, const void *data, size_t len, double deadline)
{
    const char *p = data;
    while (len > 0 && rd_now_ms() < deadline) {
        ssize_t k = send(fd, p, len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (k > 0) {
            p += k;
            len -= (size_t)k;
        } else if (k < 0 && (errno == EAGAIN || errno == EINTR)) {
            struct pollfd w = {fd, POLLOUT, 0};
            poll(&w, 1, 100);
        } else {
            return 0;
        }
    }
    return len == 0;
}

/* The answer to a client that half-closed while it waited. libmicrohttpd
 * 0.9.75 drops a connection as soon as it reads an end of stream, whatever
 * the request's state, so once resumed it would close this one before
 * sending; the answer goes out on the socket instead (nothing else was
 * sent on it) within RAW_ANSWER_MS, before the connection is resumed and
 * closed. */
static enum MHD_Result reply_raw(rd_req *r, int fd, unsigned status, const char *type, const void *body, size_t len,
                                 const char *const *headers)
{
    char head[2048];
    const char *reason = MHD_get_reason_phrase_for(status);
    size_t n = (size_t)snprintf(head, sizeof head, "HTTP/1.1 %u %s\r\nConnection: close\r\nContent-Length: %zu\r\n",
                                status, reason ? reason : "", len);
    if (type)
        n += (size_t)snprintf(head + n, sizeof head - n, "Content-Type: %s\r\n", type);
    if (r->job_id[0])
        n += (size_t)snprintf(head + n, sizeof head - n, "X-Rayd-Job: %s\r\n", r->job_id);
    if (r->request_id[0])
        n += (size_t)snprintf(head + n, sizeof head - n, "X-Request-Id: %s\r\n", r->request_id);
    for (int i = 0; headers && headers[i] && headers[i + 1] && n < sizeof head; i += 2)
        n += (size_t)snprintf(head + n, sizeof head - n, "%s: %s\r\n", headers[i], headers[i + 1]);
    if (n + 2 >= sizeof head)
        return MHD_NO;
    memcpy(head + n, "\r\n", 2);
    n += 2;
    double deadline = rd_now_ms() + RAW_ANSWER_MS;
    if (send_all(fd, head, n, deadline) && send_all(fd, body, len, deadline)) {
        r->status = status;
        r->bytes = len;
    }
    r->answered = 1;
    return MHD_NO;
}

/* Headers a browser on --cors-origin needs to read the answer. */
static void add_cors(rd_req *r, struct MHD_Response *resp)
{
    const char *origin = r->srv->opt.cors_origin;
    if (!origin)
        return;
    MHD_add_response_header(resp, "Access-Control-Allow-Origin", origin);
    MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                            "X-Request-Id, X-Rayd-Job, X-Rayd-Daemon, X-Rayd-Render-Ms, X-Rayd-Samples, X-Rayd-Passes, "
                            "X-Rayd-Error-Estimate, X-Rayd-Stopped-By, Retry-After, ETag");
}

/* One Vary naming every request header the answer depends on: Origin when
 * CORS names one origin, and the route's own (r->vary). */
static void add_vary(rd_req *r, struct MHD_Response *resp)
{
    const char *origin = r->srv->opt.cors_origin;
    int by_origin = origin && strcmp(origin, "*") != 0;
    char vary[96];
    snprintf(vary, sizeof vary, "%s%s%s", by_origin ? "Origin" : "", by_origin && r->vary ? ", " : "",
             r->vary ? r->vary : "");
    if (vary[0])
        MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY, vary);
}

enum MHD_Result rd_reply_with(rd_req *r, unsigned status, const char *type, void *body, size_t len, int must_free,
                              const char *const *headers)
{
    if (r->raw) {
        enum MHD_Result ret = reply_raw(r, rd_req_socket(r), status, type, body, len, headers);
        if (must_free)
            free(body);
        return ret;
    }
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(len, body, must_free ? MHD_RESPMEM_MUST_FREE : MHD_RESPMEM_PERSISTENT);
    if (!resp) {
        if (must_free)
            free(body);
        return MHD_NO;
    }
    if (type)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    if (r->job_id[0])
        MHD_add_response_header(resp, "X-Rayd-Job", r->job_id);
    if (r->request_id[0])
        MHD_add_response_header(resp, "X-Request-Id", r->request_id);
    /* Which daemon answered, behind a load balancer. */
    if (r->srv->daemon_id[0])
        MHD_add_response_header(resp, "X-Rayd-Daemon", r->srv->daemon_id);
    add_cors(r, resp);
    add_vary(r, resp);
    for (int i = 0; headers && headers[i] && headers[i + 1]; i += 2)
        MHD_add_response_header(resp, headers[i], headers[i + 1]);
    r->status = status;
    r->bytes = len;
    r->answered = 1;
    enum MHD_Result ret = MHD_queue_response(r->conn, status, resp);
    MHD_destroy_response(resp);
    return ret;
}

enum MHD_Result rd_reply(rd_req *r, unsigned status, const char *type, void *body, size_t len, int must_free)
{
    return rd_reply_with(r, status, type, body, len, must_free, NULL);
}

/* 1 when an If-None-Match list holds tag (or is "*"). */
static int etag_matches(const char *inm, const char *tag)
{
    if (!inm)
        return 0;
    if (strcmp(inm, "*") == 0)
        return 1;
    size_t n = strlen(tag);
    for (const char *p = inm; (p = strstr(p, tag)); p += n)
        if ((p == inm || p[-1] == ' ' || p[-1] == ',' || p[-1] == '/') && (p[n] == 0 || p[n] == ',' || p[n] == ' '))
            return 1;
    return 0;
}

enum MHD_Result rd_reply_immutable(rd_req *r, const char *type, void *body, size_t len, int must_free, const char *etag,
                                   double max_age_s)
{
    char tag[96], cache[96];
    snprintf(tag, sizeof tag, "\"%s\"", etag);
    snprintf(cache, sizeof cache, "private, max-age=%.0f, immutable", max_age_s > 0 ? max_age_s : 0);
    const char *headers[] = {MHD_HTTP_HEADER_ETAG, tag, MHD_HTTP_HEADER_CACHE_CONTROL, cache, NULL};
    if (etag_matches(MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_IF_NONE_MATCH), tag)) {
        if (must_free)
            free(body);
        return rd_reply_with(r, 304, NULL, (void *)"", 0, 0, headers);
    }
    return rd_reply_with(r, 200, type, body, len, must_free, headers);
}

/* OPTIONS: what the route takes, and a browser's preflight answer. */
static enum MHD_Result reply_options(rd_req *r, const char *allow)
{
    const char *cors = r->srv->opt.cors_origin;
    char methods[96];
    snprintf(methods, sizeof methods, "%s, OPTIONS", allow);
    /* Without --cors-origin the list ends after Allow. */
    const char *headers[] = {MHD_HTTP_HEADER_ALLOW,
                             methods,
                             cors ? "Access-Control-Allow-Methods" : NULL,
                             methods,
                             "Access-Control-Allow-Headers",
                             "Content-Type, Accept, X-Request-Id, Authorization",
                             "Access-Control-Max-Age",
                             "600",
                             NULL};
    return rd_reply_with(r, 204, NULL, (void *)"", 0, 0, headers);
}

static char *error_json(const char *code, const char *message, const rd_error *err)
{
    cJSON *root = cJSON_CreateObject(), *e = cJSON_AddObjectToObject(root, "error");
    cJSON_AddStringToObject(e, "code", code);
    cJSON_AddStringToObject(e, "message", err ? err->message : message);
    if (err && err->line > 0) {
        cJSON_AddNumberToObject(e, "line", err->line);
        cJSON_AddNumberToObject(e, "column", err->column);
    }
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

static enum MHD_Result reply_error_full(rd_req *r, unsigned status, const char *code, const rd_error *err,
                                        const char *message, const char *header, const char *value)
{
    char *text = error_json(code, message, err);
    if (!text)
        return MHD_NO;
    const char *headers[] = {header, value, NULL};
    return rd_reply_with(r, status, "application/json", text, strlen(text), 1, header ? headers : NULL);
}

enum MHD_Result rd_reply_error(rd_req *r, unsigned status, const char *code, const rd_error *err, const char *message)
{
    return reply_error_full(r, status, code, err, message, NULL, NULL);
}

enum MHD_Result rd_reply_error_hdr(rd_req *r, unsigned status, const char *code, const char *message,
                                   const char *header, const char *value)
{
    return reply_error_full(r, status, code, NULL, message, header, value);
}

enum MHD_Result rd_reply_json(rd_req *r, unsigned status, char *json_text)
{
    if (!json_text)
        return MHD_NO;
    return rd_reply(r, status, "application/json", json_text, strlen(json_text), 1);
}

enum MHD_Result rd_reply_cancelled(rd_req *r, const rd_jq_info *info, const char *what)
{
    char msg[160];
    if (info->hung_up)
        return MHD_NO; /* nobody to answer: close, and the log says so */
    if (info->requested) {
        snprintf(msg, sizeof msg, "the %s was cancelled: DELETE /v1/jobs/%s", what, info->id);
        return rd_reply_error(r, 409, "cancelled", NULL, msg);
    }
    snprintf(msg, sizeof msg, "the %s was cancelled: the server is shutting down", what);
    return rd_reply_error_hdr(r, 503, "cancelled", msg, "Retry-After", "5");
}

void rd_req_linger(rd_req *r)
{
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(r->conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    struct rd_conn *c = ci ? ci->socket_context : NULL;
    if (!c)
        return;
    pthread_mutex_lock(&r->srv->conn_mu);
    c->linger = 1;
    pthread_mutex_unlock(&r->srv->conn_mu);
}

enum MHD_Result rd_reply_too_large(rd_req *r, const char *what)
{
    rd_req_linger(r);
    char msg[160];
    snprintf(msg, sizeof msg, "%s is over the limit of %zu bytes (--max-body-bytes)", what, r->srv->opt.max_body_bytes);
    return rd_reply_error(r, 413, "too_large", NULL, msg);
}

enum MHD_Result rd_reply_draining(rd_req *r)
{
    return rd_reply_error_hdr(r, 503, "draining", "the server is shutting down", "Retry-After", "5");
}

enum MHD_Result rd_reply_starting(rd_req *r)
{
    return rd_reply_error_hdr(r, 503, "starting", "the server is starting", "Retry-After", "1");
}

enum MHD_Result rd_reply_answer(rd_req *r, rd_error_answer a, const rd_error *err)
{
    rd_error said = *err; /* its line and column stay */
    if (a.lead)
        snprintf(said.message, sizeof said.message, "%s (%.*s)", a.lead, (int)(sizeof said.message / 2), err->message);
    char after[16];
    snprintf(after, sizeof after, "%u", a.retry_after);
    return reply_error_full(r, a.http, a.code, &said, NULL, a.retry_after ? "Retry-After" : NULL, after);
}

enum MHD_Result rd_reply_failed(rd_req *r, const rd_error *err)
{
    return rd_reply_answer(r, rd_error_answer_for(err->code), err);
}

/* Answers a half-closed client on the socket, then resumes its connection
 * for libmicrohttpd to close. Its own thread: a slow reader must hold
 * neither a render thread nor an HTTP thread. */
static void *raw_answer_main(void *arg)
{
    rd_req *r = arg;
    r->route->resumed(r);
    pthread_mutex_lock(&r->mu);
    MHD_resume_connection(r->conn);
    pthread_mutex_unlock(&r->mu);
    return NULL;
}

void rd_req_on_done(rd_jq_job *job, void *user)
{
    (void)job;
    rd_req *r = user;
    pthread_mutex_lock(&r->mu);
    r->finished = 1;
    if (r->suspended && !atomic_load(&r->srv->stopped)) {
        pthread_t t;
        pthread_attr_t attr;
        r->raw = r->http11 && peer_half_closed(rd_req_socket(r));
        if (r->raw && pthread_attr_init(&attr) == 0) {
            pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
            if (pthread_create(&t, &attr, raw_answer_main, r) != 0)
                r->raw = 0;
            pthread_attr_destroy(&attr);
        }
        if (!r->raw)
            MHD_resume_connection(r->conn);
    }
    pthread_mutex_unlock(&r->mu);
}

int rd_req_wait(rd_req *r, rd_jq_job *job)
{
    rd_server *srv = r->srv;
    r->job = job;
    pthread_mutex_lock(&r->mu);
    int finished = r->finished, late = 0;
    if (!finished) {
        pthread_mutex_lock(&srv->conn_mu);
        late = srv->no_more_waits;
        if (!late) {
            MHD_suspend_connection(r->conn);
            r->suspended = 1;
            atomic_fetch_add(&srv->waiting, 1);
        }
        pthread_mutex_unlock(&srv->conn_mu);
    }
    pthread_mutex_unlock(&r->mu);
    if (late) {
        /* Too late to wait: the job stops now and is answered as stopped
         * by the shutdown, on this thread. */
        rd_jq_cancel(srv->jobs, job);
        rd_jq_wait_ended(srv->jobs, job, CANCELLED_END_MS);
        finished = 1;
    }
    return finished;
}

enum MHD_Result rd_req_submit(rd_req *r, const rd_jq_task *task, rd_jq_submit_options *so)
{
    so->watch_fd = rd_req_socket(r);
    so->watch_http11 = r->http11;
    so->done = rd_req_on_done;
    so->user = r;
    rd_jq_job *job;
    rd_error err = {0};
    rd_error_code rc = rd_jq_submit(r->srv->jobs, task, so, &job, &err);
    if (rc == RD_ERR_BUSY)
        return rd_reply_error_hdr(r, 503, "queue_full", err.message, "Retry-After", "1");
    if (rc == RD_ERR_LIMIT) /* it could never fit the memory budget */
        return rd_reply_error(r, 413, "too_large", &err, NULL);
    if (rc)
        return rd_reply_error(r, 503, "unavailable", &err, NULL);
    rd_jq_info info;
    rd_jq_info_get(r->srv->jobs, job, &info);
    snprintf(r->job_id, sizeof r->job_id, "%s", info.id);
    return rd_req_wait(r, job) ? r->route->resumed(r) : MHD_YES;
}

int rd_req_socket(rd_req *r)
{
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(r->conn, MHD_CONNECTION_INFO_CONNECTION_FD);
    return ci ? ci->connect_fd : -1;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url, const char *method,
                                  const char *version, const char *upload, size_t *upload_size, void **con_cls)
{
    rd_server *srv = cls;
    if (*con_cls == &refused_request)
        return MHD_NO;
    rd_req *r = *con_cls;
    if (!r) {
        r = calloc(1, sizeof *r);
        if (!r)
            return MHD_NO;
        pthread_mutex_init(&r->mu, NULL);
        r->srv = srv;
        r->conn = conn;
        r->t0 = rd_now_ms();
        *con_cls = r;
    }
    if (r->raw)
        return MHD_NO;
    if (!r->started) {
        r->started = 1;
        r->http11 = version && strcmp(version, MHD_HTTP_VERSION_1_1) == 0;
        snprintf(r->method, sizeof r->method, "%s", method);
        snprintf(r->path, sizeof r->path, "%s", url);
        set_deadline(srv, conn, srv->opt.body_timeout_ms);
        atomic_fetch_add(&srv->requests, 1);
        rd_access_begin(srv->access, r);
        r->route = rd_route_find(url, &r->rest);
        if (!rd_access_admit(srv->access, r))
            return rd_reply_error_hdr(r, 429, "too_many_requests", "this client has --max-per-ip requests open already",
                                      "Retry-After", "1");
        if (!r->route)
            return MHD_YES; /* answered 404 once the request is in */
        if (strcmp(method, "OPTIONS") == 0) {
            const char *all = r->route->allow_for ? r->route->allow_for(url + r->rest) : r->route->methods;
            return reply_options(r, all);
        }
        const char *allow = rd_route_allowed(r->route, method, url + r->rest);
        if (allow)
            return rd_reply_error_hdr(r, 405, "method_not_allowed", "method not allowed on this route",
                                      MHD_HTTP_HEADER_ALLOW, allow);
        return r->route->begin ? r->route->begin(r) : MHD_YES;
    }
    if (*upload_size) {
        size_t n = *upload_size;
        *upload_size = 0;
        if (r->answered || !r->route)
            return MHD_YES;
        if (r->route->data)
            return r->route->data(r, upload, n);
        if (!r->route->collect_body)
            return MHD_YES; /* bodies of other routes are ignored */
        if (r->too_big || r->len + n > r->srv->opt.max_body_bytes) {
            /* A chunked body (no Content-Length to refuse up front) went
             * past the limit. libmicrohttpd 0.9.75 cannot answer in the
             * middle of an upload, so drop the rest (nothing is kept) and
             * answer 413 at its end; one that runs more than 1 MiB further
             * gets its connection closed instead of being read on. */
            free(r->body);
            r->body = NULL;
            r->too_big = 1;
            r->discarded += n;
            return r->discarded > (1u << 20) ? MHD_NO : MHD_YES;
        }
        if (r->len + n + 1 > r->cap) {
            size_t nc = r->cap ? r->cap : 4096;
            while (nc < r->len + n + 1)
                nc *= 2;
            char *p = realloc(r->body, nc);
            if (!p)
                return MHD_NO;
            r->body = p;
            r->cap = nc;
        }
        memcpy(r->body + r->len, upload, n);
        r->len += n;
        r->body[r->len] = 0;
        return MHD_YES;
    }
    set_deadline(srv, conn, 0);
    if (r->answered)
        return MHD_YES;
    if (r->too_big)
        return rd_reply_too_large(r, "the body");
    if (!r->route)
        return rd_reply_error(r, 404, "not_found", NULL, "no such route");
    if (r->job)
        return r->route->resumed(r);
    return r->route->complete(r, url + r->rest);
}

static void on_completed(void *cls, struct MHD_Connection *conn, void **con_cls, enum MHD_RequestTerminationCode toe)
{
    rd_server *srv = cls;
    rd_req *r = *con_cls;
    *con_cls = NULL;
    if (!r || r == (void *)&refused_request)
        return;
    /* A kept-alive connection may idle for --connection-timeout, then has
     * the header deadline for its next request. */
    set_deadline(srv, conn, srv->opt.connection_timeout_s * 1e3 + srv->opt.header_timeout_ms);
    rd_metrics_request_done(srv, r, rd_now_ms() - r->t0);
    rd_access_log(&srv->opt, r, rd_now_ms() - r->t0, toe != MHD_REQUEST_TERMINATED_COMPLETED_OK);
    rd_access_end(srv->access, r);
    if (r->job) {
        /* A client that went away no longer wants its render. */
        rd_jq_detach(srv->jobs, r->job);
        rd_jq_cancel(srv->jobs, r->job);
        rd_jq_job_unref(r->job);
    }
    if (r->suspended)
        atomic_fetch_sub(&srv->waiting, 1);
    /* A render thread may still be inside on_done, just past its resume. */
    pthread_mutex_lock(&r->mu);
    pthread_mutex_unlock(&r->mu);
    pthread_mutex_destroy(&r->mu);
    if (r->free_state)
        r->free_state(r);
    free(r->body);
    free(r);
}

rd_server_options rd_server_options_default(void)
{
    rd_server_options o;
    memset(&o, 0, sizeof o);
    o.listen_host = "127.0.0.1";
    o.port = 8080;
    o.http_threads = 2;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    o.jobs.workers = cores > 0 ? (int)cores : 1;
    o.jobs.queue_length = 64;
    o.jobs.job_timeout_ms = 120000;
    o.jobs.result_memory = 256u << 20;
    o.jobs.result_ttl_ms = 600e3;
    o.jobs.kept_max = 4096;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    o.jobs.memory_budget = pages > 0 && page > 0 ? (size_t)pages * (size_t)page / 2 : (size_t)4 << 30;
    o.jobs.png = rd_png_options_default();
    o.limits = rd_scene_limits_default();
    o.max_body_bytes = 16u << 20;
    o.max_connections = 1024;
    o.max_per_ip = 512;
    o.connection_timeout_s = 30;
    o.header_timeout_ms = 10000;
    o.body_timeout_ms = 60000;
    o.max_query_args = 64;
    o.grade_cache_bytes = 256u << 20;
    o.data_dir = "var";
    o.lease_ms = 10000;
    o.store_tile = 64;
    o.grade_ttl_ms = 180 * 86400e3;
    o.max_batch_images = 500;
    o.max_batch_bytes = 256u << 20;
    o.max_batch_expanded = (size_t)1 << 30;
    o.scenes_dir = rd_default_scenes_dir();
    o.assignments_dir = rd_default_assignments_dir();
    o.bwrap = "/usr/bin/bwrap";
    o.course_dir = rd_default_course_dir();
    o.code_eval = rd_default_eval_path();
    o.max_code_bytes = RD_CODE_MAX_BYTES_DEFAULT;
    o.max_code_jobs = 2;
    o.max_code_jobs_per_client = 1;
    o.code_compile_ms = 30000;
    o.code_run_ms = 20000;
    o.sandbox_uid = 65534;
    return o;
}

static void free_server(rd_server *s)
{
    if (s->reaper_on) {
        pthread_mutex_lock(&s->conn_mu);
        s->reaper_stop = 1;
        pthread_cond_broadcast(&s->conn_cv);
        pthread_mutex_unlock(&s->conn_mu);
        pthread_join(s->reaper, NULL);
    }
    /* One shutdown order: the render threads stop (the stored tiles they
     * render stop with them, and grades or submissions in progress end,
     * committing through the farm); then the farm gives its leases back and
     * returns what it held to the budget; then the grading service,
     * whose tasks the queue ran and whose caches it counts, and the rest. */
    rd_jq_stop(s->jobs);
    rd_farm_stop(s->farm);
    rd_grading_free(s->grading);
    rd_jq_free(s->jobs);
    rd_farm_free(s->farm);
    rd_access_free(s->access);
    rd_auth_free(s->auth);
    pthread_mutex_destroy(&s->auth_mu);
    rd_metrics_free(s->metrics);
    pthread_mutex_destroy(&s->conn_mu);
    pthread_cond_destroy(&s->conn_cv);
    free(s);
}

rd_error_code rd_listen_resolve(const char *host, uint16_t port, rd_listen_addr *out, rd_error *err)
{
    char service[8];
    snprintf(service, sizeof service, "%u", (unsigned)port);
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM, .ai_flags = AI_PASSIVE}, *res = NULL;
    int rc = getaddrinfo(host && *host ? host : NULL, service, &hints, &res);
    if (rc != 0 || !res || res->ai_addrlen > sizeof out->addr) {
        if (res)
            freeaddrinfo(res);
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "--listen: '%s' does not resolve (%s)", host,
                            rc ? gai_strerror(rc) : "no address");
    }
    memcpy(&out->addr, res->ai_addr, res->ai_addrlen);
    out->len = res->ai_addrlen;
    freeaddrinfo(res);
    return RD_OK;
}

static rd_error_code need_dir(const char *dir, const char *flag, rd_error *err)
{
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "the folder %s (%s) %s", dir, flag,
                            errno == ENOENT ? "does not exist" : "is not a readable folder");
    return RD_OK;
}

/* mkdir -p, for --cache-dir. */
static rd_error_code make_dir(const char *dir, rd_error *err)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "--cache-dir: the path is too long");
    for (char *p = path + 1;; p++) {
        if (*p != '/' && *p)
            continue;
        char c = *p;
        *p = 0;
        if (mkdir(path, 0750) != 0 && errno != EEXIST)
            return rd_error_set(err, RD_ERR_IO, 0, 0, "cannot create the folder %s (--cache-dir): %s", path,
                                strerror(errno));
        *p = c;
        if (!c)
            break;
    }
    return need_dir(dir, "--cache-dir", err);
}

/* What must hold before the daemon listens: its folders are there. */
static rd_error_code start_checks(const rd_server_options *opt, rd_error *err)
{
    if (need_dir(opt->scenes_dir, "--scenes", err) || need_dir(opt->assignments_dir, "--assignments", err))
        return err->code;
    return opt->cache_dir ? make_dir(opt->cache_dir, err) : RD_OK;
}

/* libmicrohttpd's own messages go through the log, so a JSON log stays
 * JSON on every line. */
static void mhd_log(void *cls, const char *fmt, va_list ap)
{
    rd_server *s = cls;
    char msg[1024];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && (msg[n - 1] == '\n' || msg[n - 1] == '\r'))
        msg[--n] = 0;
    rd_log_msg(s->opt.log, "warning", "libmicrohttpd: %s", msg);
}

static int start_mhd(rd_server *s, const rd_listen_addr *la)
{
    const rd_server_options *opt = &s->opt;
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
    if (la->addr.ss_family == AF_INET6)
        flags |= MHD_USE_IPv6;
    /* Behind trusted proxies every connection comes from a proxy: the
     * limit counts real clients instead (access.h). */
    unsigned per_ip = rd_access_trusts_proxies(s->access) ? 0 : opt->max_per_ip;
    /* The logger first, so that the options after it log through it. */
    s->mhd = MHD_start_daemon(flags, opt->port, NULL, NULL, on_request, s, MHD_OPTION_EXTERNAL_LOGGER, mhd_log, s,
                              MHD_OPTION_SOCK_ADDR, (const struct sockaddr *)&la->addr, MHD_OPTION_THREAD_POOL_SIZE,
                              (unsigned)(opt->http_threads < 2 ? 2 : opt->http_threads), MHD_OPTION_CONNECTION_LIMIT,
                              opt->max_connections, MHD_OPTION_PER_IP_CONNECTION_LIMIT, per_ip,
                              MHD_OPTION_CONNECTION_TIMEOUT, opt->connection_timeout_s, MHD_OPTION_URI_LOG_CALLBACK,
                              on_uri, s, MHD_OPTION_NOTIFY_CONNECTION, on_connection, s, MHD_OPTION_NOTIFY_COMPLETED,
                              on_completed, s, MHD_OPTION_END);
    return s->mhd != NULL;
}

/* HOSTNAME:PORT unless --daemon-id names it: unique among daemons that
 * share a store, and the same again when this one restarts. */
static void daemon_id_of(rd_server *s)
{
    if (s->opt.daemon_id && *s->opt.daemon_id) {
        snprintf(s->daemon_id, sizeof s->daemon_id, "%s", s->opt.daemon_id);
        return;
    }
    char host[256] = "localhost";
    if (gethostname(host, sizeof host - 1) != 0)
        snprintf(host, sizeof host, "localhost");
    host[sizeof host - 1] = 0;
    host[strcspn(host, ".")] = 0; /* the short name: ids are at most 63 characters */
    snprintf(s->daemon_id, sizeof s->daemon_id, "%.48s:%u", host, (unsigned)s->port);
}

/* The job store's options, for the farm and the grade records alike. */
static rd_store_options store_options(const rd_server_options *o)
{
    rd_store_options so = rd_store_options_default();
    if (so.limits.scene_bytes < o->max_body_bytes)
        so.limits.scene_bytes = o->max_body_bytes;
    return so;
}

static const char *store_spec(const rd_server_options *o) { return o->store && *o->store ? o->store : o->data_dir; }

static const char *store_flag(const rd_server_options *o) { return o->store && *o->store ? "--store" : "--data-dir"; }

/* Once the port is known (it names the daemon): the store opened, its
 * migrations applied, the render threads claiming. */
static rd_error_code start_farm(rd_server *s, rd_error *err)
{
    const rd_server_options *o = &s->opt;
    daemon_id_of(s);
    rd_farm_options fo = {.store_spec = store_spec(o),
                          .store = store_options(o),
                          .daemon_id = s->daemon_id,
                          .workers = o->jobs.workers,
                          .lease_ms = o->lease_ms,
                          .tile = o->store_tile,
                          .job_timeout_ms = o->jobs.job_timeout_ms,
                          .result_ttl_ms = o->jobs.result_ttl_ms,
                          .queue_length = o->jobs.queue_length,
                          .limits = o->limits,
                          .scenes_dir = o->scenes_dir,
                          .png = o->jobs.png,
                          .log = o->log,
                          .jobs = s->jobs};
    rd_error why = {0};
    s->farm = rd_farm_start(&fo, &why);
    if (!s->farm)
        return rd_error_set(err, why.code, 0, 0, "the job store (%s) cannot be used: %s", store_flag(o), why.message);
    return RD_OK;
}

/* A roster that does not read stops the start, with its line and column:
 * it is read again for every table, and a typo should not wait for one. */
static int roster_ok(const char *path, rd_error *err)
{
    rd_roster r;
    if (!path)
        return 1;
    if (rd_roster_load(path, &r, err))
        return 0;
    rd_roster_free(&r);
    return 1;
}

/* After the farm, on the same store: the grading service. */
static rd_error_code start_grading(rd_server *s, rd_error *err)
{
    const rd_server_options *o = &s->opt;
    rd_grading_options go = {.jobs = s->jobs,
                             .store_spec = store_spec(o),
                             .store = store_options(o),
                             .daemon_id = s->daemon_id,
                             .workers = o->jobs.workers,
                             .assignments_dir = o->assignments_dir,
                             .roster = o->roster,
                             .scenes_dir = o->scenes_dir,
                             .cache_dir = o->cache_dir,
                             .cache_bytes = o->grade_cache_bytes,
                             .limits = o->limits,
                             .ttl_ms = o->grade_ttl_ms,
                             .log = o->log,
                             .bwrap = o->bwrap,
                             .course_dir = o->course_dir,
                             .code_eval = o->code_eval,
                             .max_code_bytes = o->max_code_bytes,
                             .code_compile_ms = o->code_compile_ms,
                             .code_run_ms = o->code_run_ms,
                             .sandbox_uid = o->sandbox_uid,
                             .max_code_jobs = o->max_code_jobs,
                             .max_code_jobs_per_client = o->max_code_jobs_per_client};
    rd_error why = {0};
    s->grading = rd_grading_start(&go, &why);
    if (!s->grading)
        return rd_error_set(err, why.code, 0, 0, "%s (%s)", why.message, store_flag(o));
    return RD_OK;
}

int rd_server_reload_tokens(rd_server *s, rd_error *err)
{
    if (!s->opt.instructor_tokens)
        return -1;
    /* A file that became unreadable or bad keeps the tokens read before:
     * a typo while revoking one token must not lock every instructor out,
     * and the caller logs why. */
    rd_auth *fresh = rd_auth_load(s->opt.instructor_tokens, err);
    if (!fresh)
        return -2;
    pthread_mutex_lock(&s->auth_mu);
    rd_auth *old = s->auth;
    s->auth = fresh;
    pthread_mutex_unlock(&s->auth_mu);
    int n = rd_auth_count(fresh);
    rd_auth_free(old);
    return n;
}

rd_server *rd_server_start(const rd_server_options *opt, rd_error *err)
{
    rd_listen_addr la;
    if (start_checks(opt, err) || rd_listen_resolve(opt->listen_host, opt->port, &la, err))
        return NULL;
    rd_server *s = calloc(1, sizeof *s);
    if (!s) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    s->opt = *opt;
    pthread_mutex_init(&s->conn_mu, NULL);
    pthread_cond_init(&s->conn_cv, NULL);
    pthread_mutex_init(&s->auth_mu, NULL);
    if ((opt->instructor_tokens && !(s->auth = rd_auth_load(opt->instructor_tokens, err))) ||
        !roster_ok(opt->roster, err)) {
        rd_auth_free(s->auth);
        free(s);
        return NULL;
    }
    s->access = rd_access_new(opt, err);
    s->jobs = s->access ? rd_jq_start(&opt->jobs, err) : NULL;
    s->metrics = s->jobs ? rd_metrics_new(rd_jq_hist_cover(opt->jobs.job_timeout_ms)) : NULL;
    if (!s->metrics || pthread_create(&s->reaper, NULL, reaper, s) != 0) {
        if (s->jobs && !s->metrics)
            rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        free_server(s);
        return NULL;
    }
    s->reaper_on = 1;
    errno = 0;
    if (!start_mhd(s, &la)) {
        /* bind's errno, before the teardown's calls replace it: "Address
         * already in use" is the usual cause, and the user's way out is
         * another port. */
        int why = errno;
        free_server(s);
        rd_error_set(err, RD_ERR_IO, 0, 0, "cannot listen on %s port %u%s%s (--listen or RAYD_LISTEN picks another)",
                     opt->listen_host, (unsigned)opt->port, why ? ": " : "", why ? strerror(why) : "");
        return NULL;
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(s->mhd, MHD_DAEMON_INFO_BIND_PORT);
    s->port = info ? info->port : opt->port;
    if (start_farm(s, err) || start_grading(s, err)) {
        MHD_stop_daemon(s->mhd);
        free_server(s);
        return NULL;
    }
    atomic_store(&s->ready, 1);
    return s;
}

uint16_t rd_server_port(const rd_server *s) { return s->port; }

const char *rd_server_daemon_id(const rd_server *s) { return s->daemon_id; }

void rd_server_stop(rd_server *s, double drain_ms)
{
    if (!s)
        return;
    atomic_store(&s->draining, 1);
    /* Running renders may finish; their clients get their images. */
    rd_jq_drain(s->jobs, drain_ms);
    /* The rest are cancelled and end within milliseconds (a job being
     * prepared, within its parse). */
    rd_jq_cancel_all(s->jobs);
    /* A request that passed its draining check before it was set may be
     * submitting still: from here it does not suspend (rd_req_wait), and
     * what it submitted before is cancelled with the rest. */
    pthread_mutex_lock(&s->conn_mu);
    s->no_more_waits = 1;
    pthread_mutex_unlock(&s->conn_mu);
    rd_jq_cancel_all(s->jobs);
    rd_jq_drain(s->jobs, CANCELLED_END_MS);
    /* Every suspended client has been resumed: let MHD send their answers. */
    for (double t0 = rd_now_ms(); atomic_load(&s->waiting) > 0 && rd_now_ms() - t0 < ANSWERS_SENT_MS;)
        usleep(10000);
    atomic_store(&s->stopped, 1);
    /* No MHD_quiesce_daemon first: with epoll and a thread pool it races
     * the pool's threads for the listening socket and aborts the process
     * (libmicrohttpd 0.9.75, "Failed to remove listen FD from epoll set").
     * MHD_stop_daemon closes that socket itself. */
    MHD_stop_daemon(s->mhd);
    /* Job references held by requests are gone; the queue can go. */
    free_server(s);
}
