#include "job_status.h"

#include <cJSON.h>

#include "json_text.h"

char *rd_job_status_json(const rd_job_status *s)
{
    int failed = 0;
    cJSON *o = cJSON_CreateObject();
    rd_json_add(o, "id", cJSON_CreateString(s->id), &failed);
    rd_json_add(o, "status", cJSON_CreateString(rd_jq_status_name(s->status)), &failed);
    rd_json_add(o, "progress", cJSON_CreateNumber(s->progress), &failed);
    rd_json_add(o, "elapsed_ms", cJSON_CreateNumber(s->elapsed_ms), &failed);
    rd_json_add(o, "queued_ms", cJSON_CreateNumber(s->queued_ms), &failed);
    rd_json_add(o, "width", cJSON_CreateNumber(s->width), &failed);
    rd_json_add(o, "height", cJSON_CreateNumber(s->height), &failed);
    /* A queued job has spent nothing yet, and a cancelled or failed one
     * keeps what it had only in the samples and the curve. */
    unsigned parts = s->status == RD_JQ_DONE      ? RD_STATS_COSTS | RD_STATS_NESTED | RD_STATS_STOPPED
                     : s->status == RD_JQ_RUNNING ? RD_STATS_COSTS | RD_STATS_NESTED
                                                  : 0;
    if (!failed && rd_stats_json(o, &s->stats, parts))
        failed = 1;
    if (s->status == RD_JQ_FAILED) {
        cJSON *e = rd_json_add(o, "error", cJSON_CreateObject(), &failed);
        rd_json_add(e, "code", cJSON_CreateString(s->error_code), &failed);
        rd_json_add(e, "message", cJSON_CreateString(s->error_message), &failed);
    }
    char *text = failed ? NULL : cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return text;
}
