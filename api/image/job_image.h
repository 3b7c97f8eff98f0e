/* A finished render's image as clients take it, the same for a job of the
 * queue and a stored job: the 8-bit PNG and, when asked for, the linear
 * image as EXR.
 *
 * Errors are values (err filled); on an error nothing is left allocated.
 * Ownership: the buffers are malloc'ed for the caller, freed with
 * rd_job_image_free. */
#ifndef RD_JOB_IMAGE_H
#define RD_JOB_IMAGE_H

#include <stddef.h>

#include "png_write.h"
#include "rayd/error.h"
#include "rayd/job.h"

typedef struct {
    unsigned char *png, *exr; /* exr NULL unless asked for */
    size_t png_len, exr_len;
} rd_job_image;

/* Encodes the core's image. With exr the linear pixels are moved out of
 * the core (rd_job_take_image): call it last. */
rd_error_code rd_job_image_encode(rd_job *core, const rd_png_options *opt, int exr, rd_job_image *out, rd_error *err);

void rd_job_image_free(rd_job_image *im);

#endif
