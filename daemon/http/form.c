/* Pieces of a multipart form as libmicrohttpd's post processor hands them
 * over: shared by the routes that read forms. */
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "http_internal.h"

int rd_form_append(unsigned char **buf, size_t *len, const char *data, size_t size)
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

int rd_form_text(char *dst, size_t cap, const char *data, size_t size)
{
    size_t have = strlen(dst);
    if (have + size >= cap)
        return 0;
    memcpy(dst + have, data, size);
    dst[have + size] = 0;
    return 1;
}

enum MHD_Result rd_form_begin(rd_req *r, const rd_form_spec *spec)
{
    const char *cl = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (cl && strtoull(cl, NULL, 10) > spec->max_total)
        return rd_reply_too_large(r, spec->too_large);
    const char *ct = MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (!ct || strncasecmp(ct, "multipart/form-data", 19) != 0)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, spec->hint);
    void *state = calloc(1, spec->size);
    if (!state)
        return MHD_NO;
    r->state = state;
    r->free_state = spec->free_state;
    rd_form *f = state; /* every form struct starts with its rd_form */
    f->post = MHD_create_post_processor(r->conn, 64 * 1024, spec->on_field, r);
    if (!f->post)
        return rd_reply_error(r, 415, "unsupported_media_type", NULL, "the form could not be read");
    return MHD_YES;
}

enum MHD_Result rd_form_data(rd_req *r, const char *data, size_t size, size_t discard_max)
{
    rd_form *f = r->state;
    if (!f || !f->post)
        return MHD_YES;
    if (f->bad || f->too_big) {
        r->discarded += size;
        return r->discarded > discard_max ? MHD_NO : MHD_YES;
    }
    if (MHD_post_process(f->post, data, size) != MHD_YES && !f->bad && !f->too_big)
        f->bad = "the form data is malformed";
    return MHD_YES;
}

void rd_form_end(rd_form *f)
{
    if (f->post)
        MHD_destroy_post_processor(f->post);
    f->post = NULL;
}
