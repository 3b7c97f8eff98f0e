/* The compiler's messages as a student sees them (daemon/codegrade/code_diag.c). */
#include <criterion/criterion.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codegrade.h"

static const char raw[] = "In file included from /rayd/course/adapter.cpp:11:\n"
                          "/work/PhongMaterial.h: In member function 'virtual vec3 PhongMaterial::calc()':\n"
                          "/work/PhongMaterial.h:27:30: error: expected ';' before '}' token\n"
                          "   27 |         return diffuse + specular\n"
                          "/rayd/course/decl/PhongMaterial.h:3:9: warning: unused \"x\" [-Wunused]\n"
                          "/work/PhongMaterial.h:4:10: fatal error: /etc/passwd: No such file or directory\n"
                          "/tmp/ccX.s:1:1: note: a note\x01\x1b[31m\n";

Test(code_diag, paths_are_the_students_and_lines_are_parsed)
{
    rd_code_compile c = {0};
    rd_code_compile_messages(&c, raw, sizeof raw - 1);
    cr_assert_not_null(c.messages);
    cr_assert_null(strstr(c.messages, "/work/"), "%s", c.messages);
    cr_assert_null(strstr(c.messages, "/rayd/"), "%s", c.messages);
    cr_assert_null(strchr(c.messages, '\x1b'), "control bytes are replaced");
    cr_assert_not_null(strstr(c.messages, "In file included from adapter.cpp:11:"), "%s", c.messages);
    cr_assert_eq(c.ndiags, 4);
    cr_assert_str_eq(c.diags[0].file, "PhongMaterial.h");
    cr_assert_eq(c.diags[0].line, 27);
    cr_assert_eq(c.diags[0].column, 30);
    cr_assert_str_eq(c.diags[0].severity, "error");
    cr_assert_str_eq(c.diags[0].message, "expected ';' before '}' token");
    cr_assert_str_eq(c.diags[1].file, "PhongMaterial.h"); /* decl/'s, shortened alike */
    cr_assert_str_eq(c.diags[1].severity, "warning");
    cr_assert_str_eq(c.diags[2].severity, "fatal error");
    cr_assert_str_eq(c.diags[2].message, "/etc/passwd: No such file or directory");
    cr_assert_str_eq(c.diags[3].file, "ccX.s");
    free(c.messages);
    free(c.diags);
}

Test(code_diag, lines_that_are_not_diagnostics_are_only_text)
{
    static const char odd[] = "a:b:c\nx.h:0:1: error: line 0\nx.h:1:2: info: not a severity\n:1:2: error: no file\n"
                              "x.h:1:2:error: no space\nx.h:99999999999:2: error: huge line\n";
    rd_code_compile c = {0};
    rd_code_compile_messages(&c, odd, sizeof odd - 1);
    cr_assert_eq(c.ndiags, 1, "only the huge line parses (%d)", c.ndiags);
    cr_assert_eq(c.diags[0].line, 1000000, "clamped");
    free(c.messages);
    free(c.diags);
}

Test(code_diag, at_most_RD_CODE_MAX_DIAGS)
{
    char *many = malloc(200 * 40);
    size_t n = 0;
    for (int i = 0; i < 200; i++)
        n += (size_t)sprintf(many + n, "/work/a.h:%d:1: error: e%d\n", i + 1, i);
    rd_code_compile c = {0};
    rd_code_compile_messages(&c, many, n);
    cr_assert_eq(c.ndiags, RD_CODE_MAX_DIAGS);
    cr_assert_eq(c.diags[RD_CODE_MAX_DIAGS - 1].line, RD_CODE_MAX_DIAGS);
    free(c.messages);
    free(c.diags);
    free(many);
}
