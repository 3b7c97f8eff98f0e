/* libFuzzer target for the upload archive reader (api/archive/archive.c):
 * instructors upload a class's images as one .zip or .tar.gz, so any bytes
 * must give files or an error, never a crash or a leak, and must cost what
 * the limits allow, never what a header declares: run.sh runs this target
 * with a malloc limit, so one allocation beyond it is a crash (an "oom-"
 * file), whether the reader or libarchive made it.
 *
 * Checked beyond "no crash", on every input: each delivered name is a
 * reduced base name as archive.h promises (1 to RD_ARCHIVE_NAME_MAX bytes
 * of UTF-8, no separator, no control character, not hidden, not "." or
 * ".."); each file is within max_entry_bytes and all of them within
 * max_total_bytes and max_entries; every byte of each file is read (so
 * AddressSanitizer sees a buffer shorter than its length); a failure's code
 * is one the header lists, the error holds it with a message, and a limit
 * error names its limit. The callback stops the reading at the third file
 * when that file's length is a multiple of 7, and the callback's code must
 * come back as is.
 *
 * libarchive, zlib and libc are the system's, built without coverage
 * instrumentation, so libFuzzer sees only the reader's own branches. As in
 * fuzz_png.c, each distinct outcome (libarchive's reason without the entry
 * name, the limit passed, the number of files) bumps a counter of its own
 * in libFuzzer's extra-counter section, which it treats as coverage, so
 * inputs that end differently are kept and mutated further. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_check.h"

#include "archive.h"
#include "utf8.h"

/* The daemon's limits are larger; these reach every path (a 64 KiB input
 * of deflated zeros inflates to 64 MB, past both byte limits) and keep
 * each input within milliseconds. */
static const rd_archive_limits LIMITS = {64, (size_t)1 << 20, (size_t)4 << 20};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

__attribute__((section("__libfuzzer_extra_counters"), used)) static uint8_t outcomes[1 << 12];

/* FNV-1a of text, then of a few small numbers. */
static void outcome(const char *text, unsigned a, unsigned b)
{
    uint32_t h = 2166136261u;
    for (const char *p = text; *p; p++)
        h = (h ^ (unsigned char)*p) * 16777619u;
    unsigned more[2] = {a, b};
    for (int i = 0; i < 2; i++)
        h = (h ^ more[i]) * 16777619u;
    outcomes[h % sizeof outcomes]++;
}

/* The reason at the end of a message ("damaged archive at 'NAME': ..."):
 * the name comes from the input and would make every name a new outcome. */
static const char *reason(const char *message)
{
    const char *r = message;
    for (const char *p = strstr(message, ": "); p; p = strstr(p + 1, ": "))
        r = p + 2;
    return r;
}

typedef struct {
    size_t files, total;
    uint32_t sum; /* of every byte delivered: each one is read */
    int stopped;
} seen;

static rd_error_code each(void *user, const char *name, int utf8, const unsigned char *data, size_t len, rd_error *err)
{
    (void)utf8; /* the name is UTF-8 either way */
    seen *s = user;
    if (!name || !data)
        rd_fuzz_fail("file %zu: name %p, data %p", s->files, (const void *)name, (const void *)data);
    size_t n = strlen(name);
    if (n == 0 || n > RD_ARCHIVE_NAME_MAX)
        rd_fuzz_fail("file %zu: a name of %zu bytes", s->files, n);
    if (rd_utf8_invalid_at(name, n) != n)
        rd_fuzz_fail("file %zu: name '%s' is not UTF-8 at byte %zu", s->files, name, rd_utf8_invalid_at(name, n));
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)name[i];
        if (c == '/' || c == '\\' || c < 0x20 || c == 0x7f)
            rd_fuzz_fail("file %zu: name '%s' holds byte 0x%02x", s->files, name, c);
    }
    if (name[0] == '.' || strcmp(name, "__MACOSX") == 0)
        rd_fuzz_fail("file %zu: hidden name '%s' delivered", s->files, name);
    if (len > LIMITS.max_entry_bytes)
        rd_fuzz_fail("file '%s': %zu bytes, over max_entry_bytes %zu", name, len, LIMITS.max_entry_bytes);
    s->files++;
    s->total += len;
    if (s->files > LIMITS.max_entries)
        rd_fuzz_fail("%zu files, over max_entries %zu", s->files, LIMITS.max_entries);
    if (s->total > LIMITS.max_total_bytes)
        rd_fuzz_fail("%zu bytes in all, over max_total_bytes %zu", s->total, LIMITS.max_total_bytes);
    for (size_t i = 0; i < len; i++)
        s->sum = s->sum * 31u + data[i];
    if (s->files == 3 && len % 7 == 0) {
        s->stopped = 1;
        return rd_error_set(err, RD_ERR_CANCELLED, 0, 0, "stopped by the callback");
    }
    return RD_OK;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Exactly size bytes: AddressSanitizer catches a read past the end. */
    unsigned char *copy = malloc(size ? size : 1);
    if (!copy)
        return 0;
    if (size)
        memcpy(copy, data, size);
    seen s = {0};
    rd_error err;
    rd_fuzz_error_init(&err);
    rd_error_code rc = rd_archive_each(copy, size, &LIMITS, each, &s, &err);
    unsigned files = s.files < 8 ? (unsigned)s.files : 8;
    if (s.stopped) {
        if (rc != RD_ERR_CANCELLED || strcmp(err.message, "stopped by the callback") != 0)
            rd_fuzz_fail("the callback stopped the reading, rd_archive_each returned %d ('%s')", (int)rc, err.message);
        outcome("stopped", files, 0);
    } else if (rc == RD_OK) {
        outcome("ok", files, 0);
    } else {
        if (rc != RD_ERR_SYNTAX && rc != RD_ERR_UNSUPPORTED && rc != RD_ERR_LIMIT && rc != RD_ERR_NOMEM)
            rd_fuzz_fail("unexpected code %d ('%s')", (int)rc, err.message);
        if (err.code != rc)
            rd_fuzz_fail("returned code %d, the error holds %d ('%s')", (int)rc, (int)err.code, err.message);
        if (!err.message[0])
            rd_fuzz_fail("code %d without a message", (int)rc);
        if (rc == RD_ERR_LIMIT) {
            static const char *const names[] = {"max_entries", "max_entry_bytes", "max_total_bytes"};
            int which = -1;
            for (int i = 0; i < 3; i++)
                if (strstr(err.message, names[i]))
                    which = i;
            if (which < 0)
                rd_fuzz_fail("a limit error must name its limit: '%s'", err.message);
            outcome(names[which], files, 0);
        } else {
            outcome(reason(err.message), (unsigned)rc, files);
        }
    }
    free(copy);
    return 0;
}
