#include "archive.h"

#include <archive.h>
#include <archive_entry.h>
#include <errno.h>
#include <locale.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "utf8.h"

/* What one archive_read_data call asks for at most: the size of the blocks
 * memory grows by, whatever an entry declares. */
#define BLOCK ((size_t)64 * 1024)

typedef struct {
    struct archive *a;
    const rd_archive_limits *lim;
    unsigned char *buf; /* the file being read; grows with what was read */
    size_t cap;
    size_t total; /* decompressed bytes of every entry so far, <= lim->max_total_bytes */
} reader;

/* ---- names ---------------------------------------------------------------- */

static int is_sep(char c) { return c == '/' || c == '\\'; }

/* 1 when the component [p, p + n) hides the entry: __MACOSX, or a name
 * starting with '.' that is not "." or "..". */
static int hides(const char *p, size_t n)
{
    if (n == 8 && memcmp(p, "__MACOSX", 8) == 0)
        return 1;
    if (n == 0 || p[0] != '.')
        return 0;
    return !(n == 1 || (n == 2 && p[1] == '.'));
}

/* Reduces path to the name the callback gets (archive.h): out holds it,
 * NUL-terminated, and *utf8 says whether its bytes were UTF-8. Returns 1
 * for a name, 0 for an entry to skip (hidden, or a name that reduces to
 * nothing). */
static int reduce_name(const char *path, char out[RD_ARCHIVE_NAME_MAX + 1], int *utf8)
{
    out[0] = '\0';
    *utf8 = 1;
    if (!path)
        return 0;
    const char *base = NULL;
    size_t base_len = 0;
    for (const char *p = path; *p;) {
        while (is_sep(*p))
            p++;
        const char *start = p;
        while (*p && !is_sep(*p))
            p++;
        size_t n = (size_t)(p - start);
        if (hides(start, n))
            return 0;
        if (n > 0)
            base = start, base_len = n;
    }
    if (!base || (base_len == 1 && base[0] == '.') || (base_len == 2 && base[0] == '.' && base[1] == '.'))
        return 0;
    *utf8 = rd_utf8_readable(base, base_len, out, RD_ARCHIVE_NAME_MAX + 1);
    return 1;
}

/* ---- errors --------------------------------------------------------------- */

/* libarchive's failure as code (RD_ERR_SYNTAX or RD_ERR_UNSUPPORTED), or
 * RD_ERR_NOMEM when it ran out of memory. */
static rd_error_code failed(struct archive *a, rd_error_code code, const char *name, rd_error *err)
{
    const char *why = archive_error_string(a);
    if (!why)
        why = "unknown error";
    if (archive_errno(a) == ENOMEM)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory reading the archive: %s", why);
    if (code == RD_ERR_UNSUPPORTED)
        return rd_error_set(err, code, 0, 0, "not a zip or tar archive (.zip, .tar, .tar.gz): %s", why);
    if (name && name[0])
        return rd_error_set(err, code, 0, 0, "damaged archive at '%s': %s", name, why);
    return rd_error_set(err, code, 0, 0, "damaged archive: %s", why);
}

/* ---- reading -------------------------------------------------------------- */

/* 1 unless the current entry is a zip entry neither stored nor deflated.
 * libarchive says which method only in the format name it sets for each
 * entry ("ZIP 2.0 (deflation)"). The other methods' decoders take their
 * memory from the archive: an LZMA header of a few bytes asks for a 4 GB
 * dictionary, allocated when reading starts. */
static int zip_method_read(struct archive *a)
{
    if ((archive_format(a) & ARCHIVE_FORMAT_BASE_MASK) != ARCHIVE_FORMAT_ZIP)
        return 1;
    const char *name = archive_format_name(a);
    size_t n = name ? strlen(name) : 0;
    static const char *const ok[] = {"(uncompressed)", "(deflation)"};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        size_t k = strlen(ok[i]);
        if (n >= k && strcmp(name + n - k, ok[i]) == 0)
            return 1;
    }
    return 0;
}

/* Makes room for need bytes in r->buf, growing by doubling but never past
 * bound (need <= bound). */
static rd_error_code reserve(reader *r, size_t need, size_t bound, rd_error *err)
{
    if (need <= r->cap)
        return RD_OK;
    size_t cap = r->cap > SIZE_MAX / 2 ? SIZE_MAX : r->cap * 2;
    if (cap < need)
        cap = need;
    if (cap > bound)
        cap = bound;
    unsigned char *p = realloc(r->buf, cap);
    if (!p)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory reading the archive (%zu bytes)", cap);
    r->buf = p;
    r->cap = cap;
    return RD_OK;
}

/* Reads the current entry's data to its end, counting it against
 * max_total_bytes and, when keep, against max_entry_bytes too; keeps it in
 * r->buf (*len bytes) when keep, else reads it block by block over the
 * same first block. name is for messages. */
static rd_error_code read_data(reader *r, const char *name, int keep, size_t *len, rd_error *err)
{
    const rd_archive_limits *lim = r->lim;
    size_t n_read = 0;
    for (;;) {
        size_t room_total = lim->max_total_bytes - r->total;
        size_t room_entry = keep ? lim->max_entry_bytes - n_read : SIZE_MAX;
        size_t room = room_entry < room_total ? room_entry : room_total;
        /* One byte past the room tells a file that ends at the limit from
         * one that goes on. */
        size_t want = room < BLOCK ? room + 1 : BLOCK;
        size_t at = keep ? n_read : 0;
        size_t bound = keep && lim->max_entry_bytes < SIZE_MAX ? lim->max_entry_bytes + 1 : SIZE_MAX;
        if (!keep)
            bound = BLOCK > r->cap ? BLOCK : r->cap;
        rd_error_code rc = reserve(r, at + want, bound, err);
        if (rc != RD_OK)
            return rc;
        la_ssize_t got = archive_read_data(r->a, r->buf + at, want);
        if (got == 0)
            break;
        if (got < 0)
            return failed(r->a, RD_ERR_SYNTAX, name, err);
        if ((size_t)got > room) {
            if (room_entry <= room_total)
                return rd_error_set(err, RD_ERR_LIMIT, 0, 0,
                                    "archive file '%s' holds more than %zu decompressed bytes (max_entry_bytes)", name,
                                    lim->max_entry_bytes);
            return rd_error_set(err, RD_ERR_LIMIT, 0, 0,
                                "archive holds more than %zu decompressed bytes in all (max_total_bytes)",
                                lim->max_total_bytes);
        }
        n_read += (size_t)got;
        r->total += (size_t)got;
    }
    *len = n_read;
    return RD_OK;
}

/* Every entry in turn; the archive is open. */
static rd_error_code read_entries(reader *r, rd_archive_file_fn each, void *user, rd_error *err)
{
    static const unsigned char no_bytes[1];
    const rd_archive_limits *lim = r->lim;
    size_t max_headers = lim->max_entries > (SIZE_MAX - 1024) / 4 ? SIZE_MAX : lim->max_entries * 4 + 1024;
    size_t headers = 0, files = 0;
    char name[RD_ARCHIVE_NAME_MAX + 1];
    for (;;) {
        struct archive_entry *e;
        int st = archive_read_next_header(r->a, &e);
        if (st == ARCHIVE_EOF)
            return RD_OK;
        /* ARCHIVE_WARN: read, with a remark (a name in another charset). */
        if (st != ARCHIVE_OK && st != ARCHIVE_WARN)
            return failed(r->a, RD_ERR_SYNTAX, NULL, err);
        if (++headers > max_headers)
            return rd_error_set(err, RD_ERR_LIMIT, 0, 0,
                                "archive holds more than %zu entries of all kinds (4 x max_entries + 1024)",
                                max_headers);
        const char *path = archive_entry_pathname_utf8(e);
        if (!path)
            path = archive_entry_pathname(e);
        int utf8 = 1;
        int named = reduce_name(path, name, &utf8);
        /* A name libarchive could not convert at all (flagged UTF-8 and
         * not): delivered all the same, under a name that says so. */
        if (!path && st == ARCHIVE_WARN) {
            snprintf(name, sizeof name, "(unreadable name %zu)", files + 1);
            named = 1, utf8 = 0;
        }
        /* Everything else (folders too: a tar may give one data) is read
         * all the same, to count its bytes. */
        int deliver =
            named && archive_entry_filetype(e) == AE_IFREG && !archive_entry_hardlink(e) && !archive_entry_symlink(e);
        if (archive_entry_is_encrypted(e))
            return rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0, "archive file '%s' is encrypted: not supported",
                                named ? name : "?");
        if (!zip_method_read(r->a))
            return rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0,
                                "archive file '%s' is compressed as %s: only stored and deflated zip files are read",
                                named ? name : "?", archive_format_name(r->a));
        if (deliver && files >= lim->max_entries)
            return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "archive holds more than %zu files (max_entries)",
                                lim->max_entries);
        size_t len = 0;
        rd_error_code rc = read_data(r, named ? name : "?", deliver, &len, err);
        if (rc != RD_OK)
            return rc;
        if (!deliver)
            continue;
        files++;
        rc = each(user, name, utf8, len ? r->buf : no_bytes, len, err);
        if (rc != RD_OK)
            return rc;
    }
}

/* rd_archive_each once the arguments are checked, in the UTF-8 locale. */
static rd_error_code read_archive(const void *data, size_t len, const rd_archive_limits *lim, rd_archive_file_fn each,
                                  void *user, rd_error *err)
{
    reader r = {.a = archive_read_new(), .lim = lim};
    if (!r.a)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory reading the archive");
    rd_error_code rc = RD_OK;
    /* gzip through zlib only: ARCHIVE_WARN would mean an external gzip
     * program, which is not run here. */
    if (archive_read_support_format_zip(r.a) != ARCHIVE_OK || archive_read_support_format_tar(r.a) != ARCHIVE_OK ||
        archive_read_support_filter_gzip(r.a) != ARCHIVE_OK) {
        rc = rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0, "libarchive here cannot read zip, tar or gzip (no zlib?)");
    } else if (archive_read_open_memory(r.a, data, len) != ARCHIVE_OK) {
        /* Opening sniffs the filters and the format: "Unrecognized archive
         * format" (errno ARCHIVE_ERRNO_FILE_FORMAT, libarchive's private
         * name for EILSEQ on Linux) is an input that is no zip and no tar;
         * anything else is one whose first bytes are damaged (a gzip
         * stream cut short). */
        rc = failed(r.a, archive_errno(r.a) == EILSEQ ? RD_ERR_UNSUPPORTED : RD_ERR_SYNTAX, NULL, err);
    } else {
        rc = read_entries(&r, each, user, err);
    }
    archive_read_free(r.a);
    free(r.buf);
    return rc;
}

rd_error_code rd_archive_each(const void *data, size_t len, const rd_archive_limits *lim, rd_archive_file_fn each,
                              void *user, rd_error *err)
{
    if (!lim || !each)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "rd_archive_each: no %s", lim ? "callback" : "limits");
    if (!data && len > 0)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "rd_archive_each: NULL data of %zu bytes", len);
    if (len == 0)
        return rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0, "not a zip or tar archive (.zip, .tar, .tar.gz): empty");
    /* libarchive converts names to the thread's LC_CTYPE charset, fixed when
     * the reader is made: in the C locale a zip name flagged UTF-8 that is
     * not ASCII has no name at all. This thread reads in C.UTF-8, and the
     * process's locale is left alone. */
    locale_t c_utf8 = newlocale(LC_CTYPE_MASK, "C.UTF-8", (locale_t)0);
    if (!c_utf8)
        return rd_error_set(err, errno == ENOMEM ? RD_ERR_NOMEM : RD_ERR_UNSUPPORTED, 0, 0,
                            "cannot read archive names as UTF-8: no C.UTF-8 locale here");
    locale_t was = uselocale(c_utf8);
    rd_error_code rc = read_archive(data, len, lim, each, user, err);
    uselocale(was);
    freelocale(c_utf8);
    return rc;
}
