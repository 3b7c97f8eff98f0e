#include "png_fixture.h"

#include <criterion/criterion.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

void png_bytes_put(png_bytes *b, const void *p, size_t n)
{
    if (b->len + n > b->cap) {
        size_t nc = (b->cap ? b->cap * 2 : 4096) + n;
        unsigned char *q = realloc(b->data, nc);
        cr_assert(q, "out of memory building a test PNG");
        b->data = q;
        b->cap = nc;
    }
    memcpy(b->data + b->len, p, n);
    b->len += n;
}

static void mem_write(png_structp png, png_bytep src, png_size_t n) { png_bytes_put(png_get_io_ptr(png), src, n); }

static void mem_flush(png_structp png) { (void)png; }

png_bytes png_fixture_encode(const png_layout *L, unsigned char **rows)
{
    png_bytes m = {NULL, 0, 0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    cr_assert(png);
    png_infop info = png_create_info_struct(png);
    cr_assert(info);
    if (setjmp(png_jmpbuf(png)))
        cr_assert_fail("libpng failed to encode the test image");
    png_set_write_fn(png, &m, mem_write, mem_flush);
    png_set_IHDR(png, info, (png_uint_32)L->width, (png_uint_32)L->height, L->depth, L->color_type,
                 L->interlace ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (L->palette)
        png_set_PLTE(png, info, L->palette, L->npalette);
    if (L->trns || L->trns_colour)
        png_set_tRNS(png, info, L->trns, L->ntrns, L->trns_colour);
    png_set_rows(png, info, rows);
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&png, &info);
    return m;
}

unsigned char **png_fixture_rows(int h, size_t bytes_per_row)
{
    unsigned char **rows = malloc(sizeof *rows * (size_t)h);
    cr_assert(rows);
    for (int y = 0; y < h; y++) {
        rows[y] = calloc(1, bytes_per_row);
        cr_assert(rows[y]);
    }
    return rows;
}

void png_fixture_free_rows(unsigned char **rows, int h)
{
    for (int y = 0; y < h; y++)
        free(rows[y]);
    free(rows);
}
