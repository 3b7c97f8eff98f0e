/* Reading uploaded archives (api/archive/archive.h). Every archive is built
 * here, in memory, with libarchive's own writer (zip, pax tar, and pax tar
 * through gzip), so the bytes are exactly what real tools write; only the
 * tests of lying headers and of a NUL in a name patch a written zip
 * afterwards. Costs are measured, not inferred, as in test_png_limits.c:
 * Criterion runs every test in a process of its own, so the peak resident
 * set (ru_maxrss) and the peak address space (VmPeak) grow only with what
 * that test allocated. */
#include <archive.h>
#include <archive_entry.h>
#include <criterion/criterion.h>
#include <locale.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "archive.h"
#include "support/fault_alloc.h"
#include "support/rng.h"
#include "utf8.h"

TestSuite(archive, .timeout = 60);

/* ---- writing archives ------------------------------------------------------ */

typedef enum { ZIP, TAR, TGZ } format;
#define FORMATS 3
static const char *const format_names[FORMATS] = {"zip", "tar", "tar.gz"};

typedef struct {
    unsigned char *p;
    size_t len, cap;
} membuf;

typedef struct {
    struct archive *a;
    membuf out;
    format f;
} writer;

static la_ssize_t mem_write(struct archive *a, void *user, const void *buf, size_t n)
{
    (void)a;
    membuf *m = user;
    if (m->len + n > m->cap) {
        size_t cap = (m->len + n) * 2;
        unsigned char *p = realloc(m->p, cap);
        cr_assert_not_null(p);
        m->p = p;
        m->cap = cap;
    }
    memcpy(m->p + m->len, buf, n);
    m->len += n;
    return (la_ssize_t)n;
}

/* options: libarchive's writer options ("zip:hdrcharset=UTF-8"), or NULL. */
static void w_open_with(writer *w, format f, const char *options)
{
    memset(w, 0, sizeof *w);
    w->f = f;
    w->a = archive_write_new();
    cr_assert_not_null(w->a);
    int st = f == ZIP ? archive_write_set_format_zip(w->a) : archive_write_set_format_pax_restricted(w->a);
    cr_assert_eq(st, ARCHIVE_OK, "%s", archive_error_string(w->a));
    if (f == TGZ)
        cr_assert_eq(archive_write_add_filter_gzip(w->a), ARCHIVE_OK, "%s", archive_error_string(w->a));
    if (options)
        cr_assert_eq(archive_write_set_options(w->a, options), ARCHIVE_OK, "%s", archive_error_string(w->a));
    /* As zip and gzip tools write them; a tar keeps tar's 10240-byte
     * blocks. */
    if (f != TAR)
        cr_assert_eq(archive_write_set_bytes_in_last_block(w->a, 1), ARCHIVE_OK);
    cr_assert_eq(archive_write_open(w->a, &w->out, NULL, mem_write, NULL), ARCHIVE_OK, "%s",
                 archive_error_string(w->a));
}

static void w_open(writer *w, format f) { w_open_with(w, f, NULL); }

/* One entry of any type; a regular file gets len bytes of data, or len
 * zero bytes when data is NULL (written a block at a time: never len
 * bytes in memory). */
static void w_entry(writer *w, const char *path, mode_t type, const void *data, size_t len, const char *symlink,
                    const char *hardlink)
{
    struct archive_entry *e = archive_entry_new();
    cr_assert_not_null(e);
    archive_entry_copy_pathname(e, path);
    archive_entry_set_filetype(e, type);
    archive_entry_set_perm(e, type == AE_IFDIR ? 0755 : 0644);
    if (type == AE_IFREG && !hardlink)
        archive_entry_set_size(e, (la_int64_t)len);
    if (symlink)
        archive_entry_copy_symlink(e, symlink);
    if (hardlink)
        archive_entry_copy_hardlink(e, hardlink);
    if (type == AE_IFCHR)
        archive_entry_set_rdev(e, 0x0103);
    /* ARCHIVE_WARN: a name the C locale cannot call UTF-8, written as is. */
    int st = archive_write_header(w->a, e);
    cr_assert_geq(st, ARCHIVE_WARN, "%s: writing '%s': %s", format_names[w->f], path, archive_error_string(w->a));
    if (type == AE_IFREG && !hardlink) {
        static const unsigned char zeros[64 * 1024];
        for (size_t done = 0; done < len;) {
            size_t n = len - done < sizeof zeros ? len - done : sizeof zeros;
            const void *from = data ? (const unsigned char *)data + done : zeros;
            la_ssize_t k = archive_write_data(w->a, from, n);
            cr_assert_eq(k, (la_ssize_t)n, "%s: data of '%s': %s", format_names[w->f], path,
                         archive_error_string(w->a));
            done += n;
        }
    }
    archive_entry_free(e);
}

static void w_file(writer *w, const char *path, const void *data, size_t len)
{
    w_entry(w, path, AE_IFREG, data, len, NULL, NULL);
}

static membuf w_close(writer *w)
{
    cr_assert_eq(archive_write_close(w->a), ARCHIVE_OK, "%s", archive_error_string(w->a));
    archive_write_free(w->a);
    return w->out;
}

/* ---- reading them ---------------------------------------------------------- */

#define KEEP 64

typedef struct {
    int calls;
    char names[KEEP][RD_ARCHIVE_NAME_MAX + 1];
    int utf8[KEEP];            /* the callback's flag: the stored name was UTF-8 */
    unsigned char *data[KEEP]; /* copies, when keep */
    size_t len[KEEP];
    uint64_t hash[KEEP]; /* FNV-1a of each file, kept without allocating */
    size_t max_len, total;
    int keep;
    int stop_after; /* return stop_code from that call (1-based) */
    rd_error_code stop_code;
} got;

static uint64_t fnv(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static rd_error_code collect(void *user, const char *name, int utf8, const unsigned char *data, size_t len,
                             rd_error *err)
{
    got *g = user;
    cr_assert_not_null(name);
    cr_assert_not_null(data, "data is never NULL, even for %zu bytes", len);
    cr_assert_leq(strlen(name), RD_ARCHIVE_NAME_MAX);
    cr_assert_eq(rd_utf8_invalid_at(name, strlen(name)), strlen(name), "the name '%s' is not UTF-8", name);
    if (g->calls < KEEP) {
        snprintf(g->names[g->calls], sizeof g->names[0], "%s", name);
        g->utf8[g->calls] = utf8;
        g->len[g->calls] = len;
        g->hash[g->calls] = fnv(data, len);
        if (g->keep) {
            g->data[g->calls] = malloc(len ? len : 1);
            cr_assert_not_null(g->data[g->calls]);
            memcpy(g->data[g->calls], data, len);
        }
    }
    g->calls++;
    g->total += len;
    if (len > g->max_len)
        g->max_len = len;
    if (g->stop_after && g->calls == g->stop_after)
        return rd_error_set(err, g->stop_code, 0, 0, "the callback stopped at '%s'", name);
    return RD_OK;
}

static void got_free(got *g)
{
    for (int i = 0; i < KEEP; i++)
        free(g->data[i]);
}

static const rd_archive_limits wide = {1000, (size_t)64 << 20, (size_t)256 << 20};

static rd_error_code run(const membuf *m, const rd_archive_limits *lim, got *g, rd_error *err)
{
    memset(err, 0, sizeof *err);
    rd_error_code rc = rd_archive_each(m->p, m->len, lim, collect, g, err);
    if (rc != RD_OK) {
        cr_assert_eq(err->code, rc, "returned %s, the error holds %s", rd_error_name(rc), rd_error_name(err->code));
        cr_assert(err->message[0], "%s without a message", rd_error_name(rc));
    }
    return rc;
}

static void fill_random(unsigned char *p, size_t n, uint64_t seed)
{
    test_rng g = {seed};
    for (size_t i = 0; i < n; i++)
        p[i] = (unsigned char)rng_u64(&g);
}

/* ---- files, names and bytes ------------------------------------------------ */

Test(archive, every_file_delivered_with_its_name_and_bytes)
{
    /* Sizes around the 64 KiB block the reader asks for at a time. */
    static const size_t sizes[] = {0, 1, 1000, 65535, 65536, 65537, 200000};
    static const char *const names[] = {"empty.png", "one.png", "a.png", "b.png", "c.png", "d.png", "big.png"};
    enum { N = sizeof sizes / sizeof sizes[0] };
    unsigned char *content[N];
    for (int i = 0; i < N; i++) {
        content[i] = malloc(sizes[i] + 1);
        fill_random(content[i], sizes[i], 100 + (uint64_t)i);
    }
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        for (int i = 0; i < N; i++)
            w_file(&w, names[i], content[i], sizes[i]);
        membuf m = w_close(&w);
        got g = {.keep = 1};
        rd_error err;
        rd_error_code rc = run(&m, &wide, &g, &err);
        cr_assert_eq(rc, RD_OK, "%s: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, N, "%s: %d calls", format_names[f], g.calls);
        for (int i = 0; i < N; i++) {
            cr_assert_str_eq(g.names[i], names[i], "%s: file %d", format_names[f], i);
            cr_assert_eq(g.len[i], sizes[i], "%s: %s has %zu bytes", format_names[f], names[i], g.len[i]);
            cr_assert(memcmp(g.data[i], content[i], sizes[i]) == 0, "%s: %s differs", format_names[f], names[i]);
        }
        got_free(&g);
        free(m.p);
    }
    for (int i = 0; i < N; i++)
        free(content[i]);
}

Test(archive, folders_dropped_and_base_names_delivered)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        w_entry(&w, "class/", AE_IFDIR, NULL, 0, NULL, NULL);
        w_entry(&w, "class/s1/", AE_IFDIR, NULL, 0, NULL, NULL);
        w_file(&w, "class/s1/phong.png", "one", 3);
        w_entry(&w, "class/s2/", AE_IFDIR, NULL, 0, NULL, NULL);
        w_file(&w, "class/s2/phong.png", "two", 3);
        w_file(&w, "top.png", "three", 5);
        membuf m = w_close(&w);
        got g = {.keep = 1};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 3, "%s: %d calls", format_names[f], g.calls);
        cr_assert_str_eq(g.names[0], "phong.png");
        cr_assert_str_eq(g.names[1], "phong.png", "names are not made unique");
        cr_assert_str_eq(g.names[2], "top.png");
        cr_assert(g.len[0] == 3 && memcmp(g.data[0], "one", 3) == 0);
        cr_assert(g.len[1] == 3 && memcmp(g.data[1], "two", 3) == 0);
        cr_assert(g.len[2] == 5 && memcmp(g.data[2], "three", 5) == 0);
        got_free(&g);
        free(m.p);
    }
}

Test(archive, links_devices_and_hidden_entries_skipped)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        w_file(&w, "a.png", "A", 1);
        w_entry(&w, "link.png", AE_IFLNK, NULL, 0, "a.png", NULL);
        w_entry(&w, "up.png", AE_IFLNK, NULL, 0, "../../etc/passwd", NULL);
        if (f != ZIP) { /* zip has no hard links, devices or FIFOs */
            w_entry(&w, "hard.png", AE_IFREG, NULL, 0, NULL, "a.png");
            w_entry(&w, "tty.png", AE_IFCHR, NULL, 0, NULL, NULL);
            w_entry(&w, "fifo.png", AE_IFIFO, NULL, 0, NULL, NULL);
        }
        w_file(&w, "__MACOSX/._a.png", "apple double", 12);
        w_file(&w, "._b.png", "apple double", 12);
        w_file(&w, ".DS_Store", "finder", 6);
        w_file(&w, "class/.git/objects/ab", "git", 3);
        w_file(&w, "class/__MACOSX/c.png", "c", 1);
        w_file(&w, "class/.hidden/d.png", "d", 1);
        w_file(&w, "...", "dots", 4);
        w_file(&w, "class/./e.png", "E", 1);
        membuf m = w_close(&w);
        got g = {.keep = 1};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 2, "%s: %d calls, the second '%s'", format_names[f], g.calls, g.names[1]);
        cr_assert_str_eq(g.names[0], "a.png");
        cr_assert(g.len[0] == 1 && g.data[0][0] == 'A');
        cr_assert_str_eq(g.names[1], "e.png", "'.' is no hidden folder");
        got_free(&g);
        free(m.p);
    }
}

Test(archive, hostile_names_reduced_to_bounded_base_names)
{
    char long_ascii[1001], long_utf8[601], deep[20001];
    memset(long_ascii, 'x', 1000);
    memcpy(long_ascii + 996, ".png", 4);
    long_ascii[1000] = '\0';
    for (int i = 0; i < 300; i++)
        memcpy(long_utf8 + 2 * i, "\xc3\xa9", 2); /* é, 2 bytes */
    long_utf8[600] = '\0';
    for (int i = 0; i < 10000; i++)
        memcpy(deep + 2 * i, "d/", 2);
    memcpy(deep + 19994, "z.png", 6);
    /* The bound cuts at a character: 255 bytes of x, 127 two-byte é. */
    char want_ascii[RD_ARCHIVE_NAME_MAX + 1], want_utf8[RD_ARCHIVE_NAME_MAX + 1];
    snprintf(want_ascii, sizeof want_ascii, "%.255s", long_ascii);
    snprintf(want_utf8, sizeof want_utf8, "%.254s", long_utf8);
    struct {
        const char *path, *want; /* want NULL: skipped */
    } cases[] = {
        {"../../etc/passwd", "passwd"},
        {"/abs/olute.png", "olute.png"},
        {"C:\\Users\\me\\win.png", "win.png"},
        {"a/../b.png", "b.png"},
        {"./c.png", "c.png"},
        {"ctl\x01\x1f\x7f.png", "ctl___.png"},
        {"\xff\xfe.png", "%FF%FE.png"},
        {"caf\xc3\xa9.png", "caf\xc3\xa9.png"},
        {"\xc3.png", "%C3.png"},
        {"x/..", NULL},
        {"..", NULL},
        {long_ascii, want_ascii},
        {long_utf8, want_utf8},
        {deep, "z.png"},
    };
    enum { N = sizeof cases / sizeof cases[0] };
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        for (int i = 0; i < N; i++) {
            char body[8];
            snprintf(body, sizeof body, "%d", i);
            w_file(&w, cases[i].path, body, strlen(body));
        }
        membuf m = w_close(&w);
        got g = {.keep = 1};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        int k = 0;
        for (int i = 0; i < N; i++) {
            if (!cases[i].want)
                continue;
            cr_assert_lt(k, g.calls, "%s: %d calls", format_names[f], g.calls);
            char body[8];
            snprintf(body, sizeof body, "%d", i);
            cr_assert(g.len[k] == strlen(body) && memcmp(g.data[k], body, g.len[k]) == 0,
                      "%s: call %d ('%s') is not case %d", format_names[f], k, g.names[k], i);
            cr_assert_str_eq(g.names[k], cases[i].want, "%s: case %d: '%.40s'", format_names[f], i, g.names[k]);
            k++;
        }
        cr_assert_eq(k, g.calls, "%s: %d calls, %d expected", format_names[f], g.calls, k);
        got_free(&g);
        free(m.p);
    }
}

/* How many of the zip's local headers have general-purpose bit 11, "the
 * name is UTF-8", set: how Python's zipfile, 7-Zip, Windows and macOS
 * write a name that is not ASCII (an ASCII name is not flagged). */
static int zip_names_flagged_utf8(const membuf *m)
{
    int flagged = 0;
    for (size_t i = 0; i + 30 <= m->len; i++)
        flagged += memcmp(m->p + i, "PK\3\4", 4) == 0 && (m->p[i + 7] & 0x08) != 0;
    return flagged;
}

/* A class's names as a zip tool writes them, flagged UTF-8, read in a
 * process whose locale is C (rayd never calls setlocale): every file is
 * delivered under its UTF-8 name, flagged UTF-8, and the process's locale
 * is still C afterwards. The writer needs a UTF-8 locale (its own thread's)
 * to flag the names. */
Test(archive, zip_names_flagged_utf8_read_in_the_c_locale)
{
    static const char *const names[] = {"m\xc3\xbcller.png", "Jos\xc3\xa9.png", "\xe6\x9d\x8e\xe9\x9b\xb7.png",
                                        "zo\xc3\xab.png", "bob.png"};
    enum { N = sizeof names / sizeof names[0] };
    locale_t c_utf8 = newlocale(LC_CTYPE_MASK, "C.UTF-8", (locale_t)0);
    cr_assert_not_null(c_utf8);
    locale_t was = uselocale(c_utf8);
    writer w;
    w_open_with(&w, ZIP, "zip:hdrcharset=UTF-8");
    for (int i = 0; i < N; i++)
        w_file(&w, names[i], names[i], strlen(names[i]));
    membuf m = w_close(&w);
    uselocale(was);
    freelocale(c_utf8);
    int flagged = zip_names_flagged_utf8(&m);
    cr_assert_eq(flagged, N - 1, "%d of the test zip's %d names that are not ASCII are flagged UTF-8", flagged, N - 1);
    cr_assert_str_eq(setlocale(LC_CTYPE, NULL), "C");
    got g = {.keep = 1};
    rd_error err;
    cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s", err.message);
    cr_assert_eq(g.calls, N, "%d of %d files delivered", g.calls, N);
    for (int i = 0; i < N; i++) {
        cr_assert_str_eq(g.names[i], names[i]);
        cr_assert(g.utf8[i], "'%s' not called UTF-8", g.names[i]);
        cr_assert(g.len[i] == strlen(names[i]) && memcmp(g.data[i], names[i], g.len[i]) == 0, "'%s': wrong bytes",
                  names[i]);
    }
    cr_assert_str_eq(setlocale(LC_CTYPE, NULL), "C", "the process's locale changed");
    got_free(&g);
    free(m.p);
}

/* A Latin-1 name (an unflagged zip, a plain tar) is delivered, flagged not
 * UTF-8, its bad byte as %HH; a name flagged UTF-8 that is not, which
 * libarchive cannot give at all, is delivered too, as "(unreadable name N)". */
Test(archive, names_that_are_not_utf8_are_delivered_and_said)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        w_file(&w, "m\xfcller.png", "1", 1);
        w_file(&w, "bob.png", "2", 1);
        membuf m = w_close(&w);
        got g = {.keep = 1};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 2, "%s: %d calls", format_names[f], g.calls);
        cr_assert_str_eq(g.names[0], "m%FCller.png", "%s", format_names[f]);
        cr_assert_not(g.utf8[0], "%s: a Latin-1 name called UTF-8", format_names[f]);
        cr_assert_str_eq(g.names[1], "bob.png");
        cr_assert(g.utf8[1]);
        got_free(&g);
        free(m.p);
    }
    /* Flagged UTF-8, and not: the name's bytes patched after writing. */
    locale_t c_utf8 = newlocale(LC_CTYPE_MASK, "C.UTF-8", (locale_t)0);
    locale_t was = uselocale(c_utf8);
    writer w;
    w_open_with(&w, ZIP, "zip:hdrcharset=UTF-8");
    w_file(&w, "m\xc3\xbcller.png", "1", 1);
    membuf m = w_close(&w);
    uselocale(was);
    freelocale(c_utf8);
    int patched = 0;
    for (size_t i = 0; i + 2 <= m.len; i++)
        if (m.p[i] == 0xc3 && m.p[i + 1] == 0xbc)
            m.p[i + 1] = 0xfc, patched++;
    cr_assert_eq(patched, 2, "the name is in the local and the central header");
    got g = {.keep = 1};
    rd_error err;
    cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s", err.message);
    cr_assert_eq(g.calls, 1, "the file was dropped");
    cr_assert_str_eq(g.names[0], "(unreadable name 1)");
    cr_assert_not(g.utf8[0]);
    got_free(&g);
    free(m.p);
}

/* A zip whose stored name holds a NUL (the writer's API cannot write one,
 * so a written name is patched in the local and central headers): the name
 * ends at the NUL. */
Test(archive, nul_in_a_name_ends_it)
{
    writer w;
    w_open(&w, ZIP);
    w_file(&w, "abcXdef.png", "data", 4);
    membuf m = w_close(&w);
    int patched = 0;
    for (size_t i = 0; i + 11 <= m.len; i++)
        if (memcmp(m.p + i, "abcXdef.png", 11) == 0) {
            m.p[i + 3] = 0;
            patched++;
        }
    cr_assert_geq(patched, 2, "local and central name");
    got g = {.keep = 1};
    rd_error err;
    rd_error_code rc = run(&m, &wide, &g, &err);
    cr_assert_eq(rc, RD_OK, "%s", err.message);
    cr_assert_eq(g.calls, 1);
    cr_assert_str_eq(g.names[0], "abc");
    got_free(&g);
    free(m.p);
}

Test(archive, empty_archives_make_no_call)
{
    for (int f = 0; f < FORMATS; f++) {
        for (int folders = 0; folders < 2; folders++) {
            writer w;
            w_open(&w, (format)f);
            if (folders) {
                w_entry(&w, "class/", AE_IFDIR, NULL, 0, NULL, NULL);
                w_entry(&w, "class/empty/", AE_IFDIR, NULL, 0, NULL, NULL);
            }
            membuf m = w_close(&w);
            got g = {0};
            rd_error err;
            cr_assert_eq(run(&m, &wide, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
            cr_assert_eq(g.calls, 0);
            free(m.p);
        }
    }
}

/* ---- limits ------------------------------------------------------------------ */

static membuf files_of(format f, int n, size_t each)
{
    unsigned char *body = malloc(each + 1);
    writer w;
    w_open(&w, f);
    for (int i = 0; i < n; i++) {
        char name[32];
        snprintf(name, sizeof name, "s%02d.png", i);
        fill_random(body, each, (uint64_t)i);
        w_file(&w, name, body, each);
    }
    free(body);
    return w_close(&w);
}

Test(archive, max_entries)
{
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 5, 10);
        rd_archive_limits lim = wide;
        lim.max_entries = 5;
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_OK, "%s: exactly at the limit: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 5);
        lim.max_entries = 4;
        memset(&g, 0, sizeof g);
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "%s", format_names[f]);
        cr_assert_eq(g.calls, 4, "%s: the files before the limit, not the one past it", format_names[f]);
        cr_assert(strstr(err.message, "max_entries"), "%s", err.message);
        lim.max_entries = 0;
        memset(&g, 0, sizeof g);
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "0 allows no file");
        cr_assert_eq(g.calls, 0);
        free(m.p);
    }
}

Test(archive, max_entry_bytes)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        unsigned char body[1000];
        fill_random(body, sizeof body, 7);
        w_file(&w, "small.png", body, 10);
        w_file(&w, "large.png", body, 1000);
        w_file(&w, "after.png", body, 10);
        membuf m = w_close(&w);
        rd_archive_limits lim = wide;
        lim.max_entry_bytes = 1000;
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_OK, "%s: exactly at the limit: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 3);
        lim.max_entry_bytes = 999;
        memset(&g, 0, sizeof g);
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "%s", format_names[f]);
        cr_assert_eq(g.calls, 1, "%s: only the file before", format_names[f]);
        cr_assert_leq(g.max_len, 999);
        cr_assert(strstr(err.message, "max_entry_bytes") && strstr(err.message, "large.png"), "%s", err.message);
        free(m.p);
    }
}

Test(archive, max_total_bytes)
{
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 3, 400);
        rd_archive_limits lim = wide;
        lim.max_total_bytes = 1200;
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_OK, "%s: exactly at the limit: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 3);
        lim.max_total_bytes = 1199;
        memset(&g, 0, sizeof g);
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "%s", format_names[f]);
        cr_assert_eq(g.calls, 2);
        cr_assert_leq(g.total, 1199);
        cr_assert(strstr(err.message, "max_total_bytes"), "%s", err.message);
        free(m.p);
    }
}

/* A bomb hidden in a skipped dot-file is decompressed to be counted. */
Test(archive, skipped_files_count_towards_max_total_bytes)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        w_file(&w, "__MACOSX/._a.png", NULL, 2u << 20);
        w_file(&w, "a.png", "a", 1);
        membuf m = w_close(&w);
        rd_archive_limits lim = wide;
        lim.max_total_bytes = 1u << 20;
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "%s", format_names[f]);
        cr_assert_eq(g.calls, 0);
        cr_assert(strstr(err.message, "max_total_bytes"), "%s", err.message);
        free(m.p);
    }
}

/* Entries without data still cost a header each: 4 x max_entries + 1024. */
Test(archive, headers_bounded_even_without_files)
{
    for (int f = 0; f < FORMATS; f++) {
        writer w;
        w_open(&w, (format)f);
        for (int i = 0; i < 1100; i++) {
            char name[32];
            snprintf(name, sizeof name, "l%04d", i);
            w_entry(&w, name, AE_IFLNK, NULL, 0, "target", NULL);
        }
        membuf m = w_close(&w);
        rd_archive_limits lim = wide;
        lim.max_entries = 19; /* 4 x 19 + 1024 = 1100 */
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        lim.max_entries = 18;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_ERR_LIMIT, "%s", format_names[f]);
        cr_assert(strstr(err.message, "max_entries"), "%s", err.message);
        cr_assert_eq(g.calls, 0);
        free(m.p);
    }
}

Test(archive, unlimited_limits_do_not_overflow)
{
    rd_archive_limits lim = {SIZE_MAX, SIZE_MAX, SIZE_MAX};
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 3, 70000);
        got g = {0};
        rd_error err;
        cr_assert_eq(run(&m, &lim, &g, &err), RD_OK, "%s: %s", format_names[f], err.message);
        cr_assert_eq(g.calls, 3);
        cr_assert_eq(g.total, 3 * 70000);
        free(m.p);
    }
}

/* ---- bombs ------------------------------------------------------------------- */

static long peak_rss_kb(void)
{
    struct rusage ru;
    cr_assert_eq(getrusage(RUSAGE_SELF, &ru), 0);
    return ru.ru_maxrss;
}

/* VmPeak in KB, or -1 where /proc does not say. */
static long peak_vm_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    long kb = -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmPeak: %ld kB", &kb) == 1)
            break;
    fclose(f);
    return kb;
}

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + ts.tv_nsec / 1e9;
}

/* Far below the 100 MB a bomb declares, far above what reading 1 MB needs
 * even with sanitizers. */
#define GROWTH_BOUND_KB (32L * 1024)

typedef struct {
    rd_error_code rc;
    rd_error err;
    got g;
    long rss_kb, vm_kb;
    double seconds;
} measured;

static measured measure(const membuf *m, const rd_archive_limits *lim)
{
    measured r;
    memset(&r, 0, sizeof r);
    long rss0 = peak_rss_kb(), vm0 = peak_vm_kb();
    double t0 = cpu_s();
    r.rc = rd_archive_each(m->p, m->len, lim, collect, &r.g, &r.err);
    r.seconds = cpu_s() - t0;
    r.rss_kb = peak_rss_kb() - rss0;
    long vm1 = peak_vm_kb();
    r.vm_kb = vm0 >= 0 && vm1 >= 0 ? vm1 - vm0 : 0;
    return r;
}

Test(archive, bomb_of_100_mb_zeros_stops_at_the_limit, .timeout = 120)
{
    const size_t bomb = (size_t)100 << 20;
    const rd_archive_limits lim = {10, (size_t)1 << 20, (size_t)4 << 20};
    for (int f = 0; f < FORMATS; f++) {
        if (f == TAR)
            continue; /* a plain tar holds its 100 MB: no bomb */
        writer w;
        w_open(&w, (format)f);
        w_file(&w, "bomb.png", NULL, bomb);
        membuf m = w_close(&w);
        cr_assert_lt(m.len, (size_t)1 << 20, "%s: %zu bytes for 100 MB of zeros", format_names[f], m.len);
        measured r = measure(&m, &lim);
        cr_assert_eq(r.rc, RD_ERR_LIMIT, "%s: %s", format_names[f], r.err.message);
        cr_assert(strstr(r.err.message, "max_entry_bytes"), "%s", r.err.message);
        cr_assert_eq(r.g.calls, 0, "%s: the bomb is never delivered", format_names[f]);
        cr_assert_lt(r.rss_kb, GROWTH_BOUND_KB, "%s: resident set grew %ld KB", format_names[f], r.rss_kb);
        cr_assert_lt(r.vm_kb, GROWTH_BOUND_KB, "%s: address space grew %ld KB", format_names[f], r.vm_kb);
        cr_assert_lt(r.seconds, 2.0, "%s: %.2f s", format_names[f], r.seconds);
        free(m.p);
    }
}

Test(archive, many_small_bombs_stop_at_the_total, .timeout = 120)
{
    const rd_archive_limits lim = {100, (size_t)16 << 20, (size_t)24 << 20};
    for (int f = 0; f < FORMATS; f++) {
        if (f == TAR)
            continue;
        writer w;
        w_open(&w, (format)f);
        for (int i = 0; i < 10; i++) {
            char name[32];
            snprintf(name, sizeof name, "b%d.png", i);
            w_file(&w, name, NULL, (size_t)10 << 20);
        }
        membuf m = w_close(&w);
        measured r = measure(&m, &lim);
        cr_assert_eq(r.rc, RD_ERR_LIMIT, "%s: %s", format_names[f], r.err.message);
        cr_assert(strstr(r.err.message, "max_total_bytes"), "%s", r.err.message);
        cr_assert_eq(r.g.calls, 2, "%s: %d calls", format_names[f], r.g.calls);
        cr_assert_leq(r.g.total, lim.max_total_bytes);
        cr_assert_lt(r.seconds, 2.0, "%s: %.2f s", format_names[f], r.seconds);
        free(m.p);
    }
}

/* The central directory's uncompressed size (offset 24 of each "PK\1\2"
 * header) set to size: what a zip declares is not what it holds. */
static void zip_declare(membuf *m, uint32_t size)
{
    int found = 0;
    for (size_t i = 0; i + 46 <= m->len; i++)
        if (memcmp(m->p + i, "PK\1\2", 4) == 0) {
            for (int b = 0; b < 4; b++)
                m->p[i + 24 + b] = (unsigned char)(size >> (8 * b));
            found++;
        }
    cr_assert_eq(found, 1);
}

Test(archive, declared_size_never_trusted, .timeout = 60)
{
    /* Declares 1000 bytes, holds 10 MB: reading stops at the limit (or at
     * the mismatch), and the callback never sees more than the limit. */
    writer w;
    w_open(&w, ZIP);
    w_file(&w, "liar.png", NULL, (size_t)10 << 20);
    membuf m = w_close(&w);
    zip_declare(&m, 1000);
    const rd_archive_limits lim = {10, (size_t)1 << 20, (size_t)4 << 20};
    measured r = measure(&m, &lim);
    cr_assert_neq(r.rc, RD_OK, "10 MB declared as 1000 bytes");
    cr_assert(r.rc == RD_ERR_LIMIT || r.rc == RD_ERR_SYNTAX, "%s: %s", rd_error_name(r.rc), r.err.message);
    cr_assert_leq(r.g.max_len, lim.max_entry_bytes);
    cr_assert_lt(r.rss_kb, GROWTH_BOUND_KB, "resident set grew %ld KB", r.rss_kb);
    free(m.p);

    /* Declares nearly 4 GB, holds 1000 bytes: nothing of that size is
     * allocated, even with no limit. */
    w_open(&w, ZIP);
    unsigned char body[1000];
    fill_random(body, sizeof body, 3);
    w_file(&w, "liar.png", body, sizeof body);
    m = w_close(&w);
    zip_declare(&m, 0xfffffff0u);
    const rd_archive_limits none = {SIZE_MAX, SIZE_MAX, SIZE_MAX};
    r = measure(&m, &none);
    cr_assert_lt(r.vm_kb, GROWTH_BOUND_KB, "address space grew %ld KB (%s)", r.vm_kb, rd_error_name(r.rc));
    cr_assert_leq(r.g.max_len, sizeof body);
    free(m.p);
}

/* ---- damaged and foreign input ------------------------------------------------ */

Test(archive, truncated_archives_are_errors)
{
    for (int f = 0; f < FORMATS; f++) {
        /* Incompressible, so the cut falls inside the second file's data. */
        membuf m = files_of((format)f, 3, 10000);
        membuf cut = m;
        cut.len = m.len / 2;
        got g = {0};
        rd_error err;
        rd_error_code rc = run(&cut, &wide, &g, &err);
        cr_assert_eq(rc, RD_ERR_SYNTAX, "%s cut at %zu of %zu: %s (%s)", format_names[f], cut.len, m.len,
                     rd_error_name(rc), err.message);
        /* The first file is delivered, but from a gzip stream cut short
         * libarchive may refuse the whole block it was decompressing. */
        if (f == TGZ)
            cr_assert_leq(g.calls, 1, "%s: %d calls", format_names[f], g.calls);
        else
            cr_assert_eq(g.calls, 1, "%s: the file before the cut, %d calls", format_names[f], g.calls);
        free(m.p);
    }
}

/* Cut anywhere: an error or fewer files, each delivered file whole. A
 * tar's cuts go in steps of 7 bytes (every offset within a 512-byte block
 * comes round) up to its end-of-archive blocks. */
Test(archive, every_cut_an_error_or_whole_files, .timeout = 120)
{
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 3, 200);
        got full = {0};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &full, &err), RD_OK);
        size_t end = f == TAR ? 3 * 1024 + 512 : m.len, step = f == TAR ? 7 : 1;
        for (size_t n = 0; n < end; n += step) {
            membuf cut = {m.p, n, n};
            got g = {0};
            rd_error_code rc = run(&cut, &wide, &g, &err);
            cr_assert(rc == RD_OK || rc == RD_ERR_SYNTAX || rc == RD_ERR_UNSUPPORTED, "%s cut at %zu: %s",
                      format_names[f], n, rd_error_name(rc));
            cr_assert_leq(g.calls, 3);
            for (int i = 0; i < g.calls; i++)
                cr_assert(g.len[i] == full.len[i] && g.hash[i] == full.hash[i],
                          "%s cut at %zu: file %d delivered damaged", format_names[f], n, i);
        }
        free(m.p);
    }
}

/* One byte changed, in turn, through the headers and data (a tar's first
 * two entries, every third byte): any answer but a crash. */
Test(archive, damaged_bytes_never_crash, .timeout = 120)
{
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 3, 100);
        unsigned char *copy = malloc(m.len);
        size_t end = f == TAR ? 2048 : m.len, step = f == TAR ? 3 : 1;
        for (size_t i = 0; i < end; i += step) {
            memcpy(copy, m.p, m.len);
            copy[i] ^= i % 2 ? 0xff : 0x01;
            membuf d = {copy, m.len, m.len};
            got g = {0};
            rd_error err;
            run(&d, &wide, &g, &err);
            cr_assert_leq(g.calls, 3);
        }
        free(copy);
        free(m.p);
    }
}

Test(archive, random_bytes_are_errors)
{
    static const char *const prefixes[] = {"", "PK\3\4", "\x1f\x8b\x08", "PK\5\6"};
    test_rng rng = {42};
    unsigned char buf[4096];
    for (int t = 0; t < 400; t++) {
        const char *pre = prefixes[t % 4];
        size_t n = 1 + (size_t)rng_int(&rng, (int)sizeof buf);
        fill_random(buf, n, rng_u64(&rng));
        size_t k = strlen(pre) < n ? strlen(pre) : n;
        memcpy(buf, pre, k);
        membuf m = {buf, n, n};
        got g = {0};
        rd_error err;
        rd_error_code rc = run(&m, &wide, &g, &err);
        /* An end-of-central-directory record first is an empty zip: what
         * follows it is not read. */
        int empty_zip = t % 4 == 3 && n >= 4;
        cr_assert(rc == RD_ERR_UNSUPPORTED || rc == RD_ERR_SYNTAX || (empty_zip && rc == RD_OK),
                  "%zu random bytes after '%s': %s", n, pre, rd_error_name(rc));
        cr_assert_eq(g.calls, 0);
    }
}

Test(archive, other_formats_unsupported)
{
    rd_error err;
    got g = {0};
    membuf m = {(unsigned char *)"", 0, 0};
    cr_assert_eq(run(&m, &wide, &g, &err), RD_ERR_UNSUPPORTED, "empty input: %s", err.message);

    static const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
    m = (membuf){(unsigned char *)png, sizeof png, sizeof png};
    cr_assert_eq(run(&m, &wide, &g, &err), RD_ERR_UNSUPPORTED, "a PNG: %s", err.message);

    /* cpio, 7-Zip, a tar through bzip2 and xz, a gzip stream of a PNG: all
     * written by libarchive, none read. */
    enum { CPIO, SEVENZIP, TBZ, TXZ, GZ_RAW, KINDS };
    static const char *const kinds[KINDS] = {"cpio", "7z", "tar.bz2", "tar.xz", "gzip of a PNG"};
    for (int k = 0; k < KINDS; k++) {
        struct archive *a = archive_write_new();
        membuf out = {0};
        int st = k == CPIO       ? archive_write_set_format_cpio_newc(a)
                 : k == SEVENZIP ? archive_write_set_format_7zip(a)
                 : k == GZ_RAW   ? archive_write_set_format_raw(a)
                                 : archive_write_set_format_pax_restricted(a);
        if (st == ARCHIVE_OK && k == TBZ)
            st = archive_write_add_filter_bzip2(a);
        if (st == ARCHIVE_OK && k == TXZ)
            st = archive_write_add_filter_xz(a);
        if (st == ARCHIVE_OK && k == GZ_RAW)
            st = archive_write_add_filter_gzip(a);
        if (st != ARCHIVE_OK) {
            cr_log_warn("libarchive cannot write %s here: not tested", kinds[k]);
            archive_write_free(a);
            continue;
        }
        cr_assert_eq(archive_write_open(a, &out, NULL, mem_write, NULL), ARCHIVE_OK);
        struct archive_entry *e = archive_entry_new();
        archive_entry_copy_pathname(e, "a.png");
        archive_entry_set_filetype(e, AE_IFREG);
        archive_entry_set_perm(e, 0644);
        archive_entry_set_size(e, sizeof png);
        cr_assert_eq(archive_write_header(a, e), ARCHIVE_OK, "%s: %s", kinds[k], archive_error_string(a));
        cr_assert_eq(archive_write_data(a, png, sizeof png), (la_ssize_t)sizeof png);
        archive_entry_free(e);
        cr_assert_eq(archive_write_close(a), ARCHIVE_OK, "%s: %s", kinds[k], archive_error_string(a));
        archive_write_free(a);
        memset(&g, 0, sizeof g);
        rd_error_code rc = run(&out, &wide, &g, &err);
        cr_assert_eq(rc, RD_ERR_UNSUPPORTED, "%s: %s (%s)", kinds[k], rd_error_name(rc), err.message);
        cr_assert_eq(g.calls, 0);
        free(out.p);
    }
}

Test(archive, encrypted_zip_unsupported)
{
    writer w;
    memset(&w, 0, sizeof w);
    w.a = archive_write_new();
    archive_write_set_format_zip(w.a);
    if (archive_write_set_options(w.a, "zip:encryption=zipcrypt") != ARCHIVE_OK ||
        archive_write_set_passphrase(w.a, "secret") != ARCHIVE_OK) {
        archive_write_free(w.a);
        cr_skip_test("libarchive cannot write an encrypted zip here");
    }
    cr_assert_eq(archive_write_open(w.a, &w.out, NULL, mem_write, NULL), ARCHIVE_OK);
    w_file(&w, "secret.png", "hidden bytes", 12);
    membuf m = w_close(&w);
    got g = {0};
    rd_error err;
    cr_assert_eq(run(&m, &wide, &g, &err), RD_ERR_UNSUPPORTED, "%s", err.message);
    cr_assert(strstr(err.message, "encrypted"), "%s", err.message);
    cr_assert_eq(g.calls, 0);
    free(m.p);
}

/* Zips whose a.png ("hello") is compressed with bzip2 (method 12) and
 * LZMA (method 14), as Python's zipfile writes them (libarchive 3.6 writes
 * only stored and deflated zips). The LZMA one's properties (bytes 39 to
 * 43: lc/lp/pb, then the dictionary size) ask for a dictionary of
 * 0xf0000000 bytes, which liblzma would allocate as reading starts. */
static const unsigned char zip_bzip2[] =
    "\x50\x4b\x03\x04\x2e\x00\x00\x00\x0c\x00\x00\x00\x21\x58\x86\xa6\x10\x36\x29\x00\x00\x00\x05\x00\x00\x00\x05"
    "\x00\x00\x00\x61\x2e\x70\x6e\x67\x42\x5a\x68\x39\x31\x41\x59\x26\x53\x59\x19\x31\x65\x3d\x00\x00\x00\x81\x00"
    "\x02\x44\xa0\x00\x21\x9a\x68\x33\x4d\x07\x33\x8b\xb9\x22\x9c\x28\x48\x0c\x98\xb2\x9e\x80\x50\x4b\x01\x02\x2e"
    "\x03\x2e\x00\x00\x00\x0c\x00\x00\x00\x21\x58\x86\xa6\x10\x36\x29\x00\x00\x00\x05\x00\x00\x00\x05\x00\x00\x00"
    "\x00\x00\x00\x00\x00\x00\x00\x00\x80\x01\x00\x00\x00\x00\x61\x2e\x70\x6e\x67\x50\x4b\x05\x06\x00\x00\x00\x00"
    "\x01\x00\x01\x00\x33\x00\x00\x00\x4c\x00\x00\x00\x00\x00";
static const unsigned char zip_lzma_4gb[] =
    "\x50\x4b\x03\x04\x3f\x00\x02\x00\x0e\x00\x00\x00\x21\x58\x86\xa6\x10\x36\x18\x00\x00\x00\x05\x00\x00\x00\x05"
    "\x00\x00\x00\x61\x2e\x70\x6e\x67\x09\x04\x05\x00\x5d\x00\x00\x00\xf0\x00\x34\x19\x49\xee\x8e\x68\x21\xff\xff"
    "\xff\xb9\xe0\x00\x00\x50\x4b\x01\x02\x3f\x03\x3f\x00\x02\x00\x0e\x00\x00\x00\x21\x58\x86\xa6\x10\x36\x18\x00"
    "\x00\x00\x05\x00\x00\x00\x05\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x01\x00\x00\x00\x00\x61\x2e\x70"
    "\x6e\x67\x50\x4b\x05\x06\x00\x00\x00\x00\x01\x00\x01\x00\x33\x00\x00\x00\x3b\x00\x00\x00\x00\x00";

Test(archive, zip_methods_but_deflate_unsupported)
{
    membuf m = {(unsigned char *)zip_bzip2, sizeof zip_bzip2 - 1, sizeof zip_bzip2 - 1};
    got g = {0};
    rd_error err;
    cr_assert_eq(run(&m, &wide, &g, &err), RD_ERR_UNSUPPORTED, "bzip2: %s", err.message);
    cr_assert(strstr(err.message, "bzip") && strstr(err.message, "a.png"), "%s", err.message);
    cr_assert_eq(g.calls, 0);

    m = (membuf){(unsigned char *)zip_lzma_4gb, sizeof zip_lzma_4gb - 1, sizeof zip_lzma_4gb - 1};
    measured r = measure(&m, &wide);
    cr_assert_eq(r.rc, RD_ERR_UNSUPPORTED, "lzma: %s", r.err.message);
    cr_assert(strstr(r.err.message, "lzma"), "%s", r.err.message);
    cr_assert_eq(r.g.calls, 0);
    cr_assert_lt(r.vm_kb, GROWTH_BOUND_KB, "address space grew %ld KB", r.vm_kb);
}

/* ---- the callback and the arguments -------------------------------------------- */

Test(archive, callback_error_returned_as_is)
{
    static const rd_error_code codes[] = {RD_ERR_INVALID, RD_ERR_CANCELLED, RD_ERR_IO};
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 5, 10);
        for (size_t c = 0; c < sizeof codes / sizeof codes[0]; c++) {
            got g = {.stop_after = 2, .stop_code = codes[c]};
            rd_error err;
            memset(&err, 0, sizeof err);
            rd_error_code rc = rd_archive_each(m.p, m.len, &wide, collect, &g, &err);
            cr_assert_eq(rc, codes[c], "%s: %s", format_names[f], rd_error_name(rc));
            cr_assert_eq(g.calls, 2, "reading stops at the callback's error");
            cr_assert_str_eq(err.message, "the callback stopped at 's01.png'");
        }
        free(m.p);
    }
}

Test(archive, null_arguments_invalid)
{
    membuf m = files_of(ZIP, 1, 10000);
    got g = {0};
    rd_error err;
    cr_assert_eq(rd_archive_each(m.p, m.len, NULL, collect, &g, &err), RD_ERR_INVALID);
    cr_assert_eq(rd_archive_each(m.p, m.len, &wide, NULL, &g, &err), RD_ERR_INVALID);
    cr_assert_eq(rd_archive_each(NULL, 10, &wide, collect, &g, &err), RD_ERR_INVALID);
    cr_assert_eq(rd_archive_each(NULL, 0, &wide, collect, &g, &err), RD_ERR_UNSUPPORTED, "nothing is no archive");
    cr_assert_eq(rd_archive_each(m.p, m.len, &wide, collect, &g, NULL), RD_OK, "err may be NULL");
    cr_assert_eq(rd_archive_each(m.p, m.len / 2, &wide, collect, &g, NULL), RD_ERR_SYNTAX);
    free(m.p);
}

/* Every allocation of the reader failed in turn (tests/support/fault_alloc.h;
 * libarchive's own are not): RD_ERR_NOMEM or the whole result, and nothing
 * left allocated. */
Test(archive, out_of_memory_at_every_allocation)
{
    for (int f = 0; f < FORMATS; f++) {
        membuf m = files_of((format)f, 3, 150000);
        got want = {0};
        rd_error err;
        cr_assert_eq(run(&m, &wide, &want, &err), RD_OK);
        long points = 0;
        for (long k = 1;; k++) {
            for (int persist = 0; persist < 2; persist++) {
                got g = {0};
                long live = rd_fault_live();
                rd_fault_arm(k, persist);
                rd_error_code rc = rd_archive_each(m.p, m.len, &wide, collect, &g, &err);
                long injected = rd_fault_injected();
                rd_fault_disarm();
                cr_assert_eq(rd_fault_live(), live, "%s, allocation %ld: %ld blocks left", format_names[f], k,
                             rd_fault_live() - live);
                if (rc == RD_OK) {
                    cr_assert_eq(g.calls, 3);
                    for (int i = 0; i < 3; i++)
                        cr_assert_eq(g.hash[i], want.hash[i]);
                } else {
                    cr_assert_eq(rc, RD_ERR_NOMEM, "%s, allocation %ld: %s", format_names[f], k, err.message);
                    cr_assert(strstr(err.message, "memory"), "%s", err.message);
                }
                if (!persist && injected == 0)
                    goto done;
            }
            points++;
        }
    done:
        cr_assert_gt(points, 0, "%s: the reader allocates", format_names[f]);
        free(m.p);
    }
}

/* The names' rendering (api/util/utf8.h), as a batch shows a name that is
 * not UTF-8: each bad byte %HH, control characters '_', cut at a
 * character within the room. */
Test(archive, names_rendered_readable)
{
    static const struct {
        const char *in;
        size_t size;
        const char *out;
        int utf8;
    } cases[] = {
        {"m\xfcller", 64, "m%FCller", 0},
        {"m\xc3\xbcller", 64, "m\xc3\xbcller", 1},
        {"a\tb\x7f", 64, "a_b_", 1},
        {"\xe6\x9d\x8e\xe9\x9b\xb7", 5, "\xe6\x9d\x8e", 1},
        {"ab\xff", 5, "ab", 0},
        {"\xc3\x28", 64, "%C3(", 0},
        {"", 1, "", 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char out[64];
        int utf8 = rd_utf8_readable(cases[i].in, strlen(cases[i].in), out, cases[i].size);
        cr_assert_str_eq(out, cases[i].out, "case %zu", i);
        cr_assert_eq(utf8, cases[i].utf8, "case %zu", i);
        cr_assert_lt(strlen(out), cases[i].size);
    }
}
