/* The evaluator's frames as the daemon reads them: the sandbox's data,
 * which the student's code could have written too. */
#include <string.h>

#include "code_frames.h"

static void take(rd_code_frames *f, uint32_t type, const unsigned char *p, size_t len, size_t expect)
{
    if (type == RD_FRAME_COMPILE && !f->has_compile && len >= sizeof f->compile) {
        memcpy(&f->compile, p, sizeof f->compile);
        f->has_compile = 1;
        f->messages = (const char *)p + sizeof f->compile;
        f->messages_len = len - sizeof f->compile;
    } else if (type == RD_FRAME_VALUES && !f->values && len >= sizeof f->vhead) {
        rd_frame_values h;
        memcpy(&h, p, sizeof h);
        if (h.count == expect && (len - sizeof h) / sizeof(rd_frame_value) == expect &&
            (len - sizeof h) % sizeof(rd_frame_value) == 0) {
            f->vhead = h;
            f->values = p + sizeof h;
        }
    } else if (type == RD_FRAME_OUTPUT && !f->has_output && len >= sizeof f->output) {
        memcpy(&f->output, p, sizeof f->output);
        f->has_output = 1;
        f->printed = (const char *)p + sizeof f->output;
        f->printed_len = len - sizeof f->output;
    } else if (type == RD_FRAME_NOTE && !f->note) {
        f->note = (const char *)p;
        f->note_len = len;
    }
}

void rd_code_read_frames(const unsigned char *data, size_t len, size_t expect, rd_code_frames *f)
{
    memset(f, 0, sizeof *f);
    for (size_t i = 0; data && len - i >= sizeof(rd_frame_header);) {
        rd_frame_header h;
        memcpy(&h, data + i, sizeof h);
        i += sizeof h;
        if (h.len > len - i)
            break;
        take(f, h.type, data + i, h.len, expect);
        i += h.len;
    }
}

rd_frame_value rd_code_frame_value(const rd_code_frames *f, size_t i)
{
    rd_frame_value v = {RD_VALUE_NOT_RUN, 0, {0, 0, 0}};
    if (f->values && i < f->vhead.count)
        memcpy(&v, f->values + i * sizeof v, sizeof v);
    return v;
}
