#include "png_read.h"

#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const unsigned char *data;
    size_t len, pos;
    char msg[200];
} reader;

static void read_fn(png_structp png, png_bytep out, png_size_t n)
{
    reader *r = png_get_io_ptr(png);
    if (n > r->len - r->pos)
        png_error(png, "file ends early");
    memcpy(out, r->data + r->pos, n);
    r->pos += n;
}

static void error_fn(png_structp png, png_const_charp msg)
{
    reader *r = png_get_error_ptr(png);
    snprintf(r->msg, sizeof r->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void warning_fn(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

int rd_png_sniff(const unsigned char *data, size_t len) { return len >= 8 && png_sig_cmp(data, 0, 8) == 0; }

rd_error_code rd_png_decode(const unsigned char *data, size_t len, size_t max_pixels, const char *limit_flag,
                            rd_png_image *out, rd_error *err)
{
    memset(out, 0, sizeof *out);
    if (!rd_png_sniff(data, len))
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "not a PNG file");
    reader r = {data, len, 0, ""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, error_fn, warning_fn);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory reading PNG");
    }
    /* Read after a longjmp, so volatile. */
    unsigned char *volatile pixels = NULL;
    png_bytep *volatile rows = NULL;
    /* An error decided here rather than by libpng (a limit, our own
     * allocations), returned after the longjmp. */
    volatile rd_error_code decided = RD_OK;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(pixels);
        free(rows);
        free(out->rgb);
        out->rgb = NULL;
        if (decided)
            return decided;
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "damaged PNG: %s", r.msg[0] ? r.msg : "unreadable");
    }
    png_set_read_fn(png, &r, read_fn);
    /* Our own pixel limit decides (below); libpng's default of 1,000,000
     * per side would call a wide but small image damaged. */
    png_set_user_limits(png, 0x7fffffffu, 0x7fffffffu);
    /* The bytes come from strangers (grade uploads), so what a file costs
     * must follow from the pixel limit, never from what its chunks declare.
     * libpng allocates the whole declared length of a tEXt, zTXt, iTXt or
     * sPLT before reading it, and over its chunk memory limit it only warns
     * (a benign error): 44 bytes declaring 2^31-1 bytes of text cost 2 GB.
     * No ancillary chunk changes what is decoded here (no gamma, colour or
     * background transform is asked for), so every chunk but IHDR, PLTE,
     * tRNS, IDAT and IEND is skipped unread, 1 KB at a time; an unknown
     * critical chunk is still an error. eXIf is named as well because
     * libpng 1.6.31 read it but left it out of that list. */
    static const png_byte also_skipped[] = {'e', 'X', 'I', 'f', 0};
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, NULL, -1);
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, also_skipped, 1);
    /* Second lines of defence, should a chunk ever be read again: store no
     * text or unknown chunk at all (libpng's counter stops at 1), and keep
     * any chunk, or what it inflates to, to 64 KiB. PLTE and tRNS, the
     * only ones still read, fit in 768 bytes; an ICC profile can exceed
     * 64 KiB, so whoever adds colour management must raise this. */
    png_set_chunk_cache_max(png, 1);
    png_set_chunk_malloc_max(png, 64 * 1024);
    png_read_info(png, info);
    png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    int ctype = png_get_color_type(png, info), depth = png_get_bit_depth(png, info);
    if ((unsigned long long)w * h > max_pixels) {
        decided = rd_error_set(err, RD_ERR_LIMIT, 0, 0, "PNG of %ux%u is %llu pixels, over the limit of %zu (%s)",
                               (unsigned)w, (unsigned)h, (unsigned long long)w * h, max_pixels, limit_flag);
        png_longjmp(png, 1);
    }
    out->had_alpha = (ctype & PNG_COLOR_MASK_ALPHA) || png_get_valid(png, info, PNG_INFO_tRNS);
    out->was_palette = ctype == PNG_COLOR_TYPE_PALETTE;
    out->was_grey = !(ctype & PNG_COLOR_MASK_COLOR);
    out->depth = depth == 16 ? 16 : 8;
    png_set_expand(png); /* palette -> RGB, grey < 8 bits -> 8, tRNS -> alpha */
    png_set_strip_alpha(png);
    png_set_gray_to_rgb(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    size_t rowbytes = png_get_rowbytes(png, info);
    int bytes = out->depth == 16 ? 2 : 1;
    if (rowbytes != (size_t)w * 3 * bytes)
        png_error(png, "unexpected row layout");
    pixels = malloc(rowbytes * h);
    rows = malloc(sizeof(png_bytep) * h);
    out->rgb = malloc(sizeof(uint16_t) * 3 * (size_t)w * h);
    if (!pixels || !rows || !out->rgb) {
        decided = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for a %ux%u PNG", (unsigned)w, (unsigned)h);
        png_longjmp(png, 1);
    }
    for (png_uint_32 y = 0; y < h; y++)
        rows[y] = pixels + y * rowbytes;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    size_t n = (size_t)w * h * 3;
    for (size_t i = 0; i < n; i++)
        out->rgb[i] = bytes == 2 ? (uint16_t)(pixels[2 * i] << 8 | pixels[2 * i + 1]) : pixels[i];
    out->width = (int)w;
    out->height = (int)h;
    out->maxval = bytes == 2 ? 65535 : 255;
    png_destroy_read_struct(&png, &info, NULL);
    free(pixels);
    free(rows);
    return RD_OK;
}

size_t rd_png_file_bound(int width, int height)
{
    return (size_t)width * (size_t)height * 8 + (size_t)height + ((size_t)1 << 20);
}
