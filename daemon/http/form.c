/* Multipart forms as libmicrohttpd's post processor hands them over, read
 * by each route's table of fields (rd_form_field), so that every form
 * refuses the same faults in the same words. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "http_internal.h"

/* Appends size bytes to *buf, kept NUL-terminated; 0 when out of memory. */
static int append(unsigned char **buf, size_t *len, const char *data, size_t size)
{
    unsigned char *p = realloc(*buf, *len + size + 1);
    if (!p)
        return 0;
    memcpy(p + *len, data, size);
    *len += size;
    p[*len] = 0;
    *buf = p;
    return 1;
}

/* Appends to dst (NUL-terminated, cap bytes); 0 when it would not fit. */
static int append_text(char *dst, size_t cap, const char *data, size_t size)
{
    size_t have = strlen(dst);
    if (have + size >= cap)
        return 0;
    memcpy(dst + have, data, size);
    dst[have + size] = 0;
    return 1;
}

enum MHD_Result rd_form_refuse(rd_form *f, unsigned status, const char *fmt, ...)
{
    if (f->refused)
        return MHD_NO;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(f->why, sizeof f->why, fmt, ap);
    va_end(ap);
    f->refused = status;
    return MHD_NO;
}

enum MHD_Result rd_form_take(rd_form *f, const char *name, unsigned char **buf, size_t *len, size_t limit,
                             const char *flag, const char *data, size_t size)
{
    if (*len + size > limit)
        return rd_form_refuse(f, 413, "the '%s' part is over the limit of %zu bytes (%s)", name, limit, flag);
    if (f->files_max && (f->file_bytes += size) > f->files_max)
        return rd_form_refuse(f, 413, "the form's files are over the limit of %zu bytes (%s)", f->files_max,
                              f->files_flag);
    if (!append(buf, len, data, size))
        return rd_form_refuse(f, 503, "out of memory");
    return MHD_YES;
}

/* libmicrohttpd may start a part with an empty call at offset 0 and then
 * give its first bytes at offset 0 again (a part that begins at the end of
 * a buffer): 1 when this call begins a part, not when it goes on the one
 * such an empty call began. */
static int part_starts(rd_form *f, const char *key, const char *filename, uint64_t off, size_t size)
{
    const char *name = filename ? filename : "";
    int again = off == 0 && size > 0 && f->empty_start && strcmp(f->empty_key, key) == 0 &&
                strncmp(f->empty_name, name, sizeof f->empty_name - 1) == 0;
    f->empty_start = off == 0 && size == 0;
    if (f->empty_start) {
        snprintf(f->empty_key, sizeof f->empty_key, "%s", key);
        snprintf(f->empty_name, sizeof f->empty_name, "%s", name);
    }
    return off == 0 && !again;
}

static size_t flag_value(const rd_req *r, const rd_form_field *fd)
{
    return *(const size_t *)((const char *)&r->srv->opt + fd->cap);
}

/* A field's name in answers: the first of the names that fill its place
 * ("code" is also "source"). */
static const char *said_name(const rd_form *f, const rd_form_field *fd)
{
    for (const rd_form_field *o = f->fields; o != fd; o++)
        if (o->offset == fd->offset && o->kind == fd->kind)
            return o->name;
    return fd->name;
}

static enum MHD_Result file_part(rd_req *r, rd_form *f, const rd_form_field *fd, rd_form_blob *b, const char *filename,
                                 int starts, const char *data, size_t size)
{
    const char *name = said_name(f, fd);
    if (starts && fd->kind == RD_FORM_FILE && b->parts)
        return rd_form_refuse(f, 400, "the form has more than one '%s' file", name);
    if (starts && fd->kind == RD_FORM_FILE && filename &&
        !append_text(b->filename, sizeof b->filename, filename, strlen(filename)))
        return rd_form_refuse(f, 400, "the '%s' file's name is longer than a file name can be", name);
    b->parts += starts;
    return rd_form_take(f, name, &b->data, &b->len, flag_value(r, fd), fd->too_long, data, size);
}

static const rd_form_field *field_named(const rd_form_field *fields, const char *key)
{
    for (const rd_form_field *fd = fields; fd->name; fd++)
        if (strcmp(fd->name, key) == 0)
            return fd;
    return NULL;
}

/* The post processor's iterator for every form: the part goes where its
 * row says; parts no row names are ignored. */
static enum MHD_Result on_field(void *cls, enum MHD_ValueKind kind, const char *key, const char *filename,
                                const char *content_type, const char *encoding, const char *data, uint64_t off,
                                size_t size)
{
    (void)kind, (void)content_type, (void)encoding;
    rd_req *r = cls;
    rd_form *f = r->state;
    /* A part without a Content-Disposition name (or with an unquoted one)
     * comes with no key at all. */
    if (!key)
        return rd_form_refuse(f, 400, "a form part has no field name (Content-Disposition: form-data; name=\"...\")");
    if (size && !data)
        return MHD_YES;
    int starts = part_starts(f, key, filename, off, size);
    const rd_form_field *fd = field_named(f->fields, key);
    if (!fd)
        return MHD_YES;
    char *at = (char *)f + fd->offset; /* the route's form struct starts with f */
    if (fd->kind == RD_FORM_TEXT)
        return append_text(at, fd->cap, data, size) ? MHD_YES : rd_form_refuse(f, 400, "%s", fd->too_long);
    if (fd->kind == RD_FORM_EACH)
        return fd->part(r, f, filename, starts, data, size);
    return file_part(r, f, fd, (rd_form_blob *)at, filename, starts, data, size);
}

enum MHD_Result rd_form_begin(rd_req *r, const rd_form_spec *spec)
{
    const char *cl = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    unsigned long long n = cl ? strtoull(cl, NULL, 10) : 0;
    if (n > spec->max_total) {
        char msg[240];
        snprintf(msg, sizeof msg, "the form's %llu bytes are over the limit of %zu bytes (%s)", n, spec->max_total,
                 spec->too_large);
        rd_req_linger(r);
        return rd_reply_error(r, 413, "too_large", NULL, msg);
    }
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (!ct || strncasecmp(ct, "multipart/form-data", 19) != 0)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, spec->hint);
    rd_form *f = calloc(1, spec->size); /* every form struct starts with its rd_form */
    if (!f)
        return MHD_NO;
    r->state = f;
    r->free_state = spec->free_state;
    f->fields = spec->fields;
    f->files_max = spec->files_max;
    f->files_flag = spec->files_flag;
    f->post = MHD_create_post_processor(r->conn, 64 * 1024, on_field, r);
    if (!f->post)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, "the form could not be read");
    return MHD_YES;
}

enum MHD_Result rd_form_data(rd_req *r, const char *data, size_t size, size_t discard_max)
{
    rd_form *f = r->state;
    if (!f || !f->post)
        return MHD_YES;
    if (f->refused) {
        r->discarded += size;
        return r->discarded > discard_max ? MHD_NO : MHD_YES;
    }
    if (MHD_post_process(f->post, data, size) != MHD_YES)
        rd_form_refuse(f, 400, "the form data is malformed");
    return MHD_YES;
}

int rd_form_refused(rd_req *r, enum MHD_Result *ret)
{
    const rd_form *f = r->state;
    if (f && !f->refused)
        return 0;
    const char *code = !f || f->refused == 400 ? "parse_error" : f->refused == 413 ? "too_large" : "unavailable";
    *ret = rd_reply_error(r, f ? f->refused : 400, code, NULL, f ? f->why : "no form");
    return 1;
}

void rd_form_blob_free(rd_form_blob *b)
{
    free(b->data);
    memset(b, 0, sizeof *b);
}

void rd_form_end(rd_form *f)
{
    if (f->post)
        MHD_destroy_post_processor(f->post);
    f->post = NULL;
}
