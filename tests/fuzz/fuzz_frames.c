/* libFuzzer target for what the code grader reads back from its sandbox
 * (daemon/codegrade/code_read.c, code_diag.c): the evaluator's frames on
 * fd 3, which the student's code shares the sandbox with and may have
 * written anything into, and the compiler's messages, which quote the
 * student's file. The first four bytes of an input are the count of
 * values expected, the rest the frames. Properties: every pointer the
 * reader gives stays inside the input, a values frame is taken only with
 * the expected count, and the messages come back no longer than they
 * were, with each diagnostic's file named and its line and column
 * positive. */
#include <stdlib.h>
#include <string.h>

#include "code_frames.h"
#include "codegrade.h"
#include "fuzz_check.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void inside(const uint8_t *data, size_t size, const void *p, size_t len, const char *what)
{
    const uint8_t *b = p;
    if (p && (b < data || b + len > data + size))
        rd_fuzz_fail("%s points outside the input", what);
}

static void check_messages(const char *text, size_t len)
{
    rd_code_compile c = {0};
    rd_code_compile_messages(&c, text, len);
    if (!c.messages || !c.diags)
        return; /* out of memory: nothing to check */
    /* (a student's own text may still spell a sandbox path once its inner
     * copy is dropped: that shows nothing the student did not write) */
    if (strlen(c.messages) > len)
        rd_fuzz_fail("the shortened messages are longer than the compiler's");
    if (c.ndiags < 0 || c.ndiags > RD_CODE_MAX_DIAGS)
        rd_fuzz_fail("%d diagnostics", c.ndiags);
    for (int i = 0; i < c.ndiags; i++)
        if (c.diags[i].line < 1 || c.diags[i].column < 1 || !c.diags[i].file[0] ||
            !memchr(c.diags[i].message, 0, sizeof c.diags[i].message))
            rd_fuzz_fail("diagnostic %d is malformed", i);
    free(c.messages);
    free(c.diags);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 4)
        return 0;
    uint32_t expect;
    memcpy(&expect, data, 4);
    expect %= 4096;
    rd_code_frames f;
    rd_code_read_frames(data + 4, size - 4, expect, &f);
    inside(data, size, f.messages, f.messages_len, "the messages");
    inside(data, size, f.printed, f.printed_len, "the output");
    inside(data, size, f.note, f.note_len, "the note");
    if (f.values) {
        if (f.vhead.count != expect)
            rd_fuzz_fail("values taken with count %u, %u expected", f.vhead.count, expect);
        inside(data, size, f.values, (size_t)expect * sizeof(rd_frame_value), "the values");
        for (size_t i = 0; i < expect; i++)
            (void)rd_code_frame_value(&f, i);
    }
    if (f.has_compile)
        check_messages(f.messages, f.messages_len);
    return 0;
}
