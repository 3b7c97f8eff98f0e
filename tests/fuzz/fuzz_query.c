/* libFuzzer target for the query parameters of POST /v1/render
 * (daemon/http/routes_render.c): width, height, samples, max_depth, gamma, seed,
 * time_budget_ms, target_error and adaptive, as libmicrohttpd splits and
 * unescapes them. Each input is the query string of one request
 * "/v1/render?INPUT" whose body is a fixed 8x8 scene, sent over TCP to the
 * real daemon started once in this process (fuzz_http.c says what counts as
 * a failure).
 *
 * The input goes into the request line as it is, '%', '&', '=' and '+'
 * included, so escapes and separators are the fuzzer's to choose; only the
 * bytes a request line cannot hold (controls, space, '#' and bytes from
 * 0x7f up) are percent-encoded. The server's own limits keep renders cheap
 * whatever the parameters ask (16x16 pixels, 4 samples, one render thread,
 * a 4-second job timeout): what is fuzzed is reading the parameters, and
 * a render of the largest allowed size costs less than the request. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_http.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const char scene[] = "[render]\nwidth = 8\nheight = 8\nbackground = 0.05 0.05 0.1\n"
                            "[camera]\neye = 0 2.5 9\ntarget = 0 1 0\nfov = 40\n"
                            "[light key]\ntype = point\nposition = 6 10 8\ncolor = 0.8 0.8 0.8\n"
                            "[material red]\ntype = diffuse\nkd = 0.8 0.15 0.1\nambient = 0.05 0.01 0.01\n"
                            "[material floor]\ntype = diffuse\nkd = 0.7 0.7 0.7\n"
                            "[sphere]\ncenter = 0 1 0\nradius = 1\nmaterial = red\n"
                            "[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = floor\n";

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    rd_server_options o = rd_fuzz_server_options();
    o.limits.max_pixels = 16 * 16;
    rd_fuzz_server_start(&o);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char hex[] = "0123456789ABCDEF";
    char *target = malloc(sizeof "/v1/render?" + 3 * size);
    if (!target)
        return 0;
    size_t n = strlen(strcpy(target, "/v1/render?"));
    for (size_t i = 0; i < size; i++) {
        unsigned char c = data[i];
        if (c <= 0x20 || c >= 0x7f || c == '#') {
            target[n++] = '%';
            target[n++] = hex[c >> 4];
            target[n++] = hex[c & 15];
        } else {
            target[n++] = (char)c;
        }
    }
    target[n] = 0;
    rd_fuzz_request("POST", target, "text/plain", (const uint8_t *)scene, sizeof scene - 1);
    free(target);
    return 0;
}
