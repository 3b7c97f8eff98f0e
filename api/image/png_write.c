#include "png_write.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

rd_png_options rd_png_options_default(void)
{
    rd_png_options o = {1, RD_PNG_FILTER_SUB};
    return o;
}

typedef struct {
    unsigned char *data;
    size_t len, cap;
    int failed;
} membuf;

static void mem_write(png_structp png, png_bytep bytes, png_size_t n)
{
    membuf *m = png_get_io_ptr(png);
    if (m->failed)
        return;
    if (m->len + n > m->cap) {
        size_t nc = m->cap ? m->cap : 4096;
        while (nc < m->len + n)
            nc *= 2;
        unsigned char *p = realloc(m->data, nc);
        if (!p) {
            m->failed = 1;
            return;
        }
        m->data = p;
        m->cap = nc;
    }
    memcpy(m->data + m->len, bytes, n);
    m->len += n;
}

static void mem_flush(png_structp png) { (void)png; }

rd_error_code rd_png_encode(const uint8_t *rgb, int width, int height, const rd_png_options *opt_in,
                            unsigned char **out, size_t *len, rd_error *err)
{
    rd_png_options opt = opt_in ? *opt_in : rd_png_options_default();
    *out = NULL;
    *len = 0;
    membuf m = {NULL, 0, 0, 0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, info ? &info : NULL);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory encoding PNG");
    }
    /* volatile: read after longjmp */
    png_bytep *volatile rows = malloc((size_t)height * sizeof(png_bytep));
    if (!rows) {
        png_destroy_write_struct(&png, &info);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory encoding PNG");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(rows);
        free(m.data);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "PNG encoding failed");
    }
    png_set_write_fn(png, &m, mem_write, mem_flush);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, opt.level < 0 ? 0 : (opt.level > 9 ? 9 : opt.level));
    png_set_filter(png, PNG_FILTER_TYPE_BASE,
                   opt.filter == RD_PNG_FILTER_NONE  ? PNG_FILTER_NONE
                   : opt.filter == RD_PNG_FILTER_SUB ? PNG_FILTER_SUB
                                                     : PNG_ALL_FILTERS);
    for (int y = 0; y < height; y++)
        rows[y] = (png_bytep)(rgb + (size_t)y * (size_t)width * 3);
    png_set_rows(png, info, rows);
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&png, &info);
    free(rows);
    if (m.failed) {
        free(m.data);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory encoding PNG");
    }
    *out = m.data;
    *len = m.len;
    return RD_OK;
}
