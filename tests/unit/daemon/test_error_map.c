/* daemon/errors: every code of RD_ERRORS has one answer, and "unavailable"
 * is answered as the service that is: the job store's by default, the
 * sandbox's for a code grade. */
#include <criterion/criterion.h>
#include <string.h>

#include "error_map.h"

Test(error_map, every_code_has_an_answer_with_a_json_code)
{
    for (int c = 0; c < RD_ERROR_COUNT; c++) {
        rd_error_answer a = rd_error_answer_for((rd_error_code)c);
        cr_assert(a.code && *a.code, "%s has no JSON code", rd_error_name((rd_error_code)c));
        cr_assert(a.http >= 200 && a.http < 600, "%s: %u", rd_error_name((rd_error_code)c), a.http);
        cr_assert(c == RD_OK || a.http >= 400, "%s is an error answered %u", rd_error_name((rd_error_code)c), a.http);
        cr_assert_neq(a.http, 500, "%s is answered 500", rd_error_name((rd_error_code)c));
    }
}

Test(error_map, unavailable_is_the_store_s_503_with_retry_after)
{
    rd_error_answer a = rd_error_answer_for(RD_ERR_UNAVAILABLE);
    cr_assert_eq(a.http, 503);
    cr_assert_str_eq(a.code, "store_unavailable");
    cr_assert_eq(a.retry_after, 5);
    cr_assert(a.lead && strstr(a.lead, "unreachable"), "%s", a.lead ? a.lead : "(none)");
    cr_assert_eq(a.exit, RD_EXIT_IO);
    cr_assert_str_eq(rd_error_name(RD_ERR_UNAVAILABLE), "unavailable");
}

Test(error_map, unavailable_in_a_code_grade_is_the_sandbox_s)
{
    rd_error_answer a = rd_code_error_answer(RD_GRADE_STAGE_NONE, RD_ERR_UNAVAILABLE);
    cr_assert_eq(a.http, 503);
    cr_assert_str_eq(a.code, "sandbox_unavailable");
    cr_assert_gt(a.retry_after, 0);
    cr_assert_eq(a.exit, RD_EXIT_IO);
}

/* A missing file stays the client's 422, never a 503. */
Test(error_map, io_is_a_missing_file_not_unavailable)
{
    rd_error_answer a = rd_error_answer_for(RD_ERR_IO);
    cr_assert_eq(a.http, 422);
    cr_assert_str_eq(a.code, "missing_file");
    cr_assert_eq(a.retry_after, 0);
    a = rd_code_error_answer(RD_GRADE_STAGE_NONE, RD_ERR_IO);
    cr_assert_str_eq(a.code, "missing_file");
}

Test(error_map, store_faults_keep_their_codes_and_say_what_to_do)
{
    rd_error_answer full = rd_error_answer_for(RD_ERR_NOSPACE), damaged = rd_error_answer_for(RD_ERR_DAMAGED);
    cr_assert(full.http == 507 && strcmp(full.code, "store_full") == 0 && full.retry_after == 30);
    cr_assert(damaged.http == 503 && strcmp(damaged.code, "store_damaged") == 0 && damaged.retry_after == 30);
    cr_assert(full.lead && strstr(full.lead, "no space left"));
    cr_assert(damaged.lead && strstr(damaged.lead, "damaged"));
    cr_assert_eq(rd_error_answer_for(RD_ERR_BUSY).retry_after, 1);
}
