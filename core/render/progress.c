#include "rayd/progress.h"

const char *rd_stop_reason_name(rd_stop_reason r)
{
    switch (r) {
    case RD_STOP_SAMPLES: return "samples";
    case RD_STOP_TIME_BUDGET: return "time_budget";
    case RD_STOP_TARGET_ERROR: return "target_error";
    case RD_STOP_CANCELLED: return "cancelled";
    default: return "none";
    }
}

int rd_progress_is_progressive(const rd_progress_settings *p) { return p->time_budget_ms > 0 || p->target_error > 0; }

int rd_progress_next(const rd_progress_settings *p, int done, int spp, double last_pass_ms, int last_pass_spp,
                     double elapsed_ms, double error, rd_stop_reason *why)
{
    int cap = p->max_samples < 1 ? 1 : p->max_samples;
    *why = RD_STOP_NONE;
    if (!rd_progress_is_progressive(p)) {
        if (done == 0)
            return cap;
        *why = RD_STOP_SAMPLES;
        return 0;
    }
    if (spp >= cap) {
        *why = RD_STOP_SAMPLES;
        return 0;
    }
    int next = done == 0 ? 2 : spp;
    if (next < 1)
        next = 1;
    if (next > cap - spp)
        next = cap - spp;
    if (done > 0 && p->target_error > 0 && spp >= 2 && error <= p->target_error) {
        *why = RD_STOP_TARGET_ERROR;
        return 0;
    }
    if (done > 0 && p->time_budget_ms > 0) {
        double per_sample = last_pass_spp > 0 ? last_pass_ms / last_pass_spp : 0;
        double left = p->time_budget_ms - elapsed_ms;
        if (left <= 0 || (per_sample > 0 && per_sample > left)) {
            *why = RD_STOP_TIME_BUDGET;
            return 0;
        }
        /* A doubled pass that would not fit shrinks to what the budget has
         * room for, instead of leaving the rest of the budget unused. */
        if (per_sample > 0 && per_sample * next > left)
            next = (int)(left / per_sample);
        if (next < 1) {
            *why = RD_STOP_TIME_BUDGET;
            return 0;
        }
    }
    return next;
}
