/* What decoding an untrusted PNG may cost (api/image/png_read.h): grade uploads
 * and textures are decoded with a pixel limit, and a file of n bytes must
 * cost at most that limit plus a small constant, whatever its chunks
 * declare. The costs are measured, not inferred: Criterion runs every test
 * in a process of its own, so the peak resident set (getrusage ru_maxrss)
 * grows only with what that test allocated and touched, and the peak
 * address space (VmPeak) with what it allocated, touched or not.
 *
 * Files are assembled here chunk by chunk, with zlib's crc32, so a chunk
 * can declare any length and carry any content; well-formed reference
 * images come from libpng's writer. Expected pixels follow the PNG
 * specification, as in test_texture.c. */
#include <criterion/criterion.h>
#include <png.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <zlib.h>

#include "png_read.h"
#include "support/png_fixture.h"

/* Far below what the attacks below used to cost (2 GB for a 44-byte file)
 * and far above what decoding a small image needs, even with sanitizers. */
#define RSS_BOUND_KB (64L * 1024)
/* The same for time, as the decoding thread's CPU time (now_s), so a
 * machine busy with other builds does not count against it. Most refusals
 * read a few hundred bytes and take under 1 ms; the slowest check here,
 * image data running on past the last row, takes 0.3 s under sanitizers. */
#define TIME_BOUND_S 2.0

/* ---- measuring ------------------------------------------------------------ */

static long peak_rss_kb(void)
{
    struct rusage ru;
    cr_assert_eq(getrusage(RUSAGE_SELF, &ru), 0);
    return ru.ru_maxrss;
}

/* VmPeak in KB, or -1 where /proc does not say. */
static long peak_vm_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    long kb = -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmPeak: %ld kB", &kb) == 1)
            break;
    fclose(f);
    return kb;
}

/* This thread's CPU time: rd_png_decode runs on the caller's thread. */
static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + ts.tv_nsec / 1e9;
}

typedef struct {
    rd_error_code rc;
    rd_png_image img;
    rd_error err;
    long rss_growth_kb; /* of the peak, over the decode */
    long vm_growth_kb;  /* the same for the address space; 0 if unknown */
    double seconds;
} decoded;

static decoded decode(const unsigned char *data, size_t len, size_t max_pixels)
{
    decoded d;
    memset(&d, 0, sizeof d);
    long before = peak_rss_kb(), vm_before = peak_vm_kb();
    double t0 = now_s();
    d.rc = rd_png_decode(data, len, max_pixels, "--limit-pixels", &d.img, &d.err);
    d.seconds = now_s() - t0;
    d.rss_growth_kb = peak_rss_kb() - before;
    long vm_after = peak_vm_kb();
    d.vm_growth_kb = vm_before >= 0 && vm_after >= 0 ? vm_after - vm_before : 0;
    return d;
}

static void assert_cheap(const decoded *d, const char *what)
{
    cr_assert(d->rss_growth_kb < RSS_BOUND_KB, "%s: peak RSS grew by %ld KB (bound %ld KB); code %d (%s)", what,
              d->rss_growth_kb, RSS_BOUND_KB, d->rc, d->err.message);
    /* An allocation never touched costs no RSS but can still fail, or
     * push out, everything else. */
    cr_assert(d->vm_growth_kb < RSS_BOUND_KB, "%s: peak address space grew by %ld KB (bound %ld KB); code %d (%s)",
              what, d->vm_growth_kb, RSS_BOUND_KB, d->rc, d->err.message);
    cr_assert(d->seconds < TIME_BOUND_S, "%s: took %.2f s; code %d (%s)", what, d->seconds, d->rc, d->err.message);
}

/* ---- assembling PNGs --------------------------------------------------------- */

typedef png_bytes buf;
#define put png_bytes_put

static void put32(buf *b, uint32_t v)
{
    unsigned char p[4] = {(unsigned char)(v >> 24), (unsigned char)(v >> 16), (unsigned char)(v >> 8),
                          (unsigned char)v};
    put(b, p, 4);
}

static void put_sig(buf *b)
{
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    put(b, sig, 8);
}

/* A complete chunk: length, type, data, CRC over type and data. */
static void put_chunk(buf *b, const char *type, const void *data, size_t n)
{
    put32(b, (uint32_t)n);
    size_t at = b->len;
    put(b, type, 4);
    if (n)
        put(b, data, n);
    put32(b, (uint32_t)crc32(0, b->data + at, (uInt)(n + 4)));
}

static void put_ihdr(buf *b, uint32_t w, uint32_t h, int depth, int ctype)
{
    unsigned char d[13] = {(unsigned char)(w >> 24),
                           (unsigned char)(w >> 16),
                           (unsigned char)(w >> 8),
                           (unsigned char)w,
                           (unsigned char)(h >> 24),
                           (unsigned char)(h >> 16),
                           (unsigned char)(h >> 8),
                           (unsigned char)h,
                           (unsigned char)depth,
                           (unsigned char)ctype,
                           0,
                           0,
                           0};
    put_chunk(b, "IHDR", d, sizeof d);
}

/* zlib data of `data` followed by `zeros` zero bytes, streamed so that a
 * gigabyte of zeros never exists in memory. */
static buf zlib_of(const void *data, size_t n, size_t zeros)
{
    static const unsigned char zero[65536];
    buf out = {NULL, 0, 0};
    z_stream z;
    memset(&z, 0, sizeof z);
    cr_assert_eq(deflateInit(&z, 9), Z_OK);
    unsigned char tmp[65536];
    int flush = Z_NO_FLUSH, rc;
    size_t left = zeros;
    z.next_in = (unsigned char *)data;
    z.avail_in = (uInt)n;
    do {
        if (z.avail_in == 0 && left) {
            size_t k = left < sizeof zero ? left : sizeof zero;
            z.next_in = (unsigned char *)zero;
            z.avail_in = (uInt)k;
            left -= k;
        }
        if (z.avail_in == 0 && !left)
            flush = Z_FINISH;
        z.next_out = tmp;
        z.avail_out = sizeof tmp;
        rc = deflate(&z, flush);
        cr_assert(rc == Z_OK || rc == Z_STREAM_END || rc == Z_BUF_ERROR, "deflate: %d", rc);
        put(&out, tmp, sizeof tmp - z.avail_out);
    } while (rc != Z_STREAM_END);
    deflateEnd(&z);
    return out;
}

/* The 8x8 8-bit RGB image the chunk tests use: pixel p channel k is
 * (p·37 + k·101 + 3) mod 256, every row with filter type 0. */
enum { SMALL = 8 };

static unsigned small_val(int p, int k) { return (unsigned)((p * 37 + k * 101 + 3) % 256); }

static buf small_idat(size_t extra_zeros)
{
    unsigned char raw[SMALL * (1 + SMALL * 3)];
    size_t n = 0;
    for (int y = 0; y < SMALL; y++) {
        raw[n++] = 0;
        for (int x = 0; x < SMALL; x++)
            for (int k = 0; k < 3; k++)
                raw[n++] = (unsigned char)small_val(y * SMALL + x, k);
    }
    return zlib_of(raw, n, extra_zeros);
}

/* The small image's own IDAT and IEND. */
static void put_small_body(buf *b)
{
    buf z = small_idat(0);
    put_chunk(b, "IDAT", z.data, z.len);
    free(z.data);
    put_chunk(b, "IEND", NULL, 0);
}

static void assert_small_pixels(const decoded *d)
{
    cr_assert_eq(d->rc, RD_OK, "code %d (%s)", d->rc, d->err.message);
    cr_assert(d->img.width == SMALL && d->img.height == SMALL, "%dx%d", d->img.width, d->img.height);
    cr_assert_eq(d->img.maxval, 255);
    for (int i = 0; i < SMALL * SMALL * 3; i++)
        cr_assert_eq(d->img.rgb[i], small_val(i / 3, i % 3), "sample %d: %u, expected %u", i, d->img.rgb[i],
                     small_val(i / 3, i % 3));
}

/* ---- (a) chunks that declare more than the file holds -------------------- */

/* The image of a 195-byte grade upload that cost 2 GB: a 320x240 IHDR,
 * then a tEXt header declaring 2^31-1 bytes, then "abc" and the end of the
 * file. */
static const unsigned char upload_2gb[44] = {0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00,
                                             0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00, 0x01, 0x40, 0x00, 0x00,
                                             0x00, 0xf0, 0x08, 0x02, 0x00, 0x00, 0x00, 0xfe, 0x4f, 0x2a, 0x3c,
                                             0x7f, 0xff, 0xff, 0xff, 0x74, 0x45, 0x58, 0x74, 0x61, 0x62, 0x63};

Test(png_limits, upload_with_a_2gb_text_chunk)
{
    decoded d = decode(upload_2gb, sizeof upload_2gb, 1u << 20);
    cr_assert_eq(d.rc, RD_ERR_SYNTAX, "code %d (%s)", d.rc, d.err.message);
    cr_assert_null(d.img.rgb);
    assert_cheap(&d, "the 2 GB text upload");
}

/* A valid small PNG whose second chunk declares the largest length PNG
 * allows, 2^31-1, followed either by nothing much (the file ends) or by the
 * rest of the image (which the chunk would then swallow). Both are damaged
 * files, and refusing them must cost no more than reading them. */
static void forged_length(const char *type)
{
    static const unsigned char lead[] = "Comment\0\0\0 a forged length: the data stops well short of it";
    for (int with_body = 0; with_body < 2; with_body++) {
        buf b = {NULL, 0, 0};
        put_sig(&b);
        put_ihdr(&b, SMALL, SMALL, 8, PNG_COLOR_TYPE_RGB);
        put32(&b, 0x7fffffffu);
        put(&b, type, 4);
        put(&b, lead, sizeof lead - 1);
        if (with_body)
            put_small_body(&b);
        char what[64];
        snprintf(what, sizeof what, "%.4s of 2^31-1 bytes%s", type, with_body ? " before IDAT" : "");
        decoded d = decode(b.data, b.len, 1u << 20);
        cr_assert_eq(d.rc, RD_ERR_SYNTAX, "%s: code %d (%s)", what, d.rc, d.err.message);
        cr_assert_null(d.img.rgb);
        assert_cheap(&d, what);
        free(b.data);
    }
}

Test(png_limits, forged_length_tEXt) { forged_length("tEXt"); }
Test(png_limits, forged_length_zTXt) { forged_length("zTXt"); }
Test(png_limits, forged_length_iTXt) { forged_length("iTXt"); }
Test(png_limits, forged_length_iCCP) { forged_length("iCCP"); }
Test(png_limits, forged_length_eXIf) { forged_length("eXIf"); }
Test(png_limits, forged_length_sPLT) { forged_length("sPLT"); }
/* Ancillary (lower-case first letter) and unknown to libpng. */
Test(png_limits, forged_length_unknown) { forged_length("vpAg"); }
/* The chunks that are read: PLTE and tRNS have fixed-size buffers, IDAT is
 * read a piece at a time. */
Test(png_limits, forged_length_PLTE) { forged_length("PLTE"); }
Test(png_limits, forged_length_tRNS) { forged_length("tRNS"); }
Test(png_limits, forged_length_IDAT) { forged_length("IDAT"); }

/* ---- decompression bombs and long tails ---------------------------------- */

/* A complete, CRC-correct chunk whose zlib data expands to 256 MiB: the
 * image must still decode, without anything like that being allocated. */
static void compressed_bomb(const char *type, const void *head, size_t head_len)
{
    buf z = zlib_of(NULL, 0, (size_t)256 << 20);
    buf data = {NULL, 0, 0};
    put(&data, head, head_len);
    put(&data, z.data, z.len);
    free(z.data);
    buf b = {NULL, 0, 0};
    put_sig(&b);
    put_ihdr(&b, SMALL, SMALL, 8, PNG_COLOR_TYPE_RGB);
    put_chunk(&b, type, data.data, data.len);
    free(data.data);
    put_small_body(&b);
    decoded d = decode(b.data, b.len, 1u << 20);
    assert_small_pixels(&d);
    assert_cheap(&d, type);
    free(d.img.rgb);
    free(b.data);
}

Test(png_limits, zTXt_bomb)
{
    static const unsigned char head[] = "Comment\0"; /* keyword, NUL, then method 0 (the final NUL) */
    compressed_bomb("zTXt", head, sizeof head);
}

Test(png_limits, iCCP_bomb)
{
    static const unsigned char head[] = "ICC profile\0";
    compressed_bomb("iCCP", head, sizeof head);
}

Test(png_limits, iTXt_bomb)
{
    /* keyword NUL, compressed 1, method 0, language NUL, translated NUL */
    static const unsigned char head[] = {'T', 'i', 't', 'l', 'e', 0, 1, 0, 0, 0};
    compressed_bomb("iTXt", head, sizeof head);
}

/* Image data that goes on after the last row (here 256 MiB of zeros in the
 * same zlib stream) is not the image: it is neither kept nor inflated to
 * its end, and the rows before it decode as they always did. */
Test(png_limits, image_data_past_the_last_row)
{
    buf z = small_idat((size_t)256 << 20);
    buf b = {NULL, 0, 0};
    put_sig(&b);
    put_ihdr(&b, SMALL, SMALL, 8, PNG_COLOR_TYPE_RGB);
    put_chunk(&b, "IDAT", z.data, z.len);
    put_chunk(&b, "IEND", NULL, 0);
    free(z.data);
    decoded d = decode(b.data, b.len, 1u << 20);
    assert_small_pixels(&d);
    assert_cheap(&d, "IDAT past the image");
    free(d.img.rgb);
    free(b.data);
}

/* Thousands of small text chunks: none is kept. */
Test(png_limits, many_text_chunks)
{
    buf b = {NULL, 0, 0};
    put_sig(&b);
    put_ihdr(&b, SMALL, SMALL, 8, PNG_COLOR_TYPE_RGB);
    unsigned char text[1000];
    memcpy(text, "Comment", 8);
    memset(text + 8, 'x', sizeof text - 8);
    for (int i = 0; i < 20000; i++)
        put_chunk(&b, "tEXt", text, sizeof text);
    put_small_body(&b);
    decoded d = decode(b.data, b.len, 1u << 20);
    assert_small_pixels(&d);
    cr_assert(d.rss_growth_kb < 8 * 1024, "20000 tEXt chunks: peak RSS grew by %ld KB", d.rss_growth_kb);
    free(d.img.rgb);
    free(b.data);
}

/* ---- (b) the pixel limit ------------------------------------------------------ */

/* w x h 16-bit RGB, every sample 0: its IDAT is tiny next to its pixels
 * (4096x4096 is 96 MiB of samples in about 100 KB). */
static buf zero_png16(uint32_t w, uint32_t h)
{
    size_t row = 1 + (size_t)w * 6;
    buf z = zlib_of(NULL, 0, row * h); /* filter byte 0 and zero samples: all zeros */
    buf b = {NULL, 0, 0};
    put_sig(&b);
    put_ihdr(&b, w, h, 16, PNG_COLOR_TYPE_RGB);
    put_chunk(&b, "IDAT", z.data, z.len);
    put_chunk(&b, "IEND", NULL, 0);
    free(z.data);
    return b;
}

Test(png_limits, over_the_pixel_limit_allocates_nothing)
{
    buf b = zero_png16(4096, 4096);
    cr_assert(b.len < 256 * 1024, "the test file is %zu bytes", b.len);
    decoded d = decode(b.data, b.len, (size_t)4096 * 4096 - 1);
    cr_assert_eq(d.rc, RD_ERR_LIMIT, "code %d (%s)", d.rc, d.err.message);
    cr_assert(strstr(d.err.message, "--limit-pixels"), "%s", d.err.message);
    cr_assert_null(d.img.rgb);
    /* Decoding would take 2 x 96 MiB; refusing takes nothing measurable. */
    cr_assert(d.rss_growth_kb < 4 * 1024, "refusing 4096x4096: peak RSS grew by %ld KB", d.rss_growth_kb);
    cr_assert(d.vm_growth_kb < 4 * 1024, "refusing 4096x4096: peak address space grew by %ld KB", d.vm_growth_kb);
    cr_assert(d.seconds < TIME_BOUND_S, "refusing 4096x4096 took %.2f s", d.seconds);
    free(b.data);
}

Test(png_limits, cost_is_bounded_by_the_pixel_limit)
{
    /* Within the limit: the file row buffer and the 16-bit result, 6 bytes
     * per pixel each, plus a constant. */
    uint32_t w = 1024, h = 1024;
    buf b = zero_png16(w, h);
    decoded d = decode(b.data, b.len, (size_t)w * h);
    cr_assert_eq(d.rc, RD_OK, "code %d (%s)", d.rc, d.err.message);
    cr_assert(d.img.width == (int)w && d.img.height == (int)h && d.img.maxval == 65535);
    for (size_t i = 0; i < (size_t)w * h * 3; i += 4099)
        cr_assert_eq(d.img.rgb[i], 0);
    long expected_kb = (long)((size_t)w * h * 12 / 1024);
    cr_assert(d.rss_growth_kb < expected_kb + 8 * 1024, "1024x1024 16-bit: peak RSS grew by %ld KB, pixels need %ld KB",
              d.rss_growth_kb, expected_kb);
    free(d.img.rgb);
    free(b.data);
}

/* ---- (c) ordinary images decode as before ------------------------------------- */

typedef png_layout layout;
#define encode png_fixture_encode

/* The same file with ancillary chunks right after IHDR, each a valid one
 * of its kind (the profile apart): text, compressed text, a colour
 * profile, gamma, a physical size, a time and a private chunk. None of them
 * may change a decoded sample. */
static buf with_ancillary(const buf *png)
{
    size_t ihdr_end = 8 + 8 + 13 + 4;
    buf b = {NULL, 0, 0};
    put(&b, png->data, ihdr_end);
    static const unsigned char text[] = "Software\0rayd tests";
    put_chunk(&b, "tEXt", text, sizeof text - 1);
    static const unsigned char words[] = "a comment that is compressed";
    buf z = zlib_of(words, sizeof words - 1, 0);
    buf zt = {NULL, 0, 0};
    put(&zt, "Comment\0", 9); /* keyword, NUL, method 0 */
    put(&zt, z.data, z.len);
    put_chunk(&b, "zTXt", zt.data, zt.len);
    free(zt.data);
    buf icc = {NULL, 0, 0};
    put(&icc, "ICC\0", 5);
    put(&icc, z.data, z.len); /* not a real profile: libpng would reject it, if it looked */
    put_chunk(&b, "iCCP", icc.data, icc.len);
    free(icc.data);
    free(z.data);
    static const unsigned char gama[4] = {0, 0, 0xb1, 0x8f}; /* 1/2.2 */
    put_chunk(&b, "gAMA", gama, 4);
    static const unsigned char phys[9] = {0, 0, 0x0b, 0x13, 0, 0, 0x0b, 0x13, 1};
    put_chunk(&b, "pHYs", phys, 9);
    static const unsigned char time_[7] = {0x07, 0xe9, 1, 2, 3, 4, 5};
    put_chunk(&b, "tIME", time_, 7);
    static const unsigned char priv[5] = {1, 2, 3, 4, 5};
    put_chunk(&b, "vpAg", priv, 5);
    put(&b, png->data + ihdr_end, png->len - ihdr_end);
    return b;
}

static void check(const buf *m, int w, int h, const unsigned *want, unsigned maxval, int had_alpha, int was_palette,
                  int was_grey)
{
    buf dressed = with_ancillary(m);
    const buf *files[2] = {m, &dressed};
    for (int f = 0; f < 2; f++) {
        decoded d = decode(files[f]->data, files[f]->len, 1u << 20);
        const char *which = f ? "with ancillary chunks" : "plain";
        cr_assert_eq(d.rc, RD_OK, "%s: code %d (%s)", which, d.rc, d.err.message);
        cr_assert(d.img.width == w && d.img.height == h, "%s: %dx%d, expected %dx%d", which, d.img.width, d.img.height,
                  w, h);
        cr_assert_eq(d.img.maxval, maxval, "%s", which);
        cr_assert_eq(d.img.depth, maxval == 65535 ? 16 : 8, "%s", which);
        cr_assert_eq(d.img.had_alpha, had_alpha, "%s", which);
        cr_assert_eq(d.img.was_palette, was_palette, "%s", which);
        cr_assert_eq(d.img.was_grey, was_grey, "%s", which);
        for (int i = 0; i < w * h * 3; i++)
            cr_assert_eq(d.img.rgb[i], want[i], "%s: pixel (%d,%d) channel %d: %u, expected %u", which, (i / 3) % w,
                         (i / 3) / w, i % 3, d.img.rgb[i], want[i]);
        free(d.img.rgb);
    }
    free(dressed.data);
}

#define alloc_rows png_fixture_rows
#define free_rows png_fixture_free_rows

static const png_color palette[5] = {{0, 0, 0}, {255, 0, 0}, {12, 200, 34}, {1, 2, 3}, {250, 251, 252}};

Test(png_limits, palette_with_trns)
{
    int w = 6, h = 2;
    png_byte alpha[3] = {0, 128, 255};
    layout L = {w, h, PNG_COLOR_TYPE_PALETTE, 8, 0, palette, 5, alpha, 3, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w);
    unsigned want[6 * 2 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int idx = (x + 3 * y) % 5;
            rows[y][x] = (unsigned char)idx;
            want[(y * w + x) * 3 + 0] = palette[idx].red;
            want[(y * w + x) * 3 + 1] = palette[idx].green;
            want[(y * w + x) * 3 + 2] = palette[idx].blue;
        }
    buf m = encode(&L, rows);
    check(&m, w, h, want, 255, 1, 1, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(png_limits, rgb_with_trns_colour)
{
    /* tRNS of a truecolour image names one transparent colour: the image
     * counts as having alpha, and that colour still decodes as itself. */
    int w = 3, h = 2;
    png_color_16 key = {0, 10, 20, 30, 0};
    layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 0, NULL, 0, NULL, 0, &key};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    unsigned want[3 * 2 * 3];
    for (int p = 0; p < w * h; p++)
        for (int k = 0; k < 3; k++)
            want[3 * p + k] = rows[p / w][3 * (p % w) + k] =
                (unsigned char)(p == 2 ? 10u * (unsigned)(k + 1) : small_val(p, k));
    buf m = encode(&L, rows);
    check(&m, w, h, want, 255, 1, 0, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(png_limits, grey_1bit)
{
    int w = 11, h = 3; /* the last byte of each row is partly padding */
    layout L = {w, h, PNG_COLOR_TYPE_GRAY, 1, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, ((size_t)w + 7) / 8);
    unsigned want[11 * 3 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned s = (unsigned)((x + 2 * y) % 3 == 0);
            rows[y][x / 8] |= (unsigned char)(s << (7 - x % 8));
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = s * 255;
        }
    buf m = encode(&L, rows);
    check(&m, w, h, want, 255, 0, 0, 1);
    free(m.data);
    free_rows(rows, h);
}

Test(png_limits, rgba_16bit)
{
    int w = 3, h = 2;
    layout L = {w, h, PNG_COLOR_TYPE_RGB_ALPHA, 16, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 8);
    unsigned want[3 * 2 * 3];
    for (int p = 0; p < w * h; p++)
        for (int k = 0; k < 4; k++) {
            unsigned v = k == 3 ? 0x1111u * (unsigned)p : 0x0f0fu * (unsigned)(p + k) + 7;
            rows[p / w][8 * (p % w) + 2 * k] = (unsigned char)(v >> 8);
            rows[p / w][8 * (p % w) + 2 * k + 1] = (unsigned char)v;
            if (k < 3)
                want[3 * p + k] = v;
        }
    buf m = encode(&L, rows);
    check(&m, w, h, want, 65535, 1, 0, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(png_limits, interlaced)
{
    /* 13x11 reaches all seven Adam7 passes with partial blocks. */
    int w = 13, h = 11;
    layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 1, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    unsigned want[13 * 11 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = rows[y][x * 3 + k] = (unsigned char)small_val(y * w + x, k);
    buf m = encode(&L, rows);
    cr_assert_eq(m.data[8 + 8 + 12], 1, "interlace method %d", m.data[8 + 8 + 12]);
    check(&m, w, h, want, 255, 0, 0, 0);
    free(m.data);
    free_rows(rows, h);

    /* Interlaced 16-bit RGBA. */
    layout A = {w, h, PNG_COLOR_TYPE_RGB_ALPHA, 16, 1, NULL, 0, NULL, 0, NULL};
    rows = alloc_rows(h, (size_t)w * 8);
    for (int p = 0; p < w * h; p++)
        for (int k = 0; k < 4; k++) {
            unsigned v = (unsigned)(p * 499 + k * 12345) & 0xffffu;
            rows[p / w][8 * (p % w) + 2 * k] = (unsigned char)(v >> 8);
            rows[p / w][8 * (p % w) + 2 * k + 1] = (unsigned char)v;
            if (k < 3)
                want[3 * p + k] = v;
        }
    m = encode(&A, rows);
    check(&m, w, h, want, 65535, 1, 0, 0);
    free(m.data);
    free_rows(rows, h);
}
