/* Properties the fuzz targets check beyond "does not crash". Shared by
 * fuzz_cfg.c and fuzz_json.c so both formats are held to the same rules
 * whichever reader produced the scene.
 *
 * Every check aborts (after one explanatory line on stderr) when it fails:
 * abort() is what libFuzzer records as a crash and minimises, so a broken
 * property is reported exactly like a memory error. */
#ifndef RD_FUZZ_CHECK_H
#define RD_FUZZ_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"

/* The first parse of fuzz input. -max_len in run.sh is 65536 too: a bigger
 * limit would only let the fuzzer spend time on inputs it never generates,
 * and a smaller one would turn most large inputs into a cheap limit error. */
#define RD_FUZZ_MAX_BYTES 65536

/* Limits for the first parse: the defaults with max_bytes above. */
rd_scene_limits rd_fuzz_limits(void);

/* One line "fuzz property failed: ..." on stderr, then abort(): what
 * libFuzzer records as a crash. Every target's property checks use it. */
void rd_fuzz_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

/* An rd_error that shows whether the parser filled it in. */
void rd_fuzz_error_init(rd_error *err);

/* After a failed parse: the error must say what went wrong (spec: "a clear
 * error"), with the same code the parser returned, starting with the
 * source name that was passed in. */
void rd_fuzz_check_error(rd_error_code rc, const rd_error *err, const char *source);

/* After a successful parse: for cfg and for JSON, writes s, parses the text
 * again and requires (scene_write.h's contract) that it parses with no
 * error, gives a scene equal to s field for field, and writes the identical
 * text again. rd_scene_write_cfg may refuse only a scene holding a name or
 * string with '"', CR or LF, as scene_write.h documents. */
void rd_fuzz_check_roundtrip(const rd_scene *s);

/* One scene reader's target (fuzz_cfg.c, fuzz_json.c): parse data (exactly
 * size bytes, not NUL-terminated, so AddressSanitizer catches a reader that
 * runs past the end) named "<fuzz>"; a scene must pass the limit check's
 * rules and the round trip, an error must be well formed, and the scene is
 * freed either way (LeakSanitizer catches a partly filled scene that
 * leaks). */
typedef rd_error_code (*rd_fuzz_reader)(const char *text, size_t len, const char *source, const rd_scene_limits *lim,
                                        rd_scene *s, rd_error *err);
void rd_fuzz_scene_text(const uint8_t *data, size_t size, rd_fuzz_reader parse);

#endif
