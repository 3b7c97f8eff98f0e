/* The daemon in-process, for the fuzz targets that drive it over HTTP
 * (fuzz_form.c, fuzz_query.c): the real rd_server_start with its real
 * routes, libmicrohttpd and job queue, on a free port of 127.0.0.1, and a
 * minimal HTTP/1.1 client that sends one request per input.
 *
 * Failures, each reported on stderr and then abort()ed so that libFuzzer
 * saves the input: no answer within RD_FUZZ_ANSWER_MS (a hang), or an
 * answer of 500 or more other than 503 (bad input never gets a 500; 503
 * means "full, or stopping", which is allowed). A connection closed
 * without any answer is counted, not failed: libmicrohttpd 0.9.75 cannot
 * send an answer decided while the body is still arriving
 * (docs/http-api.md), so the daemon closes instead. With
 * RD_FUZZ_STRICT_CLOSE=1 in the environment it fails too.
 *
 * The daemon logs a line per request to stderr; those lines are dropped
 * (stderr is pointed at /dev/null once the server is up) unless
 * RD_FUZZ_LOG=1. libFuzzer and the sanitizers keep writing to the real
 * stderr: libFuzzer holds its own copy of the stream, the sanitizers write
 * to file descriptor 2. */
#ifndef RD_FUZZ_HTTP_H
#define RD_FUZZ_HTTP_H

#include <stddef.h>
#include <stdint.h>

#include "server.h"

#define RD_FUZZ_ANSWER_MS 8000

/* Starts the server (once per process) on 127.0.0.1 and a free port,
 * whatever o says, and aborts when it cannot. */
/* rayd serve's defaults (scenes/ and scenes/assignments/ from the
 * repository root) made cheap for fuzzing: one render thread, a 4 s job
 * timeout, 16 MiB of results, 4 samples, depth 8. */
rd_server_options rd_fuzz_server_options(void);

void rd_fuzz_server_start(const rd_server_options *o);

/* One request on a new connection: method and target ("/v1/grade"), a
 * Content-Type and the body. Returns the status of the answer, or 0 when
 * the connection closed without one; aborts on the failures above. */
int rd_fuzz_request(const char *method, const char *target, const char *content_type, const uint8_t *body, size_t len);

/* Formats a failure on the real stderr and aborts. */
void rd_fuzz_http_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

#endif
