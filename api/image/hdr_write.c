#include "hdr_write.h"

#include <openexr.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The file as OpenEXRCore writes it: at offsets, since it comes back to
 * fill the chunk offset table once the chunks are written. */
typedef struct {
    unsigned char *data;
    size_t len, cap;
    char message[200]; /* the library's last complaint */
} membuf;

static int64_t mem_write(exr_const_context_t ctxt, void *user, const void *buf, uint64_t sz, uint64_t offset,
                         exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt, (void)error_cb;
    membuf *m = user;
    if (offset > SIZE_MAX / 2 || sz > SIZE_MAX / 2)
        return -1;
    size_t end = (size_t)offset + (size_t)sz;
    if (end > m->cap) {
        size_t nc = m->cap ? m->cap : 65536;
        while (nc < end)
            nc *= 2;
        unsigned char *p = realloc(m->data, nc);
        if (!p)
            return -1;
        m->data = p;
        m->cap = nc;
    }
    if (offset > m->len)
        memset(m->data + m->len, 0, (size_t)offset - m->len);
    memcpy(m->data + offset, buf, (size_t)sz);
    if (end > m->len)
        m->len = end;
    return (int64_t)sz;
}

/* Keeps the message instead of printing it: errors are values here. */
static void on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *user = NULL;
    (void)code;
    if (exr_get_user_data(ctxt, &user) == EXR_ERR_SUCCESS && user)
        snprintf(((membuf *)user)->message, sizeof((membuf *)user)->message, "%s", msg);
}

/* The header: one scanline part of R, G, B floats, ZIP. */
static exr_result_t define_part(exr_context_t ctx, int w, int h)
{
    int part;
    exr_result_t r = exr_add_part(ctx, "rgb", EXR_STORAGE_SCANLINE, &part);
    if (r == EXR_ERR_SUCCESS)
        r = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP);
    static const char *const names[] = {"R", "G", "B"};
    for (int c = 0; c < 3 && r == EXR_ERR_SUCCESS; c++)
        r = exr_add_channel(ctx, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    return r == EXR_ERR_SUCCESS ? exr_write_header(ctx) : r;
}

/* Points the pipeline's channels (in the library's order) at rows, RGB
 * floats of the chunk's lines. */
static void point_channels(exr_encode_pipeline_t *enc, const float *rows, int w)
{
    for (int c = 0; c < enc->channel_count; c++) {
        exr_coding_channel_info_t *ch = &enc->channels[c];
        int off = ch->channel_name[0] == 'R' ? 0 : ch->channel_name[0] == 'G' ? 1 : 2;
        ch->encode_from_ptr = (const uint8_t *)(rows + off);
        ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
        ch->user_line_stride = 3 * (int32_t)sizeof(float) * w;
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
    }
}

/* Every chunk of lines, each converted to floats and encoded. */
static exr_result_t write_chunks(exr_context_t ctx, const rd_image *img, float *rows, int lines)
{
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    exr_result_t r = EXR_ERR_SUCCESS;
    size_t row = (size_t)img->width * 3;
    for (int y = 0; y < img->height && r == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t ci;
        r = exr_write_scanline_chunk_info(ctx, 0, y, &ci);
        if (r == EXR_ERR_SUCCESS)
            r = y == 0 ? exr_encoding_initialize(ctx, 0, &ci, &enc) : exr_encoding_update(ctx, 0, &ci, &enc);
        if (r != EXR_ERR_SUCCESS)
            break;
        const double *src = img->rgb + (size_t)y * row;
        for (size_t i = 0; i < (size_t)ci.height * row; i++)
            rows[i] = (float)src[i];
        point_channels(&enc, rows, img->width);
        if (y == 0)
            r = exr_encoding_choose_default_routines(ctx, 0, &enc);
        if (r == EXR_ERR_SUCCESS)
            r = exr_encoding_run(ctx, 0, &enc);
    }
    exr_result_t d = exr_encoding_destroy(ctx, &enc);
    return r != EXR_ERR_SUCCESS ? r : d;
}

static rd_error_code exr_failed(membuf *m, exr_result_t r, rd_error *err)
{
    free(m->data);
    if (r == EXR_ERR_OUT_OF_MEMORY)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory encoding the EXR");
    return rd_error_set(err, RD_ERR_IO, 0, 0, "EXR encoding failed: %s",
                        m->message[0] ? m->message : exr_get_default_error_message(r));
}

rd_error_code rd_exr_encode(const rd_image *img, unsigned char **out, size_t *len, rd_error *err)
{
    *out = NULL;
    *len = 0;
    if (!img->rgb || img->width < 1 || img->height < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "no image to encode");
    membuf m = {0};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &m;
    init.write_fn = mem_write;
    init.error_handler_fn = on_error;
    exr_context_t ctx = NULL;
    exr_result_t r = exr_start_write(&ctx, "<memory>", EXR_WRITE_FILE_DIRECTLY, &init);
    if (r != EXR_ERR_SUCCESS)
        return exr_failed(&m, r, err);
    r = define_part(ctx, img->width, img->height);
    int32_t lines = 0;
    if (r == EXR_ERR_SUCCESS)
        r = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    float *rows = r == EXR_ERR_SUCCESS ? malloc((size_t)img->width * 3 * sizeof *rows * (size_t)lines) : NULL;
    if (r == EXR_ERR_SUCCESS && !rows)
        r = EXR_ERR_OUT_OF_MEMORY;
    if (r == EXR_ERR_SUCCESS)
        r = write_chunks(ctx, img, rows, lines);
    free(rows);
    /* Finishing writes the offset table: the file is whole only after it. */
    exr_result_t f = exr_finish(&ctx);
    if (r != EXR_ERR_SUCCESS || f != EXR_ERR_SUCCESS)
        return exr_failed(&m, r != EXR_ERR_SUCCESS ? r : f, err);
    *out = m.data;
    *len = m.len;
    return RD_OK;
}

rd_error_code rd_pfm_encode(const rd_image *img, unsigned char **out, size_t *len, rd_error *err)
{
    *out = NULL;
    *len = 0;
    if (!img->rgb || img->width < 1 || img->height < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "no image to encode");
    char head[64];
    int hl = snprintf(head, sizeof head, "PF\n%d %d\n-1\n", img->width, img->height);
    size_t row = (size_t)img->width * 3, n = (size_t)hl + row * (size_t)img->height * 4;
    unsigned char *p = malloc(n);
    if (!p)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory encoding the PFM");
    memcpy(p, head, (size_t)hl);
    unsigned char *q = p + hl;
    for (int y = img->height - 1; y >= 0; y--)
        for (size_t i = 0; i < row; i++) {
            float f = (float)img->rgb[(size_t)y * row + i];
            uint32_t u;
            memcpy(&u, &f, sizeof u);
            for (int b = 0; b < 4; b++)
                *q++ = (unsigned char)(u >> (8 * b));
        }
    *out = p;
    *len = n;
    return RD_OK;
}
