/* libFuzzer target for the cfg reader (api/scene/cfg_parse.c): scene text comes
 * from untrusted users through the CLI and the HTTP API, so any byte string
 * must give either a scene or an error, never a crash, hang or leak. A scene
 * that parses must also survive rd_scene_write_cfg/_json and back unchanged
 * (fuzz_check.c), which exercises the writers on every odd scene the fuzzer
 * can build and catches readers and writers that disagree.
 *
 * No I/O: libFuzzer runs this millions of times in one process, and files
 * or output would make it slow and its results depend on the machine. */
#include <stddef.h>
#include <stdint.h>

#include "cfg_parse.h"
#include "fuzz_check.h"

/* The name messages must start with; also what the daemon would pass. */
#define SOURCE "<fuzz>"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_scene_limits lim = rd_fuzz_limits();
    rd_scene s;
    rd_error err;
    rd_scene_init(&s);
    rd_fuzz_error_init(&err);
    /* data is exactly size bytes, not NUL-terminated: AddressSanitizer
     * catches a reader that runs past the end. */
    rd_error_code rc = rd_cfg_parse((const char *)data, size, SOURCE, &lim, &s, &err);
    if (rc == RD_OK) {
        /* Also on the daemon's path after every parse; pure arithmetic. */
        rd_fuzz_error_init(&err);
        rc = rd_scene_check_limits(&s, &lim, SOURCE, &err);
        if (rc)
            rd_fuzz_check_error(rc, &err, SOURCE);
        rd_fuzz_check_roundtrip(&s);
    } else {
        rd_fuzz_check_error(rc, &err, SOURCE);
    }
    /* The header says free it either way: a partly filled scene after an
     * error must not leak (LeakSanitizer reports it). */
    rd_scene_free(&s);
    return 0;
}
