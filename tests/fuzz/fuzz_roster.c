/* libFuzzer target for the roster reader (api/grading/roster.c): an
 * instructor's CSV, exported by whatever spreadsheet, read whenever the
 * daemon's tables or gradebook use --roster. Any bytes must give a
 * roster that keeps its promises (sorted, unique, UTF-8 cells of at most
 * 255 bytes) or an error with its line and column, never a crash. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fuzz_check.h"

#include "roster.h"
#include "utf8.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void cell_ok(const char *s, int may_be_empty)
{
    size_t n = strlen(s);
    if (n > RD_ROSTER_CELL_MAX || (!may_be_empty && n == 0) || rd_utf8_invalid_at(s, n) != n)
        rd_fuzz_fail("a cell of %zu bytes breaks the roster's promise", n);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_roster r;
    rd_error err;
    memset(&err, 0, sizeof err);
    rd_error_code rc = rd_roster_parse((const char *)data, size, "r.csv", &r, &err);
    if (rc) {
        if (r.e || r.n)
            rd_fuzz_fail("an error left %zu entries", r.n);
        if (!err.message[0] || err.code != rc)
            rd_fuzz_fail("code %d without its message", (int)rc);
        if (rc == RD_ERR_SYNTAX && strncmp(err.message, "r.csv:", 6) != 0)
            rd_fuzz_fail("a syntax error without the file's name: '%s'", err.message);
        if (rc != RD_ERR_SYNTAX && rc != RD_ERR_LIMIT && rc != RD_ERR_NOMEM)
            rd_fuzz_fail("unexpected code %d: '%s'", (int)rc, err.message);
        return 0;
    }
    for (size_t i = 0; i < r.n; i++) {
        cell_ok(r.e[i].student, 0);
        cell_ok(r.e[i].name, 1);
        cell_ok(r.e[i].email, 1);
        if (i && strcmp(r.e[i - 1].student, r.e[i].student) >= 0)
            rd_fuzz_fail("students not sorted and unique at %zu", i);
        if (rd_roster_find(&r, r.e[i].student) != &r.e[i])
            rd_fuzz_fail("student %zu not found", i);
    }
    rd_roster_free(&r);
    return 0;
}
