/* Who is asking: each request's id (echoed as X-Request-Id), its client
 * (the socket's peer, or with --trust-proxy the address a trusted proxy
 * names in X-Forwarded-For), the per-client request limit that then
 * replaces libmicrohttpd's per-socket one, and the access log line.
 * Not a public interface: the server's own files use it. */
#ifndef RD_ACCESS_H
#define RD_ACCESS_H

#include <stddef.h>

#include "rayd/error.h"
#include "server.h"

struct rd_req;
typedef struct rd_access rd_access;

/* NULL with *err set when --trust-proxy holds something that is not an
 * address. Freed by rd_access_free. */
rd_access *rd_access_new(const rd_server_options *opt, rd_error *err);
void rd_access_free(rd_access *a);

/* 1 when the proxy addresses are trusted (MHD's per-IP limit is then off). */
int rd_access_trusts_proxies(const rd_access *a);

/* A new request id (16 hex digits) into buf (>= 17 bytes). */
void rd_access_new_id(rd_access *a, char *buf, size_t size);

/* At a request's first call: its id, client, user agent and query. */
void rd_access_begin(rd_access *a, struct rd_req *r);

/* With --trust-proxy, counts r against --max-per-ip for its client; 0 when
 * that client already has as many requests open (r is then answered 429).
 * Always 1 otherwise. Every admitted request is released by rd_access_end. */
int rd_access_admit(rd_access *a, struct rd_req *r);
void rd_access_end(rd_access *a, struct rd_req *r);

/* The access log line of a finished request. */
void rd_access_log(const rd_server_options *opt, const struct rd_req *r, double ms, int aborted);

#endif
