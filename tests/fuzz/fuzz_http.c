#include "fuzz_http.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "rayd/clock.h"

static rd_server *server;
static uint16_t port;
static FILE *report; /* the real stderr */

/* Answers by kind, printed at exit: what the inputs reached. */
static unsigned long answers[6], closed, requests;

void rd_fuzz_http_fail(const char *fmt, ...)
{
    FILE *f = report ? report : stderr;
    va_list ap;
    va_start(ap, fmt);
    fputs("fuzz property failed: ", f);
    vfprintf(f, fmt, ap);
    fputc('\n', f);
    va_end(ap);
    fflush(f);
    abort();
}

/* Before LeakSanitizer's check at exit (registered earlier, so run
 * later): what the server still holds is freed by its own stop, and
 * whatever is left is a leak. The pause lets it finish with the
 * connections the last inputs reset, so that the check is about leaks, not
 * about stopping mid-request. */
static void stop_server(void)
{
    if (!server)
        return;
    struct timespec pause = {0, 200 * 1000000L};
    nanosleep(&pause, NULL);
    rd_server_stop(server, 0);
    server = NULL;
}

static void print_answers(void)
{
    fprintf(report,
            "fuzz http: %lu requests: %lu 2xx, %lu 3xx, %lu 4xx, %lu 5xx (503 only); %lu closed without an answer\n",
            requests, answers[2], answers[3], answers[4], answers[5], closed);
}

rd_server_options rd_fuzz_server_options(void)
{
    rd_server_options o = rd_server_options_default();
    o.jobs.workers = 1;
    o.jobs.job_timeout_ms = 4000;
    o.jobs.result_memory = 16u << 20;
    o.limits.max_samples = 4;
    o.limits.max_depth = 8;
    return o;
}

void rd_fuzz_server_start(const rd_server_options *o)
{
    if (server)
        return;
    report = stderr;
    rd_server_options local = *o;
    local.listen_host = "127.0.0.1";
    local.port = 0;
    rd_error err;
    memset(&err, 0, sizeof err);
    server = rd_server_start(&local, &err);
    if (!server)
        rd_fuzz_http_fail("rd_server_start: %s (run from the repository root)", err.message);
    port = rd_server_port(server);
    const char *log = getenv("RD_FUZZ_LOG");
    if (!log || strcmp(log, "1") != 0) {
        FILE *null = fopen("/dev/null", "w");
        if (null)
            stderr = null;
    }
    atexit(print_answers);
    atexit(stop_server);
}

/* Waits for `events` until the deadline; 0 when it passed. */
static int wait_for(int fd, short events, double deadline)
{
    for (;;) {
        double left = deadline - rd_now_ms();
        if (left <= 0)
            return 0;
        struct pollfd p = {fd, events, 0};
        int k = poll(&p, 1, (int)left + 1);
        if (k > 0)
            return 1;
        if (k < 0 && errno != EINTR)
            rd_fuzz_http_fail("poll: %s", strerror(errno));
    }
}

/* Sends everything it can; 0 once the server stopped reading (it answered
 * or closed early: the answer, if any, is read next). */
static int send_all(int fd, const char *p, size_t n, double deadline)
{
    while (n) {
        if (!wait_for(fd, POLLOUT, deadline))
            return 0;
        ssize_t k = send(fd, p, n, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (k < 0 && (errno == EINTR || errno == EAGAIN))
            continue;
        if (k <= 0)
            return 0;
        p += k;
        n -= (size_t)k;
    }
    return 1;
}

/* The value of a header in head (NUL-terminated, lines ending CRLF), or NULL. */
static const char *header(const char *head, const char *name)
{
    size_t n = strlen(name);
    for (const char *l = strstr(head, "\r\n"); l; l = strstr(l, "\r\n")) {
        l += 2;
        if (strncasecmp(l, name, n) == 0 && l[n] == ':') {
            l += n + 1;
            while (*l == ' ' || *l == '\t')
                l++;
            return l;
        }
    }
    return NULL;
}

int rd_fuzz_request(const char *method, const char *target, const char *content_type, const uint8_t *body, size_t len)
{
    double start = rd_now_ms(), deadline = start + RD_FUZZ_ANSWER_MS;
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
        rd_fuzz_http_fail("socket: %s", strerror(errno));
    /* Closing with a reset leaves no TIME_WAIT on either side: millions of
     * connections would otherwise use up the ports of 127.0.0.1. */
    struct linger lg = {1, 0};
    setsockopt(fd, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        /* Interrupted (libFuzzer's timers send signals), the connection
         * still completes in the background. */
        int e = errno, soerr = 0;
        socklen_t sl = sizeof soerr;
        if (e != EINTR || !wait_for(fd, POLLOUT, deadline) || getsockopt(fd, SOL_SOCKET, SO_ERROR, &soerr, &sl) != 0 ||
            soerr != 0)
            rd_fuzz_http_fail("connect to 127.0.0.1:%u: %s", (unsigned)port, strerror(soerr ? soerr : e));
    }
    size_t tlen = strlen(target);
    size_t cap = tlen + strlen(method) + strlen(content_type) + 200;
    char *head = malloc(cap);
    if (!head)
        rd_fuzz_http_fail("out of memory");
    int hn = snprintf(head, cap, "%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: %s\r\nContent-Length: %zu\r\n\r\n",
                      method, target, content_type, len);
    requests++;
    if (send_all(fd, head, (size_t)hn, deadline))
        send_all(fd, (const char *)body, len, deadline);
    free(head);

    /* The answer: status line and headers, then Content-Length bytes (the
     * daemon always sends one), or up to the close. Interim answers (102
     * while a render runs) are skipped. */
    char buf[16384];
    size_t have = 0, need = 0;
    long long body_seen = 0;
    int status = -1;
    for (;;) {
        if (!wait_for(fd, POLLIN, deadline))
            rd_fuzz_http_fail("%s %.200s%s: no answer within %d ms (%zu bytes of it so far)", method, target,
                              tlen > 200 ? "..." : "", RD_FUZZ_ANSWER_MS, have);
        char *into = status < 0 ? buf + have : buf;
        size_t room = status < 0 ? sizeof buf - 1 - have : sizeof buf;
        ssize_t k = recv(fd, into, room, 0);
        if (k < 0 && (errno == EINTR || errno == EAGAIN))
            continue;
        if (k <= 0)
            break; /* closed (or reset) */
        if (status >= 0) {
            body_seen += k;
        } else {
            have += (size_t)k;
            buf[have] = 0;
        }
        char *end;
        while (status < 0 && (end = strstr(buf, "\r\n\r\n"))) {
            *end = 0;
            if (strncmp(buf, "HTTP/1.", 7) != 0 || sscanf(buf + 8, " %d", &status) != 1 || status < 100 || status > 599)
                rd_fuzz_http_fail("not an HTTP answer: '%.80s'", buf);
            size_t rest = have - (size_t)(end + 4 - buf);
            if (status < 200) {
                memmove(buf, end + 4, rest + 1);
                have = rest;
                status = -1;
                continue;
            }
            const char *cl = header(buf, "Content-Length");
            need = cl ? (size_t)strtoull(cl, NULL, 10) : (size_t)-1;
            body_seen = (long long)rest;
        }
        if (status < 0 && have == sizeof buf - 1)
            rd_fuzz_http_fail("answer headers longer than %zu bytes", sizeof buf);
        if (status >= 0 && need != (size_t)-1 && (size_t)body_seen >= need)
            break;
    }
    close(fd);
    if (status < 0) {
        closed++;
        const char *strict = getenv("RD_FUZZ_STRICT_CLOSE");
        if (strict && strcmp(strict, "1") == 0)
            rd_fuzz_http_fail("%s %.200s: connection closed without an answer", method, target);
        return 0;
    }
    answers[status / 100]++;
    if (status >= 500 && status != 503)
        rd_fuzz_http_fail("%s %.200s: answered %d", method, target, status);
    return status;
}
