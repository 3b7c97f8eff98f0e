/* Textures: bilinear wrapped lookup (core/shading/texture.h) and PNG decoding in
 * every layout (api/image/png_read.h, rd_texture_from_png in
 * api/assets/scene_assets.h).
 *
 * The PNGs are encoded here, in memory, with libpng's write API, so each
 * test knows every stored sample. Expected decoded values follow the PNG
 * specification: grey of depth d < 8 scales by 255/(2^d - 1) (1 -> 255,
 * 2-bit 1 -> 85, 4-bit 1 -> 17), palette entries expand to their RGB,
 * alpha and tRNS are dropped (not composited), 16-bit samples keep all 16
 * bits, and a texture holds value/255 or value/65535. */
#include <criterion/criterion.h>
#include <math.h>
#include <png.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "png_read.h"
#include "rayd/scene.h"
#include "scene_assets.h"
#include "scene_limits.h"
#include "support/png_fixture.h"
#include "texture.h"

/* ---- rd_texture_sample ---------------------------------------------------- */

/* A w x h texture whose texel (i, j) channel k is (1 + i + w·j)/64 + k/256:
 * every value distinct and exact in float, and every average of two or
 * four of them exact in double. */
static rd_texture make_tex(int w, int h)
{
    rd_texture t;
    t.width = w;
    t.height = h;
    t.rgb = malloc(sizeof(float) * 3 * (size_t)w * h);
    cr_assert(t.rgb);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++)
            for (int k = 0; k < 3; k++)
                t.rgb[3 * (j * w + i) + k] = (float)((1 + i + w * j) / 64.0 + k / 256.0);
    return t;
}

static double texel(const rd_texture *t, int i, int j, int k) { return t->rgb[3 * (j * t->width + i) + k]; }

#define assert_rgb(c, r, g, b, tol, ...)                                                                               \
    cr_assert(fabs((c).x - (r)) <= (tol) && fabs((c).y - (g)) <= (tol) && fabs((c).z - (b)) <= (tol), __VA_ARGS__)

Test(texture, sample_texel_centres_are_exact)
{
    /* Power-of-two sizes: (i + 0.5)/w·w - 0.5 = i exactly, so the texel
     * itself comes back bit for bit. */
    rd_texture t = make_tex(4, 8);
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 4; i++) {
            rd_rgb c = rd_texture_sample(&t, (i + 0.5) / 4, (j + 0.5) / 8);
            assert_rgb(c, texel(&t, i, j, 0), texel(&t, i, j, 1), texel(&t, i, j, 2), 0.0,
                       "texel (%d,%d): (%.17g, %.17g, %.17g), expected (%.17g, ...)", i, j, c.x, c.y, c.z,
                       texel(&t, i, j, 0));
        }
    free(t.rgb);
    /* Other sizes: (j + 0.5)/3 is rounded, which may weigh a neighbour by
     * ~1e-16; 1e-12 allows that and nothing else (neighbours differ by >=
     * 1/64). */
    t = make_tex(5, 3);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 5; i++) {
            rd_rgb c = rd_texture_sample(&t, (i + 0.5) / 5, (j + 0.5) / 3);
            assert_rgb(c, texel(&t, i, j, 0), texel(&t, i, j, 1), texel(&t, i, j, 2), 1e-12,
                       "5x3 texel (%d,%d): %.17g, expected %.17g", i, j, c.x, texel(&t, i, j, 0));
        }
    free(t.rgb);
}

Test(texture, sample_bilinear_midpoints)
{
    rd_texture t = make_tex(4, 4);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i + 1 < 4; i++) {
            /* Halfway between (i, j) and (i+1, j). */
            rd_rgb c = rd_texture_sample(&t, (i + 1) / 4.0, (j + 0.5) / 4);
            double want[3];
            for (int k = 0; k < 3; k++)
                want[k] = (texel(&t, i, j, k) + texel(&t, i + 1, j, k)) / 2;
            assert_rgb(c, want[0], want[1], want[2], 0.0, "between (%d,%d) and (%d,%d): %.17g, expected %.17g", i, j,
                       i + 1, j, c.x, want[0]);
        }
    for (int j = 0; j + 1 < 4; j++)
        for (int i = 0; i < 4; i++) {
            /* Halfway between (i, j) and (i, j+1). */
            rd_rgb c = rd_texture_sample(&t, (i + 0.5) / 4, (j + 1) / 4.0);
            double want = (texel(&t, i, j, 1) + texel(&t, i, j + 1, 1)) / 2;
            cr_assert(c.y == want, "between (%d,%d) and (%d,%d): %.17g, expected %.17g", i, j, i, j + 1, c.y, want);
        }
    /* The corner shared by four texels: their mean. A quarter of the way:
     * weights 3/4 and 1/4. */
    rd_rgb c = rd_texture_sample(&t, 2 / 4.0, 2 / 4.0);
    double want = (texel(&t, 1, 1, 0) + texel(&t, 2, 1, 0) + texel(&t, 1, 2, 0) + texel(&t, 2, 2, 0)) / 4;
    cr_assert(c.x == want, "four-texel corner: %.17g, expected %.17g", c.x, want);
    c = rd_texture_sample(&t, (1 + 0.5 + 0.25) / 4, (2 + 0.5) / 4);
    want = 0.75 * texel(&t, 1, 2, 2) + 0.25 * texel(&t, 2, 2, 2);
    cr_assert(c.z == want, "quarter way: %.17g, expected %.17g", c.z, want);
    free(t.rgb);
}

Test(texture, sample_wrap_seam)
{
    /* u = 0 and u = 1 are both the seam: halfway between the last column
     * and the first. Likewise v = 0 and v = 1 between the last and first
     * rows. */
    rd_texture t = make_tex(4, 4);
    for (int j = 0; j < 4; j++) {
        double v = (j + 0.5) / 4;
        double want[3];
        for (int k = 0; k < 3; k++)
            want[k] = (texel(&t, 3, j, k) + texel(&t, 0, j, k)) / 2;
        rd_rgb a = rd_texture_sample(&t, 0.0, v), b = rd_texture_sample(&t, 1.0, v);
        assert_rgb(a, want[0], want[1], want[2], 0.0, "u = 0, row %d: %.17g, expected %.17g", j, a.x, want[0]);
        assert_rgb(b, want[0], want[1], want[2], 0.0, "u = 1, row %d: %.17g, expected %.17g", j, b.x, want[0]);
        /* Just inside the edges, 1/8 texel from the seam, from both sides:
         * past the last texel's centre the lookup wraps to the first
         * column. */
        rd_rgb e = rd_texture_sample(&t, 1.0 / 32, v);
        cr_assert(e.x == 0.375 * texel(&t, 3, j, 0) + 0.625 * texel(&t, 0, j, 0), "u = 1/32: %.17g", e.x);
        e = rd_texture_sample(&t, 1 - 1.0 / 32, v);
        cr_assert(e.x == 0.625 * texel(&t, 3, j, 0) + 0.375 * texel(&t, 0, j, 0), "u = 31/32: %.17g", e.x);
    }
    for (int i = 0; i < 4; i++) {
        rd_rgb e = rd_texture_sample(&t, (i + 0.5) / 4, 1 - 1.0 / 32);
        cr_assert(e.y == 0.625 * texel(&t, i, 3, 1) + 0.375 * texel(&t, i, 0, 1), "v = 31/32: %.17g", e.y);
    }
    for (int i = 0; i < 4; i++) {
        double want = (texel(&t, i, 3, 0) + texel(&t, i, 0, 0)) / 2;
        rd_rgb a = rd_texture_sample(&t, (i + 0.5) / 4, 0.0), b = rd_texture_sample(&t, (i + 0.5) / 4, 1.0);
        cr_assert(a.x == want && b.x == want, "column %d at v = 0 / 1: %.17g / %.17g, expected %.17g", i, a.x, b.x,
                  want);
    }
    free(t.rgb);
}

Test(texture, sample_negative_and_huge_coordinates_wrap)
{
    rd_texture t = make_tex(4, 4);
    /* Offsets by whole numbers that keep (i + 0.5)/4 exact. */
    double shifts[] = {-1, -3, -1024, 1, 7, 1048576, 4294967296.0, -4294967296.0, 1099511627776.0};
    for (size_t s = 0; s < sizeof shifts / sizeof *shifts; s++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                double u = (i + 0.5) / 4 + shifts[s], v = (j + 0.5) / 4 - shifts[s];
                cr_assert_eq(u - shifts[s], (i + 0.5) / 4); /* the test's own premise */
                rd_rgb c = rd_texture_sample(&t, u, v);
                assert_rgb(c, texel(&t, i, j, 0), texel(&t, i, j, 1), texel(&t, i, j, 2), 0.0,
                           "u = %.17g, v = %.17g: %.17g, expected texel (%d,%d) = %.17g", u, v, c.x, i, j,
                           texel(&t, i, j, 0));
            }
    /* Beyond 2^53 every double is an integer: the seam, and finite. */
    rd_rgb c = rd_texture_sample(&t, 1e300, -1e300);
    double want = (texel(&t, 3, 3, 0) + texel(&t, 0, 3, 0) + texel(&t, 3, 0, 0) + texel(&t, 0, 0, 0)) / 4;
    cr_assert(c.x == want, "u = 1e300: %.17g, expected the corner mean %.17g", c.x, want);
    /* Non-finite coordinates give black rather than garbage. */
    c = rd_texture_sample(&t, NAN, 0.5);
    cr_assert(isfinite(c.x) && isfinite(c.y) && isfinite(c.z));
    c = rd_texture_sample(&t, 0.5, -INFINITY);
    cr_assert(isfinite(c.x) && isfinite(c.y) && isfinite(c.z));
    free(t.rgb);
}

Test(texture, sample_v_zero_is_the_top_row)
{
    /* Row 0 of the array is the top row of the image (the PNG's first
     * row); v grows downward: small v reads row 0, v near 1 the last row. */
    rd_texture t = make_tex(2, 4);
    rd_rgb top = rd_texture_sample(&t, 0.25, 0.125), bottom = rd_texture_sample(&t, 0.25, 0.875);
    cr_assert(top.x == texel(&t, 0, 0, 0), "v = 1/8 reads %.17g, row 0 holds %.17g", top.x, texel(&t, 0, 0, 0));
    cr_assert(bottom.x == texel(&t, 0, 3, 0), "v = 7/8 reads %.17g, row 3 holds %.17g", bottom.x, texel(&t, 0, 3, 0));
    free(t.rgb);
}

/* ---- encoding PNGs in memory ----------------------------------------------- */

typedef png_bytes membuf;
#define encode_png png_fixture_encode
#define alloc_rows png_fixture_rows
#define free_rows png_fixture_free_rows

/* Decodes and checks the layout flags, then every pixel against want
 * (3 per pixel, in 0..maxval), and the texture made from the same bytes
 * against want/maxval. */
static void check_decode(const membuf *m, int w, int h, const unsigned *want, unsigned maxval, int had_alpha,
                         int was_palette, int was_grey)
{
    rd_png_image img;
    rd_error err = {0};
    rd_error_code rc = rd_png_decode(m->data, m->len, 1u << 20, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_OK, "rd_png_decode: %s", err.message);
    cr_assert(img.width == w && img.height == h, "decoded %dx%d, expected %dx%d", img.width, img.height, w, h);
    cr_assert_eq(img.maxval, maxval);
    cr_assert_eq(img.depth, maxval == 65535 ? 16 : 8);
    cr_assert_eq(img.had_alpha, had_alpha);
    cr_assert_eq(img.was_palette, was_palette);
    cr_assert_eq(img.was_grey, was_grey);
    for (int i = 0; i < w * h * 3; i++)
        cr_assert_eq(img.rgb[i], want[i], "pixel (%d,%d) channel %d: %u, expected %u", (i / 3) % w, (i / 3) / w, i % 3,
                     img.rgb[i], want[i]);
    free(img.rgb);
    rd_texture t;
    rc = rd_texture_from_png(m->data, m->len, 1u << 20, &t, &err);
    cr_assert_eq(rc, RD_OK, "rd_texture_from_png: %s", err.message);
    cr_assert(t.width == w && t.height == h);
    for (int i = 0; i < w * h * 3; i++)
        cr_assert(t.rgb[i] == (float)((double)want[i] / maxval), "texture value %d: %.9g, expected %u/%u", i, t.rgb[i],
                  want[i], maxval);
    free(t.rgb);
}

/* Distinct-ish sample values for pixel p, channel k, in 0..255. */
static unsigned val8(int p, int k) { return (unsigned)((p * 37 + k * 101 + 3) % 256); }

Test(texture, png_rgb_8bit)
{
    int w = 5, h = 3;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    unsigned want[5 * 3 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = rows[y][x * 3 + k] = (unsigned char)val8(y * w + x, k);
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 255, 0, 0, 0);
    /* The top row of the file is row 0 of the texture, read at small v. */
    rd_texture t;
    rd_error err = {0};
    cr_assert_eq(rd_texture_from_png(m.data, m.len, 100, &t, &err), RD_OK);
    rd_rgb c = rd_texture_sample(&t, 0.5 / w, 0.5 / h);
    cr_assert(c.x == (float)(want[0] / 255.0) && c.y == (float)(want[1] / 255.0),
              "texel (0,0) at the top: %.9g, expected %u/255", c.x, want[0]);
    free(t.rgb);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_rgba_drops_alpha)
{
    int w = 4, h = 3;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB_ALPHA, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 4);
    unsigned want[4 * 3 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = rows[y][x * 4 + k] = (unsigned char)val8(y * w + x, k);
            /* Alpha 0, 128 and 255: the colour must come through unchanged
             * (not multiplied, not composited on anything). */
            rows[y][x * 4 + 3] = (unsigned char)((x * 127 + y) % 256);
        }
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 255, 1, 0, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_grey_8bit)
{
    int w = 7, h = 2;
    png_layout L = {w, h, PNG_COLOR_TYPE_GRAY, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w);
    unsigned want[7 * 2 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned g = val8(y * w + x, 0);
            if (x == 0)
                g = y ? 255 : 0;
            rows[y][x] = (unsigned char)g;
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = g;
        }
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 255, 0, 0, 1);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_grey_1_2_4_bit)
{
    int depths[] = {1, 2, 4};
    for (int di = 0; di < 3; di++) {
        int d = depths[di], w = 11, h = 3; /* 11 pixels: the last byte of a row is partly padding */
        unsigned maxs = (1u << d) - 1, scale = 255 / maxs;
        png_layout L = {w, h, PNG_COLOR_TYPE_GRAY, d, 0, NULL, 0, NULL, 0, NULL};
        unsigned char **rows = alloc_rows(h, ((size_t)w * d + 7) / 8);
        unsigned want[11 * 3 * 3];
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                unsigned s = (unsigned)(x + 2 * y) % (maxs + 1);
                /* Pack most significant bits first. */
                int bit = x * d;
                rows[y][bit / 8] |= (unsigned char)(s << (8 - d - bit % 8));
                for (int k = 0; k < 3; k++)
                    want[(y * w + x) * 3 + k] = s * scale;
            }
        membuf m = encode_png(&L, rows);
        check_decode(&m, w, h, want, 255, 0, 0, 1);
        free(m.data);
        free_rows(rows, h);
    }
}

Test(texture, png_grey_alpha)
{
    int w = 3, h = 3;
    png_layout L = {w, h, PNG_COLOR_TYPE_GRAY_ALPHA, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 2);
    unsigned want[3 * 3 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned g = val8(y * w + x, 2);
            rows[y][2 * x] = (unsigned char)g;
            rows[y][2 * x + 1] = (unsigned char)(x * 100);
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = g;
        }
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 255, 1, 0, 1);
    free(m.data);
    free_rows(rows, h);
}

static const png_color test_palette[5] = {{0, 0, 0}, {255, 0, 0}, {12, 200, 34}, {1, 2, 3}, {250, 251, 252}};

Test(texture, png_palette_with_and_without_trns)
{
    int w = 6, h = 2;
    for (int with_trns = 0; with_trns < 2; with_trns++) {
        png_byte alpha[3] = {0, 128, 255};
        png_layout L = {
            w, h, PNG_COLOR_TYPE_PALETTE, 8, 0, test_palette, 5, with_trns ? alpha : NULL, with_trns ? 3 : 0, NULL};
        unsigned char **rows = alloc_rows(h, (size_t)w);
        unsigned want[6 * 2 * 3];
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                int idx = (x + 3 * y) % 5;
                rows[y][x] = (unsigned char)idx;
                want[(y * w + x) * 3 + 0] = test_palette[idx].red;
                want[(y * w + x) * 3 + 1] = test_palette[idx].green;
                want[(y * w + x) * 3 + 2] = test_palette[idx].blue;
            }
        membuf m = encode_png(&L, rows);
        check_decode(&m, w, h, want, 255, with_trns, 1, 0);
        free(m.data);
        free_rows(rows, h);
    }
}

Test(texture, png_palette_2bit)
{
    /* Packed palette indices. */
    int w = 7, h = 2;
    png_layout L = {w, h, PNG_COLOR_TYPE_PALETTE, 2, 0, test_palette, 4, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, ((size_t)w * 2 + 7) / 8);
    unsigned want[7 * 2 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int idx = (x + y) % 4, bit = 2 * x;
            rows[y][bit / 8] |= (unsigned char)(idx << (6 - bit % 8));
            want[(y * w + x) * 3 + 0] = test_palette[idx].red;
            want[(y * w + x) * 3 + 1] = test_palette[idx].green;
            want[(y * w + x) * 3 + 2] = test_palette[idx].blue;
        }
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 255, 0, 1, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_rgb_16bit_keeps_all_bits)
{
    int w = 4, h = 2;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB, 16, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 6);
    unsigned want[4 * 2 * 3];
    /* Values that an 8-bit path would merge: 0x1234 and 0x12ff, 1, 65534. */
    unsigned vals[] = {0, 1, 65534, 65535, 0x1234, 0x12ff, 0x8000, 0x7fff, 257, 256, 255, 0xabcd};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 3; k++) {
                unsigned v = vals[((y * w + x) * 3 + k) % 12];
                rows[y][x * 6 + 2 * k] = (unsigned char)(v >> 8);
                rows[y][x * 6 + 2 * k + 1] = (unsigned char)(v & 0xff);
                want[(y * w + x) * 3 + k] = v;
            }
    membuf m = encode_png(&L, rows);
    check_decode(&m, w, h, want, 65535, 0, 0, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_grey_16bit_and_rgba_16bit)
{
    int w = 3, h = 2;
    png_layout G = {w, h, PNG_COLOR_TYPE_GRAY, 16, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 2);
    unsigned want[3 * 2 * 3];
    for (int p = 0; p < w * h; p++) {
        unsigned v = 0x0101u * (unsigned)p + 0x00f0u;
        rows[p / w][2 * (p % w)] = (unsigned char)(v >> 8);
        rows[p / w][2 * (p % w) + 1] = (unsigned char)v;
        want[3 * p] = want[3 * p + 1] = want[3 * p + 2] = v;
    }
    membuf m = encode_png(&G, rows);
    check_decode(&m, w, h, want, 65535, 0, 0, 1);
    free(m.data);
    free_rows(rows, h);

    png_layout A = {w, h, PNG_COLOR_TYPE_RGB_ALPHA, 16, 0, NULL, 0, NULL, 0, NULL};
    rows = alloc_rows(h, (size_t)w * 8);
    for (int p = 0; p < w * h; p++)
        for (int k = 0; k < 4; k++) {
            unsigned v = k == 3 ? 0x1111u * (unsigned)p : 0x0f0fu * (unsigned)(p + k) + 7;
            rows[p / w][8 * (p % w) + 2 * k] = (unsigned char)(v >> 8);
            rows[p / w][8 * (p % w) + 2 * k + 1] = (unsigned char)v;
            if (k < 3)
                want[3 * p + k] = v;
        }
    m = encode_png(&A, rows);
    check_decode(&m, w, h, want, 65535, 1, 0, 0);
    free(m.data);
    free_rows(rows, h);
}

Test(texture, png_interlaced_adam7)
{
    /* 13x11 reaches every one of the seven passes with partial blocks. */
    int w = 13, h = 11;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 1, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    unsigned want[13 * 11 * 3];
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = rows[y][x * 3 + k] = (unsigned char)val8(y * w + x, k);
    membuf m = encode_png(&L, rows);
    /* It really is interlaced: IHDR's last byte. */
    cr_assert_eq(m.data[8 + 8 + 12], 1, "interlace method %d", m.data[8 + 8 + 12]);
    check_decode(&m, w, h, want, 255, 0, 0, 0);
    free(m.data);
    free_rows(rows, h);

    /* Interlaced and packed: 1-bit grey. */
    png_layout G = {w, h, PNG_COLOR_TYPE_GRAY, 1, 1, NULL, 0, NULL, 0, NULL};
    rows = alloc_rows(h, ((size_t)w + 7) / 8);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned s = (unsigned)((x * 3 + y * 5) % 7 < 3);
            rows[y][x / 8] |= (unsigned char)(s << (7 - x % 8));
            for (int k = 0; k < 3; k++)
                want[(y * w + x) * 3 + k] = s * 255;
        }
    m = encode_png(&G, rows);
    check_decode(&m, w, h, want, 255, 0, 0, 1);
    free(m.data);
    free_rows(rows, h);
}

/* ---- damaged input and limits ----------------------------------------------- */

static membuf small_png(void)
{
    int w = 6, h = 5;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w * 3; x++)
            rows[y][x] = (unsigned char)(x * 31 + y * 17);
    membuf m = encode_png(&L, rows);
    free_rows(rows, h);
    return m;
}

Test(texture, png_truncated_png_is_a_syntax_error)
{
    membuf m = small_png();
    /* Every proper prefix: mid-signature, mid-header, mid-data, without IEND. */
    for (size_t n = 0; n < m.len; n++) {
        rd_png_image img;
        rd_error err = {0};
        rd_error_code rc = rd_png_decode(m.data, n, 1u << 20, "--limit-texture-pixels", &img, &err);
        cr_assert_eq(rc, RD_ERR_SYNTAX, "%zu of %zu bytes: code %d (%s)", n, m.len, rc, err.message);
        cr_assert_null(img.rgb);
        rd_texture t;
        rc = rd_texture_from_png(m.data, n, 1u << 20, &t, &err);
        cr_assert_eq(rc, RD_ERR_SYNTAX);
        cr_assert_null(t.rgb);
    }
    /* A flipped bit in the image data fails its CRC. */
    unsigned char *bad = malloc(m.len);
    cr_assert(bad);
    memcpy(bad, m.data, m.len);
    bad[m.len - 12 - 4 - 3] ^= 0x10; /* inside IDAT, just before its CRC */
    rd_png_image img;
    rd_error err = {0};
    cr_assert_eq(rd_png_decode(bad, m.len, 1u << 20, "--limit-texture-pixels", &img, &err), RD_ERR_SYNTAX);
    free(bad);
    free(m.data);
}

Test(texture, png_not_a_png_is_a_syntax_error)
{
    const char *texts[] = {"GIF89a\x01\x00\x01\x00", "P6\n1 1\n255\n\xff\xff\xff", "\x89PNG\r\n\x1a", "",
                           "\x89PNG\r\n\x1b\n\0\0\0\rIHDR"};
    size_t lens[] = {10, 14, 7, 0, 16};
    for (size_t i = 0; i < 5; i++) {
        rd_png_image img;
        rd_error err = {0};
        rd_error_code rc =
            rd_png_decode((const unsigned char *)texts[i], lens[i], 1u << 20, "--limit-texture-pixels", &img, &err);
        cr_assert_eq(rc, RD_ERR_SYNTAX, "input %zu: code %d (%s)", i, rc, err.message);
        cr_assert_null(img.rgb);
    }
}

static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* Signature, a valid IHDR for w x h 8-bit RGB, then an IDAT whose 64 bytes
 * are not zlib data at all (with a correct CRC): decoding it would fail,
 * so a LIMIT error proves the size was judged from the header alone. */
static size_t header_only_png(unsigned char *out, uint32_t w, uint32_t h)
{
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    size_t n = 0;
    memcpy(out, sig, 8);
    n = 8;
    put32(out + n, 13);
    memcpy(out + n + 4, "IHDR", 4);
    put32(out + n + 8, w);
    put32(out + n + 12, h);
    out[n + 16] = 8; /* depth */
    out[n + 17] = 2; /* RGB */
    out[n + 18] = 0;
    out[n + 19] = 0;
    out[n + 20] = 0;
    put32(out + n + 21, (uint32_t)crc32(0, out + n + 4, 17));
    n += 25;
    put32(out + n, 64);
    memcpy(out + n + 4, "IDAT", 4);
    memset(out + n + 8, 0xA5, 64);
    put32(out + n + 72, (uint32_t)crc32(0, out + n + 4, 68));
    n += 76;
    return n;
}

Test(texture, png_over_the_pixel_limit_before_decoding)
{
    unsigned char buf[256];
    /* A real 100x100 image: 10000 pixels passes a limit of 10000, not 9999. */
    int w = 100, h = 100;
    png_layout L = {w, h, PNG_COLOR_TYPE_RGB, 8, 0, NULL, 0, NULL, 0, NULL};
    unsigned char **rows = alloc_rows(h, (size_t)w * 3);
    membuf m = encode_png(&L, rows);
    free_rows(rows, h);
    rd_png_image img;
    rd_error err = {0};
    cr_assert_eq(rd_png_decode(m.data, m.len, 10000, "--limit-texture-pixels", &img, &err), RD_OK, "%s", err.message);
    free(img.rgb);
    rd_error_code rc = rd_png_decode(m.data, m.len, 9999, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_ERR_LIMIT, "code %d (%s)", rc, err.message);
    cr_assert(strstr(err.message, "--limit-texture-pixels"), "%s", err.message);
    cr_assert_null(img.rgb);
    /* The texture loader names its own limit flag. */
    rd_texture t;
    rc = rd_texture_from_png(m.data, m.len, 9999, &t, &err);
    cr_assert_eq(rc, RD_ERR_LIMIT);
    cr_assert(strstr(err.message, rd_limit_flag(offsetof(rd_scene_limits, max_texture_pixels))), "%s", err.message);
    cr_assert_null(t.rgb);
    free(m.data);

    /* Header-only images with undecodable data. */
    size_t n = header_only_png(buf, 100, 100);
    rc = rd_png_decode(buf, n, 10000, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_ERR_SYNTAX, "the garbage IDAT must fail when within the limit: %d (%s)", rc, err.message);
    rc = rd_png_decode(buf, n, 9999, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_ERR_LIMIT, "code %d (%s)", rc, err.message);
    /* Huge declared sizes are refused at once (no attempt to allocate
     * 16 GB of pixels). */
    n = header_only_png(buf, 65536, 65536);
    rc = rd_png_decode(buf, n, 8192u * 8192u, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_ERR_LIMIT, "65536x65536: code %d (%s)", rc, err.message);
}

Test(texture, png_wide_image_over_the_limit_is_a_limit_error)
{
    /* 3,000,000 x 1 is 3M pixels, over a limit of 1M: a size limit, not a
     * damaged file, whatever width libpng itself would accept. */
    unsigned char buf[256];
    size_t n = header_only_png(buf, 3000000, 1);
    rd_png_image img;
    rd_error err = {0};
    rd_error_code rc = rd_png_decode(buf, n, 1000000, "--limit-texture-pixels", &img, &err);
    cr_assert_eq(rc, RD_ERR_LIMIT, "3000000x1 over a 1M-pixel limit: code %d (%s)", rc, err.message);
    cr_assert(strstr(err.message, "--limit-texture-pixels"), "%s", err.message);
}

Test(texture, png_limit_error_without_an_error_record)
{
    /* Like every rd_ function taking rd_error *, a NULL err must be
     * allowed (rd_error_set accepts it): the code alone comes back. */
    unsigned char buf[256];
    size_t n = header_only_png(buf, 100, 100);
    rd_png_image img;
    cr_assert_eq(rd_png_decode(buf, n, 9999, "--limit-texture-pixels", &img, NULL), RD_ERR_LIMIT);
    /* Cut inside IHDR: damaged before its size is known. (Cut later, the
     * complete header already shows the image is over the limit.) */
    cr_assert_eq(rd_png_decode(buf, 20, 9999, "--limit-texture-pixels", &img, NULL), RD_ERR_SYNTAX);
    cr_assert_eq(rd_png_decode(buf, n / 2, 9999, "--limit-texture-pixels", &img, NULL), RD_ERR_LIMIT);
}
