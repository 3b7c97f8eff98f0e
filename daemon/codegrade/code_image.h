/* The image with the student's function (codegrade.c's steps 2 and 4):
 * what the renderer asks a material of the graded type is recorded as
 * queries in one render, and answered from the student's values in a
 * second. Both renders take one thread, so the calls come in the same
 * order; each answer is checked to be for the same call. */
#ifndef RD_CODE_IMAGE_H
#define RD_CODE_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "code_frames.h"
#include "rayd/error.h"
#include "rayd/scene.h"

/* A material's parameters as the adapter takes them. */
rayd_code_material rd_code_material_of(const rd_material *m);

/* Appends to *q (n of them, capacity *cap) every call the render of s
 * makes to a material of type t, at most max. s is modified while it
 * runs and restored. RD_ERR_LIMIT past max; render errors. */
rd_error_code rd_code_record(rd_scene *s, rd_material_type t, size_t max, rd_code_query **q, size_t *n, size_t *cap,
                             rd_error *err);

/* Renders s with the calls to type t answered by values (n of them, for
 * the queries q that rd_code_record gave), into malloc'ed 8-bit RGB.
 * *mismatched counts calls that were not the recorded ones (answered 0). */
rd_error_code rd_code_replay(rd_scene *s, rd_material_type t, const rd_code_query *q, const rd_frame_value *values,
                             size_t n, uint8_t **rgb, int *w, int *h, size_t *mismatched, rd_error *err);

#endif
