/* libFuzzer target for the PNG reader (api/image/png_read.c) and the grade
 * upload decoder on top of it (rd_grade_load_png, api/grading/grade.c). Students
 * upload the PNGs that POST /v1/grade decodes, so any bytes must give an
 * image or an error, never a crash or a leak, and must cost what the pixel
 * limit allows, never what a chunk declares: run.sh runs this target with
 * a malloc limit, so one allocation beyond it is a crash (an "oom-" file).
 *
 * Nearly every mutation breaks a chunk's CRC, and libpng stops at the
 * first bad CRC of a critical chunk. So each input is decoded twice: as
 * it is (the CRC checks themselves) and, when that changes anything, with
 * the CRC of every complete chunk made right, which lets mutations reach
 * the chunk handlers, inflate and the row transforms. A crash input saved
 * from the second pass still has its wrong CRCs: it reproduces through this
 * target, and RD_FUZZ_PNG_FIXED=FILE writes the repaired copy, the file
 * the decoder saw, for use elsewhere (curl, rayd grade).
 *
 * libpng is the system's, built without coverage instrumentation, so
 * libFuzzer sees only the few branches of png_read.c around it and cannot
 * tell an input that reached a new libpng check from one that did not.
 * What libpng decided still shows in the outcome: its error message, or
 * the layout of the decoded image. Each distinct outcome bumps a counter
 * of its own in libFuzzer's extra-counter section, which it treats as
 * coverage, so inputs that end differently are kept and mutated further. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "fuzz_check.h"

#include "grade.h"
#include "png_read.h"

/* The daemon's --limit-pixels is larger; a megapixel already reaches every
 * code path and keeps each input within milliseconds. */
#define MAX_PIXELS ((size_t)1 << 20)
#define FLAG "--limit-pixels"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

__attribute__((section("__libfuzzer_extra_counters"), used)) static uint8_t outcomes[1 << 12];

/* FNV-1a of text, then of a few small numbers. */
static void outcome(const char *text, unsigned a, unsigned b, unsigned c)
{
    uint32_t h = 2166136261u;
    for (const char *p = text; *p; p++)
        h = (h ^ (unsigned char)*p) * 16777619u;
    unsigned more[3] = {a, b, c};
    for (int i = 0; i < 3; i++)
        h = (h ^ more[i]) * 16777619u;
    outcomes[h % sizeof outcomes]++;
}

/* libpng's reason without what precedes it ("damaged PNG: IDAT: ..."):
 * the chunk name comes from the input and would make every name a new
 * outcome. */
static const char *reason(const char *message)
{
    const char *r = message;
    for (const char *p = strstr(message, ": "); p; p = strstr(p + 1, ": "))
        r = p + 2;
    return r;
}

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* Rewrites the CRC of every chunk that lies wholly inside the buffer;
 * returns 1 when any changed. Stops at the first chunk that runs past the
 * end, which is left for libpng to find short. */
static int fix_crcs(unsigned char *p, size_t n)
{
    int changed = 0;
    size_t at = 8;
    while (n - at >= 12) {
        uint32_t len = be32(p + at);
        if (len > n - at - 12)
            break;
        uint32_t crc = (uint32_t)crc32(0, p + at + 4, len + 4);
        unsigned char *c = p + at + 8 + len;
        if (be32(c) != crc) {
            c[0] = (unsigned char)(crc >> 24);
            c[1] = (unsigned char)(crc >> 16);
            c[2] = (unsigned char)(crc >> 8);
            c[3] = (unsigned char)crc;
            changed = 1;
        }
        at += 12 + (size_t)len;
    }
    return changed;
}

static void check_error(const char *who, rd_error_code rc, const rd_error *err)
{
    if (rc != RD_ERR_SYNTAX && rc != RD_ERR_LIMIT && rc != RD_ERR_NOMEM)
        rd_fuzz_fail("%s: unexpected code %d ('%s')", who, (int)rc, err->message);
    if (err->code != rc)
        rd_fuzz_fail("%s: returned code %d, the error holds %d ('%s')", who, (int)rc, (int)err->code, err->message);
    if (!err->message[0])
        rd_fuzz_fail("%s: code %d without a message", who, (int)rc);
    if (rc == RD_ERR_LIMIT && !strstr(err->message, FLAG))
        rd_fuzz_fail("%s: a limit error must name its flag: '%s'", who, err->message);
}

static void decode(const unsigned char *bytes, size_t n)
{
    rd_png_image img;
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_png_decode(bytes, n, MAX_PIXELS, FLAG, &img, &err);
    if (rc == RD_OK) {
        size_t px = (size_t)img.width * (size_t)img.height;
        if (img.width <= 0 || img.height <= 0 || px > MAX_PIXELS)
            rd_fuzz_fail("decoded %dx%d with a limit of %zu pixels", img.width, img.height, MAX_PIXELS);
        if (!img.rgb)
            rd_fuzz_fail("decoded %dx%d without pixels", img.width, img.height);
        if (!((img.depth == 8 && img.maxval == 255) || (img.depth == 16 && img.maxval == 65535)))
            rd_fuzz_fail("depth %d with maxval %u", img.depth, img.maxval);
        for (size_t i = 0; i < px * 3; i++)
            if (img.rgb[i] > img.maxval)
                rd_fuzz_fail("sample %zu is %u, over maxval %u", i, img.rgb[i], img.maxval);
        outcome("decoded",
                (unsigned)img.depth | (unsigned)img.had_alpha << 5 | (unsigned)img.was_palette << 6 |
                    (unsigned)img.was_grey << 7,
                img.width < 16 ? (unsigned)img.width : 16, img.height < 16 ? (unsigned)img.height : 16);
    } else {
        check_error("rd_png_decode", rc, &err);
        outcome(rc == RD_ERR_LIMIT ? "limit" : reason(err.message), (unsigned)rc, 0, 0);
        if (img.rgb)
            rd_fuzz_fail("rd_png_decode failed (%s) but left pixels", err.message);
    }

    /* The grade decoder must agree, sample for sample after rounding to
     * 8 bits: it is the same file. */
    uint8_t *rgb8 = NULL;
    int w = -1, h = -1;
    rd_error err8;
    memset(&err8, 0, sizeof err8);
    rd_error_code rc8 = rd_grade_load_png(bytes, n, MAX_PIXELS, &rgb8, &w, &h, &err8);
    if (rc8 != rc)
        rd_fuzz_fail("rd_grade_load_png returned %d ('%s'), rd_png_decode %d ('%s')", (int)rc8, err8.message, (int)rc,
                     err.message);
    if (rc == RD_OK) {
        if (w != img.width || h != img.height || !rgb8)
            rd_fuzz_fail("rd_grade_load_png: %dx%d, rd_png_decode %dx%d", w, h, img.width, img.height);
        for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++) {
            unsigned want = img.maxval == 255 ? img.rgb[i] : (img.rgb[i] * 255u + 32767u) / 65535u;
            if (rgb8[i] != want)
                rd_fuzz_fail("sample %zu: %u from rd_grade_load_png, %u from rd_png_decode", i, rgb8[i], want);
        }
    } else {
        check_error("rd_grade_load_png", rc8, &err8);
        if (rgb8)
            rd_fuzz_fail("rd_grade_load_png failed (%s) but left pixels", err8.message);
    }
    free(rgb8);
    free(img.rgb);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Exactly size bytes: AddressSanitizer catches a read past the end. */
    unsigned char *copy = malloc(size ? size : 1);
    if (!copy)
        return 0;
    if (size)
        memcpy(copy, data, size);
    decode(copy, size);
    if (rd_png_sniff(copy, size) && fix_crcs(copy, size)) {
        static const char *save;
        static int looked;
        if (!looked) {
            save = getenv("RD_FUZZ_PNG_FIXED");
            looked = 1;
        }
        if (save) {
            FILE *f = fopen(save, "wb");
            if (!f || fwrite(copy, 1, size, f) != size || fclose(f) != 0)
                rd_fuzz_fail("cannot write %s", save);
        }
        decode(copy, size);
    }
    free(copy);
    return 0;
}
