/* The roster reader (api/grading/roster.h): columns by their header in any
 * order, RFC 4180 quoting, a byte order mark, and every fault with its
 * line and column. */
#include <criterion/criterion.h>
#include <string.h>

#include "roster.h"

static rd_error_code parse(const char *text, rd_roster *r, rd_error *err)
{
    memset(err, 0, sizeof *err);
    return rd_roster_parse(text, strlen(text), "class.csv", r, err);
}

Test(roster, columns_by_their_header_quoting_and_a_byte_order_mark)
{
    rd_roster r;
    rd_error err;
    const char *text = "\xEF\xBB\xBF"
                       "email,section,student,name\r\n"
                       "zoe@example.org,A,zoe,\"Zoe \"\"Z\"\" Smith\"\r\n"
                       "\r\n"
                       ",B,\"smith, j\",\"Smith,\nJ\"\n"
                       "yamada@example.jp,A,\xE5\xB1\xB1\xE7\x94\xB0,\xE5\xB1\xB1\xE7\x94\xB0 \xE5\xA4\xAA\xE9\x83\x8E";
    cr_assert_eq(parse(text, &r, &err), RD_OK, "%s", err.message);
    cr_assert_eq(r.n, 3);
    cr_assert_str_eq(r.e[0].student, "smith, j", "sorted by student in byte order");
    cr_assert_str_eq(r.e[0].name, "Smith,\nJ");
    cr_assert_str_eq(r.e[0].email, "");
    cr_assert_str_eq(r.e[1].student, "zoe");
    cr_assert_str_eq(r.e[1].name, "Zoe \"Z\" Smith");
    cr_assert_str_eq(r.e[2].email, "yamada@example.jp");
    cr_assert(rd_roster_find(&r, "zoe") == &r.e[1]);
    cr_assert_null(rd_roster_find(&r, "zo"));
    rd_roster_free(&r);
    cr_assert_eq(parse("student,name\r\n", &r, &err), RD_OK, "a header alone: no student");
    cr_assert(r.n == 0 && rd_roster_find(&r, "ann") == NULL);
    rd_roster_free(&r);
    cr_assert_eq(parse("student\nann\n", &r, &err), RD_OK, "only the student column");
    cr_assert_str_eq(r.e[0].name, "");
    rd_roster_free(&r);
}

Test(roster, faults_have_their_line_and_column)
{
    static const struct {
        const char *text;
        int line, column;
        const char *says;
    } cases[] = {
        {"", 1, 1, "empty"},
        {"name,email\nann,a@x\n", 1, 1, "no 'student' column"},
        {"student,name\nann,\"Ann\n", 2, 5, "not closed"},
        {"student,name\nann,\"Ann\" B\n", 2, 10, "after a quoted cell"},
        {"student,name\nann,A\"nn\n", 2, 6, "a quote inside"},
        {"student,name\nann,A\n,B\n", 3, 1, "without a student id"},
        {"student\nab\xff\n", 2, 1, "not UTF-8"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rd_roster r;
        rd_error err;
        cr_assert_eq(parse(cases[i].text, &r, &err), RD_ERR_SYNTAX, "case %zu", i);
        cr_assert(strstr(err.message, cases[i].says), "case %zu: %s", i, err.message);
        cr_assert_eq(err.line, cases[i].line, "case %zu: %s", i, err.message);
        cr_assert_eq(err.column, cases[i].column, "case %zu: %s", i, err.message);
        cr_assert(strncmp(err.message, "class.csv:", 10) == 0, "%s", err.message);
        cr_assert_null(r.e);
    }
    rd_roster r;
    rd_error err;
    cr_assert_eq(parse("student\nann\nbob\nann\n", &r, &err), RD_ERR_SYNTAX);
    cr_assert(strstr(err.message, "'ann' is listed twice"), "%s", err.message);
    char big[400] = "student\n";
    memset(big + 8, 'x', 300);
    cr_assert_eq(parse(big, &r, &err), RD_ERR_SYNTAX);
    cr_assert(strstr(err.message, "longer than 255 bytes"), "%s", err.message);
}
