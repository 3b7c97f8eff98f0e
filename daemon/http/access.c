#include "access.h"

#include <arpa/inet.h>
#include <cJSON.h>
#include <ctype.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hash.h"
#include "http_internal.h"
#include "log.h"

/* An address as 16 bytes: IPv4 as its IPv4-mapped IPv6 form. */
typedef struct {
    unsigned char b[16];
} ip16;

enum { CLIENT_SLOTS = 1024 };

typedef struct {
    char addr[64];
    unsigned open;
} client_slot;

struct rd_access {
    ip16 *proxies;
    size_t nproxies;
    unsigned max_per_client;
    uint64_t key;
    atomic_ullong next_id;
    pthread_mutex_t mu;
    client_slot *clients; /* open addressing; only with proxies */
};

static int parse_ip(const char *s, ip16 *out)
{
    struct in_addr v4;
    memset(out, 0, sizeof *out);
    if (inet_pton(AF_INET6, s, out->b) == 1)
        return 1;
    if (inet_pton(AF_INET, s, &v4) != 1)
        return 0;
    out->b[10] = out->b[11] = 0xff;
    memcpy(out->b + 12, &v4, 4);
    return 1;
}

static int trusted(const rd_access *a, const char *s)
{
    ip16 ip;
    if (!parse_ip(s, &ip))
        return 0;
    for (size_t i = 0; i < a->nproxies; i++)
        if (memcmp(&a->proxies[i], &ip, sizeof ip) == 0)
            return 1;
    return 0;
}

static rd_error_code parse_proxies(rd_access *a, const char *list, rd_error *err)
{
    size_t cap = 1;
    for (const char *p = list; *p; p++)
        cap += *p == ',';
    a->proxies = calloc(cap, sizeof *a->proxies);
    if (!a->proxies)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    for (const char *p = list; *p;) {
        size_t n = strcspn(p, ",");
        char one[64];
        snprintf(one, sizeof one, "%.*s", (int)(n < sizeof one ? n : sizeof one - 1), p);
        if (n >= sizeof one || !parse_ip(one, &a->proxies[a->nproxies]))
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "--trust-proxy: '%.*s' is not an IP address", (int)n, p);
        a->nproxies++;
        p += n + (p[n] == ',');
    }
    return RD_OK;
}

rd_access *rd_access_new(const rd_server_options *opt, rd_error *err)
{
    rd_access *a = calloc(1, sizeof *a);
    if (!a) {
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    pthread_mutex_init(&a->mu, NULL);
    a->key = rd_random_key();
    a->max_per_client = opt->max_per_ip;
    if (opt->trust_proxy && *opt->trust_proxy &&
        (parse_proxies(a, opt->trust_proxy, err) || !(a->clients = calloc(CLIENT_SLOTS, sizeof *a->clients)))) {
        if (!err->code)
            rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        rd_access_free(a);
        return NULL;
    }
    return a;
}

void rd_access_free(rd_access *a)
{
    if (!a)
        return;
    pthread_mutex_destroy(&a->mu);
    free(a->proxies);
    free(a->clients);
    free(a);
}

int rd_access_trusts_proxies(const rd_access *a) { return a && a->nproxies > 0; }

static void peer_address(struct MHD_Connection *conn, char *buf, size_t size)
{
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
    const struct sockaddr *sa = ci ? ci->client_addr : NULL;
    snprintf(buf, size, "-");
    if (sa && sa->sa_family == AF_INET)
        inet_ntop(AF_INET, &((const struct sockaddr_in *)(const void *)sa)->sin_addr, buf, (socklen_t)size);
    else if (sa && sa->sa_family == AF_INET6)
        inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)(const void *)sa)->sin6_addr, buf, (socklen_t)size);
}

/* The rightmost address of X-Forwarded-For that is not a trusted proxy
 * (proxies append the address they were called from); entries that are not
 * addresses end the walk, since whoever wrote them is not to be believed. */
static void forwarded_client(const rd_access *a, const char *xff, char *client, size_t size)
{
    size_t end = strlen(xff);
    while (end > 0) {
        size_t start = end;
        while (start > 0 && xff[start - 1] != ',')
            start--;
        char one[64];
        size_t b = start, e = end;
        while (b < e && isspace((unsigned char)xff[b]))
            b++;
        while (e > b && isspace((unsigned char)xff[e - 1]))
            e--;
        ip16 ip;
        if (e - b >= sizeof one)
            return;
        snprintf(one, sizeof one, "%.*s", (int)(e - b), xff + b);
        if (!parse_ip(one, &ip))
            return;
        snprintf(client, size, "%s", one);
        if (!trusted(a, one))
            return;
        end = start > 0 ? start - 1 : 0;
    }
}

/* A caller's id is kept when it is short and plain, so a proxy's id
 * follows the request through; otherwise one is made. */
static int plain_id(const char *s)
{
    size_t n = s ? strlen(s) : 0;
    if (n == 0 || n > 64)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (!isalnum((unsigned char)s[i]) && !strchr("-_.:", s[i]))
            return 0;
    return 1;
}

static enum MHD_Result add_arg(void *cls, enum MHD_ValueKind kind, const char *key, const char *value)
{
    (void)kind;
    rd_req *r = cls;
    size_t n = strlen(r->query);
    if (key && n + 1 < sizeof r->query)
        snprintf(r->query + n, sizeof r->query - n, "%s%s%s%s", n ? "&" : "", key, value ? "=" : "",
                 value ? value : "");
    return MHD_YES;
}

void rd_access_new_id(rd_access *a, char *buf, size_t size)
{
    snprintf(buf, size, "%016llx", (unsigned long long)rd_mix64(a->key ^ atomic_fetch_add(&a->next_id, 1)));
}

void rd_access_begin(rd_access *a, rd_req *r)
{
    const char *id = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, "X-Request-Id");
    if (plain_id(id))
        snprintf(r->request_id, sizeof r->request_id, "%s", id);
    else
        rd_access_new_id(a, r->request_id, sizeof r->request_id);
    peer_address(r->conn, r->client, sizeof r->client);
    const char *xff = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, "X-Forwarded-For");
    if (xff && a->nproxies && trusted(a, r->client))
        forwarded_client(a, xff, r->client, sizeof r->client);
    const char *ua = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_USER_AGENT);
    snprintf(r->user_agent, sizeof r->user_agent, "%s", ua ? ua : "");
    MHD_get_connection_values(r->conn, MHD_GET_ARGUMENT_KIND, add_arg, r);
}

static client_slot *slot_of(rd_access *a, const char *addr, int create)
{
    size_t h = (size_t)rd_fnv1a(RD_FNV_OFFSET, addr, strlen(addr)) % CLIENT_SLOTS;
    client_slot *free_slot = NULL;
    for (size_t k = 0; k < CLIENT_SLOTS; k++) {
        client_slot *s = &a->clients[(h + k) % CLIENT_SLOTS];
        if (s->open > 0 && strcmp(s->addr, addr) == 0)
            return s;
        if (s->open == 0 && !free_slot)
            free_slot = s;
        if (s->open == 0 && s->addr[0] == 0)
            break; /* never used: the address is not further on */
    }
    if (free_slot && create)
        snprintf(free_slot->addr, sizeof free_slot->addr, "%s", addr);
    return create ? free_slot : NULL;
}

int rd_access_admit(rd_access *a, rd_req *r)
{
    if (!a->clients)
        return 1;
    pthread_mutex_lock(&a->mu);
    client_slot *s = slot_of(a, r->client, 1);
    int ok = s && s->open < a->max_per_client;
    if (ok)
        s->open++;
    pthread_mutex_unlock(&a->mu);
    r->admitted = ok;
    return ok;
}

void rd_access_end(rd_access *a, rd_req *r)
{
    if (!a->clients || !r->admitted)
        return;
    pthread_mutex_lock(&a->mu);
    client_slot *s = slot_of(a, r->client, 0);
    if (s && s->open > 0)
        s->open--;
    pthread_mutex_unlock(&a->mu);
    r->admitted = 0;
}

static void log_json(const rd_server_options *opt, const rd_req *r, double ms, int aborted)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "method", r->method);
    cJSON_AddStringToObject(o, "path", r->path);
    cJSON_AddStringToObject(o, "query", r->query);
    cJSON_AddNumberToObject(o, "status", r->status);
    cJSON_AddNumberToObject(o, "bytes", (double)r->bytes);
    cJSON_AddNumberToObject(o, "ms", ms);
    cJSON_AddStringToObject(o, "client", r->client);
    cJSON_AddStringToObject(o, "user_agent", r->user_agent);
    cJSON_AddStringToObject(o, "request_id", r->request_id);
    if (r->job_id[0])
        cJSON_AddStringToObject(o, "job", r->job_id);
    if (aborted)
        cJSON_AddBoolToObject(o, "aborted", 1);
    rd_log_event(opt->log, "info", "request", o);
}

/* Bytes a text line must not carry as they are (spaces split fields). */
static void clean(char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20 || *s == 0x7f || *s == '"')
            *s = '?';
}

void rd_access_log(const rd_server_options *opt, const rd_req *r, double ms, int aborted)
{
    if (rd_log_is_json(opt->log)) {
        log_json(opt, r, ms, aborted);
        return;
    }
    char when[40], ua[sizeof r->user_agent], target[sizeof r->path + sizeof r->query + 2], line[2048];
    rd_log_time(when, sizeof when);
    snprintf(ua, sizeof ua, "%s", r->user_agent);
    snprintf(target, sizeof target, "%s%s%s", r->path, r->query[0] ? "?" : "", r->query);
    clean(ua);
    for (char *p = target; *p; p++)
        if ((unsigned char)*p <= 0x20 || *p == 0x7f)
            *p = '?';
    snprintf(line, sizeof line, "%s %s %s %s %u %zu %.1fms id=%s%s%s \"%s\"%s", when, r->client, r->method, target,
             r->status, r->bytes, ms, r->request_id, r->job_id[0] ? " job=" : "", r->job_id, ua,
             aborted ? " (connection closed early)" : "");
    rd_log_line(opt->log, line);
}
