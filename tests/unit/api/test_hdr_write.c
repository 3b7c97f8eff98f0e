/* Unit tests for api/image/hdr_write.h: the EXR is read back with
 * OpenEXRCore's own decoder (tests/support/exr_read.h) and the PFM byte by
 * byte, and every float must be exactly the core's linear double rounded
 * to float: no clamp, no gamma, no quantisation. */
#include <criterion/criterion.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hdr_write.h"
#include "support/exr_read.h"
#include "support/scene_fixture.h"

/* A w x h image whose every channel differs and whose values need all of a
 * float's bits: over 1, under 0.001, a denormal-range double, zero. */
static rd_image ramp(int w, int h)
{
    rd_image img = {w, h, malloc((size_t)w * (size_t)h * 3 * sizeof(double))};
    cr_assert_not_null(img.rgb);
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
        img.rgb[i] = i % 7 == 0 ? 0.0 : i % 11 == 0 ? 1e-40 : (double)i / 3.0 * (i % 2 ? 1e-3 : 1.7);
    return img;
}

/* Encodes img as EXR, decodes it, and checks every float. */
static void assert_exr_round_trip(const rd_image *img)
{
    unsigned char *exr;
    size_t len;
    rd_error err = {0};
    cr_assert_eq(rd_exr_encode(img, &exr, &len, &err), RD_OK, "%s", err.message);
    int w, h;
    float *back;
    const char *why = "";
    cr_assert_eq(exr_read_rgb(exr, len, &w, &h, &back, &why), 0, "decoding: %s", why);
    cr_assert_eq(w, img->width);
    cr_assert_eq(h, img->height);
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
        cr_assert_eq(back[i], (float)img->rgb[i], "channel %zu: %.9g, written %.17g", i, back[i], img->rgb[i]);
    free(back);
    free(exr);
}

Test(hdr_write, exr_holds_every_float_of_the_image)
{
    /* 37 rows: ZIP chunks are 16 lines, so the last is partial. */
    rd_image img = ramp(5, 37);
    assert_exr_round_trip(&img);
    rd_image_free(&img);
}

Test(hdr_write, exr_is_float_rgb_with_zip)
{
    rd_image img = ramp(3, 2);
    unsigned char *exr;
    size_t len;
    cr_assert_eq(rd_exr_encode(&img, &exr, &len, NULL), RD_OK);
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    cr_assert(len > 4 && memcmp(exr, magic, 4) == 0);
    char names[8];
    int compression;
    cr_assert_eq(exr_read_layout(exr, len, names, &compression), 0);
    cr_assert_str_eq(names, "BGR"); /* the file sorts channels by name */
    cr_assert_eq(compression, 3);   /* EXR_COMPRESSION_ZIP */
    free(exr);
    rd_image_free(&img);
}

Test(hdr_write, exr_of_a_render_is_its_linear_image)
{
    /* Radiance over 1 (the light is bright) is kept, not clamped. */
    rd_scene s;
    soft_shadow_scene(&s, 4);
    rd_image img;
    render_ok(&s, NULL, &img, NULL);
    double most = 0;
    for (size_t i = 0; i < (size_t)img.width * (size_t)img.height * 3; i++)
        most = img.rgb[i] > most ? img.rgb[i] : most;
    cr_assert(most > 0, "the render is black");
    assert_exr_round_trip(&img);
    rd_image_free(&img);
    rd_scene_free(&s);
}

/* The little-endian float at p. */
static float le_float(const unsigned char *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

Test(hdr_write, pfm_is_little_endian_bottom_row_first)
{
    rd_image img = ramp(5, 3);
    unsigned char *pfm;
    size_t len;
    rd_error err = {0};
    cr_assert_eq(rd_pfm_encode(&img, &pfm, &len, &err), RD_OK, "%s", err.message);
    static const char head[] = "PF\n5 3\n-1\n";
    size_t hl = sizeof head - 1;
    cr_assert_eq(len, hl + 5 * 3 * 3 * 4);
    cr_assert(memcmp(pfm, head, hl) == 0, "header %.*s", (int)hl, pfm);
    for (int y = 0; y < 3; y++)
        for (int i = 0; i < 15; i++) {
            float got = le_float(pfm + hl + ((size_t)(2 - y) * 15 + (size_t)i) * 4);
            cr_assert_eq(got, (float)img.rgb[y * 15 + i], "row %d channel %d: %.9g", y, i, got);
        }
    free(pfm);
    rd_image_free(&img);
}

Test(hdr_write, an_empty_image_is_refused_with_nothing_allocated)
{
    rd_image img = {0, 0, NULL};
    unsigned char *out = (unsigned char *)"x";
    size_t len = 1;
    rd_error err = {0};
    cr_assert_eq(rd_exr_encode(&img, &out, &len, &err), RD_ERR_INVALID);
    cr_assert(out == NULL && len == 0);
    out = (unsigned char *)"x";
    cr_assert_eq(rd_pfm_encode(&img, &out, &len, &err), RD_ERR_INVALID);
    cr_assert(out == NULL && len == 0);
    cr_assert_str_eq(err.message, "no image to encode");
}
