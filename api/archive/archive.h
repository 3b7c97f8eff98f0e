/* Reading the files of an uploaded archive in memory, with libarchive: a
 * .zip (entries stored or deflated, what zip tools write by default), or a
 * .tar optionally gzip-compressed (.tar.gz, .tgz). Instructors upload a
 * class's images as one archive (POST /v1/grade/batch); every byte of it
 * is untrusted, so what reading costs is bounded by the limits below,
 * never by what the archive's headers declare, and nothing is written to
 * disk. */
#ifndef RD_ARCHIVE_H
#define RD_ARCHIVE_H

#include <stddef.h>

#include "rayd/error.h"

/* The longest name handed to the callback, in bytes (NAME_MAX on Linux);
 * the name buffer holds one more for the NUL. */
#define RD_ARCHIVE_NAME_MAX 255

/* Each limit is exact: 0 allows nothing, SIZE_MAX removes the limit. */
typedef struct {
    size_t max_entries;     /* files (not folders) delivered at most; more: RD_ERR_LIMIT */
    size_t max_entry_bytes; /* one delivered file's decompressed bytes at most */
    size_t max_total_bytes; /* all files' decompressed bytes at most, skipped ones included (a zip bomb) */
} rd_archive_limits;

/* The callback: one regular file of the archive. name is its reduced base
 * name (below), at most RD_ARCHIVE_NAME_MAX bytes, NUL-terminated, always
 * UTF-8; utf8 is 0 when the name stored in the archive was not (its bytes
 * are shown as %HH, below), so that the caller can say so; data
 * holds its len decompressed bytes (never NULL, even when len is 0). Both
 * belong to rd_archive_each and are valid during the call only: copy what
 * is kept. err is the one given to rd_archive_each. Returning anything but
 * RD_OK stops the reading, and rd_archive_each returns that code as is
 * (the callback fills err as it sees fit). */
typedef rd_error_code (*rd_archive_file_fn)(void *user, const char *name, int utf8, const unsigned char *data,
                                            size_t len, rd_error *err);

/* Calls each(user, name, data, len, err) for every regular file of the len
 * bytes at data (which stay the caller's and are only read), in archive
 * order. The format is sniffed by libarchive from the bytes, whatever the
 * upload was called.
 *
 * Delivered: regular files only. Folders, symbolic links, hard links,
 * devices, FIFOs and sockets are skipped, and so are entries with any path
 * component named __MACOSX or starting with '.' (other than "." and ".."):
 * dot-files such as the AppleDouble ._x.png and .DS_Store, and everything
 * in hidden folders.
 *
 * Names: an entry's path is untrusted. It is reduced to its last component
 * ('/' and '\' both separate components, so "../", absolute paths and
 * C:\ go with the folders), control characters (below 0x20, 0x7f) each
 * become '_', each byte that is not UTF-8 becomes the three characters
 * %HH (its value in hex, as in a URL: m%FCller.png for a Latin-1 ü; the
 * callback's utf8 is then 0), and the result is
 * cut to RD_ARCHIVE_NAME_MAX bytes at a character boundary. Zip names
 * flagged UTF-8 (bit 11, as Python, 7-Zip, Windows and macOS write them)
 * and pax tar names are read as UTF-8 whatever the process's locale;
 * unflagged zip names and plain tar names are taken as the bytes they are
 * (a Latin-1 name is not UTF-8). A name flagged UTF-8 that is not cannot
 * be read at all: the file is delivered as "(unreadable name N)", N its
 * 1-based place among the delivered files, with utf8 0. A NUL inside a
 * stored name ends it (libarchive's names are C strings). A file whose
 * name reduces to nothing ("", ".", "..") is skipped. Names are not made
 * unique: two folders may both hold a.png, and each gets its call.
 *
 * Limits (lim, required), all enforced while decompressing: data is read
 * in blocks with archive_read_data, an entry's declared size is never
 * trusted and never allocated up front, and memory grows only with the
 * bytes actually read (at most max_entry_bytes + 1 for the file being
 * read, plus libarchive's own buffers; for a zip, libarchive also keeps
 * its central directory, in proportion to len). A delivered file over
 * max_entry_bytes, files over max_entries, or all files' bytes over
 * max_total_bytes (the data of skipped entries is decompressed to count it,
 * so that a bomb cannot hide in a dot-file) stop the reading with
 * RD_ERR_LIMIT and a message naming the limit (max_entries,
 * max_entry_bytes, max_total_bytes); the callback never sees the file that
 * passed it. Entries of every kind are also bounded in number, at
 * 4 * max_entries + 1024 headers, because each costs time to read even
 * without data (RD_ERR_LIMIT naming max_entries).
 *
 * Returns RD_OK once every entry was read (an archive without files makes
 * no call), or the first of:
 *   RD_ERR_UNSUPPORTED  not a zip or a tar (an empty input, random bytes, a
 *                       gzip stream that does not hold a tar, any other
 *                       format, other compressions: bzip2, xz), an
 *                       encrypted entry, or a zip entry compressed by a
 *                       method other than deflate (bzip2, LZMA, xz, zstd,
 *                       PPMd: their decoders take as much memory as the
 *                       archive asks, and an LZMA header of a few bytes
 *                       asks for 4 GB), refused before it is decompressed;
 *   RD_ERR_SYNTAX       a damaged archive: truncated, a bad checksum, a
 *                       broken header or compressed stream, with
 *                       libarchive's reason; files before the damage have
 *                       already been delivered;
 *   RD_ERR_LIMIT        a limit passed, as above;
 *   RD_ERR_NOMEM        out of memory;
 *   RD_ERR_INVALID      lim or each NULL, or data NULL with len > 0;
 *   the callback's own code, returned as is.
 * err (may be NULL) is filled for every code but the callback's. Nothing is
 * left allocated whatever the outcome. Thread-safe: it keeps no state
 * between calls. The calling thread's locale is C.UTF-8 (uselocale) while
 * it reads, the callback's calls included, and is given back before it
 * returns; the process's locale (setlocale) is never changed. No C.UTF-8
 * locale on the machine is RD_ERR_UNSUPPORTED. */
rd_error_code rd_archive_each(const void *data, size_t len, const rd_archive_limits *lim, rd_archive_file_fn each,
                              void *user, rd_error *err);

#endif
