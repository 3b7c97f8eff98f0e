/* bare_mhd.c: the HTTP ceiling of this machine, for the benchmark's http section.
 *
 * A libmicrohttpd server started with the same flags as `rayd serve`
 * (daemon/http/http_server.c: internal polling thread, epoll, a thread pool of 2,
 * suspend/resume allowed) that answers every request, whatever its method and
 * path, 200 with one fixed PNG read at start-up. A request body is read and
 * thrown away. No parsing, no queue, no rendering: what is left is the cost of
 * libmicrohttpd and the kernel's loopback for the same request and answer
 * sizes, the most any service on this machine can do with them.
 *
 * usage: bare_mhd IMAGE.png PORT-FILE [THREADS]
 *   listens on 127.0.0.1 on a port the kernel picks, writes the port to
 *   PORT-FILE once ready, and runs until SIGTERM or SIGINT (exit 0).
 *
 * Build: cc -O2 bench/bare_mhd.c $(pkg-config --cflags --libs libmicrohttpd) -o bare_mhd
 */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <errno.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#if MHD_VERSION < 0x00097002
typedef int MHD_Result_t;
#else
typedef enum MHD_Result MHD_Result_t;
#endif

static struct MHD_Response *png_response;

static MHD_Result_t on_request(void *cls, struct MHD_Connection *conn, const char *url, const char *method,
                               const char *version, const char *upload_data, size_t *upload_size, void **con_cls)
{
    (void)cls, (void)url, (void)method, (void)version, (void)upload_data;
    static int first_call_marker;
    if (*con_cls == NULL) {
        /* The first call only has the headers; answer after the body. */
        *con_cls = &first_call_marker;
        return MHD_YES;
    }
    if (*upload_size != 0) {
        *upload_size = 0; /* the body is read and dropped */
        return MHD_YES;
    }
    return MHD_queue_response(conn, MHD_HTTP_OK, png_response);
}

int main(int argc, char **argv)
{
    if (argc < 3 || argc > 4) {
        fprintf(stderr, "usage: bare_mhd IMAGE.png PORT-FILE [THREADS]\n");
        return 2;
    }
    unsigned threads = argc == 4 ? (unsigned)atoi(argv[3]) : 2;
    if (threads < 1)
        threads = 1;
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        fprintf(stderr, "bare_mhd: %s: %s\n", argv[1], strerror(errno));
        return 3;
    }
    size_t cap = 1 << 16, len = 0;
    char *png = malloc(cap);
    for (;;) {
        if (!png) {
            fprintf(stderr, "bare_mhd: out of memory\n");
            return 3;
        }
        len += fread(png + len, 1, cap - len, f);
        if (len < cap)
            break;
        cap *= 2;
        png = realloc(png, cap);
    }
    fclose(f);
    png_response = MHD_create_response_from_buffer(len, png, MHD_RESPMEM_PERSISTENT);
    if (!png_response || MHD_add_response_header(png_response, "Content-Type", "image/png") != MHD_YES) {
        fprintf(stderr, "bare_mhd: cannot make the response\n");
        return 3;
    }

    /* SIGTERM and SIGINT are blocked before libmicrohttpd starts its threads,
     * which inherit the mask, so only sigwait() below receives them. */
    sigset_t stop_set;
    sigemptyset(&stop_set);
    sigaddset(&stop_set, SIGTERM);
    sigaddset(&stop_set, SIGINT);
    pthread_sigmask(SIG_BLOCK, &stop_set, NULL);
    signal(SIGPIPE, SIG_IGN);

    struct sockaddr_in addr;
    memset(&addr, 0, sizeof addr);
    addr.sin_family = AF_INET;
    addr.sin_port = 0;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    /* The flags of rayd's daemon/http/http_server.c. */
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
    struct MHD_Daemon *d =
        MHD_start_daemon(flags, 0, NULL, NULL, on_request, NULL, MHD_OPTION_SOCK_ADDR, (const struct sockaddr *)&addr,
                         MHD_OPTION_THREAD_POOL_SIZE, threads, MHD_OPTION_CONNECTION_LIMIT, 1024U,
                         MHD_OPTION_CONNECTION_TIMEOUT, 30U, MHD_OPTION_END);
    if (!d) {
        fprintf(stderr, "bare_mhd: cannot listen on 127.0.0.1\n");
        return 3;
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT);
    if (!info || info->port == 0) {
        fprintf(stderr, "bare_mhd: no port\n");
        MHD_stop_daemon(d);
        return 3;
    }
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", argv[2]);
    f = fopen(tmp, "w");
    if (!f || fprintf(f, "%u\n", (unsigned)info->port) < 0 || fclose(f) != 0 || rename(tmp, argv[2]) != 0) {
        fprintf(stderr, "bare_mhd: cannot write %s\n", argv[2]);
        MHD_stop_daemon(d);
        return 3;
    }
    fprintf(stderr, "bare_mhd: %zu-byte PNG on 127.0.0.1:%u, %u threads\n", len, (unsigned)info->port, threads);
    int sig = 0;
    while (sigwait(&stop_set, &sig) != 0)
        ;
    MHD_stop_daemon(d);
    MHD_destroy_response(png_response);
    free(png);
    return 0;
}
