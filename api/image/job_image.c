#include "job_image.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hdr_write.h"

void rd_job_image_free(rd_job_image *im)
{
    free(im->png);
    free(im->exr);
    memset(im, 0, sizeof *im);
}

rd_error_code rd_job_image_encode(rd_job *core, const rd_png_options *opt, int exr, rd_job_image *out, rd_error *err)
{
    memset(out, 0, sizeof *out);
    int w = rd_job_width(core), h = rd_job_height(core);
    uint8_t *rgb = malloc((size_t)w * (size_t)h * 3);
    if (!rgb)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory assembling a %dx%d image", w, h);
    rd_job_rgb8(core, rgb);
    rd_error_code rc = rd_png_encode(rgb, w, h, opt, &out->png, &out->png_len, err);
    free(rgb);
    if (!rc && exr) {
        rd_image img;
        rd_job_take_image(core, &img);
        rc = rd_exr_encode(&img, &out->exr, &out->exr_len, err);
        rd_image_free(&img);
    }
    if (rc)
        rd_job_image_free(out);
    return rc;
}
