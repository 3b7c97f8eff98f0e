/* libFuzzer target for POST /v1/grade (daemon/http/routes_grade.c): a student's
 * multipart form with an image and an assignment name or a scene, read by
 * libmicrohttpd's form parser and the daemon's field callback, then graded.
 * Each input is the body of one request with
 * "Content-Type: multipart/form-data; boundary=XyZ", sent over TCP to the
 * real daemon started once in this process (fuzz_http.c says what counts as
 * a failure).
 *
 * The limits keep every input cheap without closing a route: the bundled
 * 320x240 assignments still load, so images reach the PNG decoder and the
 * size check, but a posted scene is refused above 320x240 pixels, 4
 * samples or 2000 objects, and one render thread with a 4-second job
 * timeout bounds the rest (an answer is due within 8 s). Run it from the
 * repository root: the assignments are read from scenes/assignments. */
#include <stddef.h>
#include <stdint.h>

#include "fuzz_http.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    rd_server_options o = rd_fuzz_server_options();
    o.limits.max_pixels = 320 * 240;
    o.limits.max_objects = 2000;
    o.limits.max_texture_pixels = 256 * 256;
    o.max_body_bytes = 1u << 20;
    rd_fuzz_server_start(&o);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rd_fuzz_request("POST", "/v1/grade", "multipart/form-data; boundary=XyZ", data, size);
    return 0;
}
