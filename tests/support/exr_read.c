#include "exr_read.h"

#include <openexr.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const unsigned char *data;
    size_t len;
} source;

static int64_t mem_read(exr_const_context_t ctxt, void *user, void *buf, uint64_t sz, uint64_t offset,
                        exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt, (void)error_cb;
    const source *s = user;
    if (offset >= s->len)
        return 0;
    size_t n = s->len - (size_t)offset < sz ? s->len - (size_t)offset : (size_t)sz;
    memcpy(buf, s->data + offset, n);
    return (int64_t)n;
}

static int64_t mem_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    return (int64_t)((const source *)user)->len;
}

static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg) { (void)ctxt, (void)code, (void)msg; }

static exr_result_t open_mem(exr_context_t *ctx, source *s)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = s;
    init.read_fn = mem_read;
    init.size_fn = mem_size;
    init.error_handler_fn = quiet;
    return exr_start_read(ctx, "<memory>", &init);
}

int exr_read_layout(const unsigned char *data, size_t len, char names[8], int *compression)
{
    source s = {data, len};
    exr_context_t ctx = NULL;
    if (open_mem(&ctx, &s) != EXR_ERR_SUCCESS)
        return -1;
    const exr_attr_chlist_t *ch = NULL;
    exr_compression_t c;
    int ok = exr_get_channels(ctx, 0, &ch) == EXR_ERR_SUCCESS && ch->num_channels < 8 &&
             exr_get_compression(ctx, 0, &c) == EXR_ERR_SUCCESS;
    for (int i = 0; ok && i < ch->num_channels; i++)
        names[i] = ch->entries[i].name.str[0];
    if (ok) {
        names[ch->num_channels] = 0;
        *compression = (int)c;
    }
    exr_finish(&ctx);
    return ok ? 0 : -1;
}

/* Decodes each chunk of lines into out (RGB floats, w per row). */
static exr_result_t decode_all(exr_context_t ctx, int w, int h, float *out)
{
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int32_t lines = 0;
    exr_result_t r = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    for (int y = 0; y < h && r == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t ci;
        r = exr_read_scanline_chunk_info(ctx, 0, y, &ci);
        if (r == EXR_ERR_SUCCESS)
            r = y == 0 ? exr_decoding_initialize(ctx, 0, &ci, &dec) : exr_decoding_update(ctx, 0, &ci, &dec);
        for (int c = 0; r == EXR_ERR_SUCCESS && c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int off = ch->channel_name[0] == 'R' ? 0 : ch->channel_name[0] == 'G' ? 1 : 2;
            ch->decode_to_ptr = (uint8_t *)(out + (size_t)y * (size_t)w * 3 + off);
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = 3 * (int32_t)sizeof(float) * w;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
        }
        if (r == EXR_ERR_SUCCESS && y == 0)
            r = exr_decoding_choose_default_routines(ctx, 0, &dec);
        if (r == EXR_ERR_SUCCESS)
            r = exr_decoding_run(ctx, 0, &dec);
    }
    exr_decoding_destroy(ctx, &dec);
    return r;
}

int exr_read_rgb(const unsigned char *data, size_t len, int *width, int *height, float **rgb, const char **why)
{
    *rgb = NULL;
    source s = {data, len};
    exr_context_t ctx = NULL;
    exr_result_t r = open_mem(&ctx, &s);
    exr_attr_box2i_t dw;
    if (r == EXR_ERR_SUCCESS)
        r = exr_get_data_window(ctx, 0, &dw);
    float *out = NULL;
    if (r == EXR_ERR_SUCCESS) {
        *width = dw.max.x - dw.min.x + 1;
        *height = dw.max.y - dw.min.y + 1;
        out = calloc((size_t)*width * (size_t)*height * 3, sizeof *out);
        r = out ? decode_all(ctx, *width, *height, out) : EXR_ERR_OUT_OF_MEMORY;
    }
    exr_finish(&ctx);
    if (r != EXR_ERR_SUCCESS) {
        free(out);
        *why = exr_get_default_error_message(r);
        return -1;
    }
    *rgb = out;
    return 0;
}
