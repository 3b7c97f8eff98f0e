/* An assignment's term (api/grading/term.h) and UTC times as text
 * (api/util/time_text.h): the schedule's keys, windows at their exact
 * edges, scores from the rules, which submission counts. */
#include <criterion/criterion.h>
#include <math.h>
#include <string.h>

#include "term.h"
#include "time_text.h"

#define DAY RD_TERM_DAY_MS
/* 2026-12-01T23:59:00Z */
#define DUE 1796169540000LL

static rd_term with(const char *const *kv)
{
    rd_term t = rd_term_default();
    char why[160];
    for (; *kv; kv += 2)
        cr_assert_eq(rd_term_key(&t, kv[0], kv[1], why, sizeof why), 1, "%s = %s: %s", kv[0], kv[1], why);
    return t;
}

Test(term, utc_times_read_and_written)
{
    cr_assert_eq(rd_time_parse("2026-12-01T23:59Z"), DUE);
    cr_assert_eq(rd_time_parse("2026-12-01T23:59:00Z"), DUE);
    cr_assert_eq(rd_time_parse("2026-12-01T23:59:00.000Z"), DUE);
    cr_assert_eq(rd_time_parse("2026-12-01T23:59"), DUE);
    cr_assert_eq(rd_time_parse("2026-12-01"), DUE - (23 * 60 + 59) * 60000LL);
    cr_assert_eq(rd_time_parse("1970-01-01"), 0);
    cr_assert_eq(rd_time_parse("2024-02-29"), 1709164800000LL, "a leap day");
    static const char *const bad[] = {"",
                                      "2026-13-01",
                                      "2025-02-29",
                                      "2026-12-01T24:00Z",
                                      "1969-12-31",
                                      "2026-12-01+09:00",
                                      "2026-12-01T23:59+09:00",
                                      "2026/12/01",
                                      "2026-12-1",
                                      "2026-12-01T23:59Zjunk",
                                      "12345"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        cr_assert_eq(rd_time_parse(bad[i]), -1, "'%s' was read", bad[i]);
    char buf[40];
    rd_time_text(DUE + 7, buf, sizeof buf);
    cr_assert_str_eq(buf, "2026-12-01T23:59:00.007Z");
    cr_assert_eq(rd_time_parse(buf), DUE + 7, "what is written reads back");
}

Test(term, bad_values_are_refused_with_what_was_expected)
{
    static const char *const bad[][2] = {{"due", "tomorrow"},      {"release", "2026-12-01T09:00+01:00"},
                                         {"late_days", "-1"},      {"late_penalty", "1.5"},
                                         {"points", "0"},          {"points", "nan"},
                                         {"credit", "some"},       {"counts", "first"},
                                         {"image_credit", "0.1"},  {"image_credit", "0.2:0.5 0.1:0.3"},
                                         {"image_credit", "0.1:2"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        rd_term t = rd_term_default();
        char why[160] = "";
        cr_assert_eq(rd_term_key(&t, bad[i][0], bad[i][1], why, sizeof why), -1, "%s = %s", bad[i][0], bad[i][1]);
        cr_assert(strncmp(why, "expected ", 9) == 0, "%s", why);
    }
    rd_term t = rd_term_default();
    char why[8];
    cr_assert_eq(rd_term_key(&t, "fail", "3", why, sizeof why), 0, "not a term key");
}

Test(term, windows_at_their_exact_edges)
{
    static const char *const kv[] = {"release", "2026-11-24", "due", "2026-12-01T23:59Z", "late_days", "2", NULL};
    rd_term t = with(kv);
    long long late;
    cr_assert_eq(rd_term_when(&t, t.release_ms - 1, &late), RD_TERM_NOT_RELEASED);
    cr_assert_eq(rd_term_when(&t, t.release_ms, &late), RD_TERM_ON_TIME);
    cr_assert_eq(rd_term_when(&t, DUE, &late), RD_TERM_ON_TIME, "the due instant is on time");
    cr_assert_eq(late, 0);
    cr_assert_eq(rd_term_when(&t, DUE + 1, &late), RD_TERM_LATE);
    cr_assert_eq(late, 1);
    cr_assert_eq(rd_term_late_days(late), 1, "1 ms late is a started day");
    cr_assert_eq(rd_term_when(&t, DUE + 2 * DAY, &late), RD_TERM_LATE, "the window's last instant");
    cr_assert_eq(rd_term_late_days(late), 2);
    cr_assert_eq(rd_term_when(&t, DUE + 2 * DAY + 1, &late), RD_TERM_CLOSED);
    rd_term open = rd_term_default();
    cr_assert_eq(rd_term_when(&open, 0, NULL), RD_TERM_ON_TIME, "no schedule: always on time");
    static const char *const hard[] = {"due", "2026-12-01T23:59Z", NULL};
    rd_term h = with(hard);
    cr_assert_eq(rd_term_when(&h, DUE + 1, NULL), RD_TERM_CLOSED, "no late window: late work is refused");
}

Test(term, scores_from_the_rules)
{
    rd_term all = rd_term_default();
    rd_term_outcome pass = {.graded = 1, .pass = 1}, fail = {.graded = 1, .failed_fraction = 0.004};
    cr_assert_eq(rd_term_score(&all, &pass), 1, "a pass earns the default 1 point");
    cr_assert_eq(rd_term_score(&all, &fail), 0);
    static const char *const kv[] = {"points",
                                     "10",
                                     "credit",
                                     "partial",
                                     "image_credit",
                                     "0.005:0.5 0.05:0.2",
                                     "due",
                                     "2026-12-01T23:59Z",
                                     "late_days",
                                     "3",
                                     "late_penalty",
                                     "0.1",
                                     NULL};
    rd_term t = with(kv);
    cr_assert_eq(rd_term_score(&t, &fail), 5, "0.004 within the first step");
    fail.failed_fraction = 0.005;
    cr_assert_eq(rd_term_score(&t, &fail), 5, "a step's fraction is inclusive");
    fail.failed_fraction = 0.01;
    cr_assert_eq(rd_term_score(&t, &fail), 2);
    fail.failed_fraction = 0.5;
    cr_assert_eq(rd_term_score(&t, &fail), 0, "past the last step");
    rd_term_outcome code = {.graded = 1, .code = 1, .share = 0.75, .failed_fraction = 0};
    cr_assert_eq(rd_term_score(&t, &code), 7.5, "code: its share of configurations");
    code.share = NAN;
    cr_assert_eq(rd_term_score(&t, &code), 0);
    rd_term_outcome error = {.graded = 0, .pass = 1};
    cr_assert_eq(rd_term_score(&t, &error), 0, "not graded: nothing");
    pass.late_ms = DAY + 1; /* two started days */
    cr_assert_eq(rd_term_score(&t, &pass), 8);
    pass.late_ms = 3 * DAY;
    cr_assert_eq(rd_term_score(&t, &pass), 7, "the window's last instant: three days");
    pass.late_ms = 3 * DAY + 1;
    cr_assert_eq(rd_term_score(&t, &pass), 0, "after the window: nothing");
    rd_term_outcome late_code = {.graded = 1, .code = 1, .share = 0.1, .late_ms = 2 * DAY};
    cr_assert_eq(rd_term_score(&t, &late_code), 0, "never below 0");
}

Test(term, which_submission_counts)
{
    rd_term_entry e[] = {{100, 5, 0}, {300, 2, 0}, {200, 9, 0}, {400, 10, 1}};
    cr_assert_eq(rd_term_pick(RD_COUNTS_LATEST, e, 4), 1, "the latest not closed");
    cr_assert_eq(rd_term_pick(RD_COUNTS_BEST, e, 4), 2, "the best not closed");
    rd_term_entry tie[] = {{100, 5, 0}, {200, 5, 0}};
    cr_assert_eq(rd_term_pick(RD_COUNTS_BEST, tie, 2), 1, "of equal scores the later");
    rd_term_entry closed[] = {{100, 5, 1}};
    cr_assert_eq(rd_term_pick(RD_COUNTS_LATEST, closed, 1), -1, "a closed one never counts");
    cr_assert_eq(rd_term_pick(RD_COUNTS_LATEST, NULL, 0), -1);
}
