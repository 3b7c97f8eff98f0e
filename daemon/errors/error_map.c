#include "error_map.h"

static const rd_error_answer answers[RD_ERROR_COUNT] = {
    [RD_OK] = {200, "ok", RD_EXIT_OK, 0, NULL},
    [RD_ERR_SYNTAX] = {400, "parse_error", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_INVALID] = {422, "invalid_scene", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_LIMIT] = {413, "too_large", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_IO] = {422, "missing_file", RD_EXIT_IO, 0, NULL},
    [RD_ERR_NOMEM] = {503, "unavailable", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_CANCELLED] = {503, "cancelled", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_TIMEOUT] = {422, "time_limit", RD_EXIT_SCENE, 0, NULL},
    [RD_ERR_BUSY] = {503, "queue_full", RD_EXIT_SCENE, 1, NULL},
    [RD_ERR_NOT_FOUND] = {404, "not_found", RD_EXIT_USAGE, 0, NULL},
    [RD_ERR_UNSUPPORTED] = {415, "unsupported_media_type", RD_EXIT_SCENE, 0, NULL},
    /* Only the job store meets these in the daemon. */
    [RD_ERR_NOSPACE] = {507, "store_full", RD_EXIT_IO, 30, "the job store has no space left to write: free some"},
    [RD_ERR_DAMAGED] = {503, "store_damaged", RD_EXIT_IO, 30,
                        "the job store is damaged: an operator must repair or restore it"},
    /* The job store's unless a stage says otherwise (rd_code_error_answer:
     * the sandbox's). */
    [RD_ERR_UNAVAILABLE] = {503, "store_unavailable", RD_EXIT_IO, 5, "the job store is unreachable; try again shortly"},
};

rd_error_answer rd_error_answer_for(rd_error_code c)
{
    return (unsigned)c < RD_ERROR_COUNT ? answers[c] : answers[RD_ERR_NOMEM];
}

rd_error_answer rd_grade_error_answer(rd_grade_stage stage, rd_error_code c)
{
    rd_error_answer a = rd_error_answer_for(c);
    /* An assignment the server holds that does not load is not the
     * client's malformed input: 422, whatever the parser said. */
    if (stage == RD_GRADE_STAGE_ASSIGNMENT &&
        (c == RD_ERR_SYNTAX || c == RD_ERR_INVALID || c == RD_ERR_IO || c == RD_ERR_LIMIT)) {
        a.http = 422;
        a.code = "bad_assignment";
    }
    if (stage == RD_GRADE_STAGE_IMAGE && c == RD_ERR_INVALID) {
        a.http = 422;
        a.code = "size_mismatch";
    }
    if (stage == RD_GRADE_STAGE_IMAGE && c == RD_ERR_SYNTAX) {
        a.http = 422;
        a.code = "bad_image";
    }
    return a;
}

rd_error_answer rd_code_error_answer(rd_grade_stage stage, rd_error_code c)
{
    if (stage != RD_GRADE_STAGE_NONE)
        return rd_grade_error_answer(stage, c);
    rd_error_answer a = rd_error_answer_for(c);
    if (c == RD_ERR_INVALID)
        a = (rd_error_answer){422, "bad_code", RD_EXIT_SCENE, 0, NULL};
    /* A sandbox that cannot start here will not start in a minute either. */
    if (c == RD_ERR_UNAVAILABLE)
        a = (rd_error_answer){503, "sandbox_unavailable", RD_EXIT_IO, 3600, NULL};
    return a;
}
