/* PNG files built in memory for the tests of the PNG reader and textures:
 * a growing byte buffer (for chunks written by hand) and libpng's encoder
 * for images of any layout. Failures fail the current Criterion test. */
#ifndef RD_TEST_PNG_FIXTURE_H
#define RD_TEST_PNG_FIXTURE_H

#include <png.h>
#include <stddef.h>

typedef struct {
    unsigned char *data; /* malloc'ed; the test frees it */
    size_t len, cap;
} png_bytes;

/* Appends n bytes. */
void png_bytes_put(png_bytes *b, const void *p, size_t n);

typedef struct {
    int width, height, color_type, depth, interlace;
    const png_color *palette;
    int npalette;
    const png_byte *trns; /* palette alpha */
    int ntrns;
    const png_color_16 *trns_colour; /* grey or RGB transparency; may be NULL */
} png_layout;

/* Rows exactly as PNG stores them (packed below 8 bits, big-endian at 16),
 * encoded by libpng. */
png_bytes png_fixture_encode(const png_layout *L, unsigned char **rows);

/* h zeroed rows of bytes_per_row bytes, and their release. */
unsigned char **png_fixture_rows(int h, size_t bytes_per_row);
void png_fixture_free_rows(unsigned char **rows, int h);

#endif
