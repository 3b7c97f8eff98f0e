/* libFuzzer target for the JSON reader (api/scene/json_parse.c, on top of cJSON):
 * scene text comes from untrusted users through the CLI and the HTTP API,
 * so any byte string must give either a scene or an error, never a crash,
 * hang or leak. A scene that parses must also survive
 * rd_scene_write_cfg/_json and back unchanged (fuzz_check.c), which
 * exercises the writers on every odd scene the fuzzer can build and catches
 * readers and writers that disagree.
 * What is checked is rd_fuzz_scene_text's (fuzz_check.c), shared with
 * the other scene reader's target.
 *
 * No I/O: libFuzzer runs this millions of times in one process, and files
 * or output would make it slow and its results depend on the machine. */
#include <stddef.h>
#include <stdint.h>

#include "fuzz_check.h"
#include "json_parse.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_fuzz_scene_text(data, size, rd_json_parse);
    return 0;
}
