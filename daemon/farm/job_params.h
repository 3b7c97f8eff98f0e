/* What a render request asks for besides its scene: the render section's
 * overrides, the progressive settings and whether to keep an EXR. Read
 * from an HTTP query one parameter at a time, and kept with a stored job
 * as a query text of its own, so that whichever daemon renders the job
 * reads it back exactly as the one that accepted it did. */
#ifndef RD_JOB_PARAMS_H
#define RD_JOB_PARAMS_H

#include "rayd/error.h"
#include "rayd/progress.h"
#include "scene_overrides.h"

typedef struct {
    rd_scene_overrides ov;
    rd_progress_settings progress; /* max_samples is the scene's, set when it is read */
    int hdr;
    char query[1024]; /* the parameters given, as name=value&...; every value is one the readers accept */
} rd_job_params;

/* The parameters a request may give, by index from 0 until NULL: the
 * overrides of scene_overrides.h, then time_budget_ms, target_error,
 * adaptive, hdr. */
const char *rd_job_param_name(int i);

void rd_job_params_init(rd_job_params *p);

/* Reads parameter name (one rd_job_param_name gives) into p and appends it
 * to p->query. RD_ERR_SYNTAX naming "query parameter NAME" for a bad
 * value; RD_ERR_NOT_FOUND for a name that is not a parameter. */
rd_error_code rd_job_params_set(rd_job_params *p, const char *name, const char *value, rd_error *err);

/* Reads a query text written by rd_job_params_set back into p (initialised
 * here). Errors as rd_job_params_set's, and RD_ERR_LIMIT for a text longer
 * than p->query holds. */
rd_error_code rd_job_params_parse(rd_job_params *p, const char *query, rd_error *err);

#endif
